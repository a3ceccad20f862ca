#pragma once
// The organ meshes' binding as buffers a host's GPU skins from (docs/skinning.md, "Skinning on the
// host's GPU"; decision 0110): per vertex its rest position and normal and a range of slots, per slot
// a ring and its four coefficients (an along-rod vertex: its screw), per frame kGpuRingDataFloats
// floats a ring. A vertex shader
// (render/shaders/haustra_skin.glsl) computes what the CPU's skinning does; gpu_skin_vertex below
// is the same sum on the CPU, for a host's picking and for tests.
#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <vector>

#include "haustra/kernels/cage_rings.hpp"
#include "haustra/kernels/skinning.hpp"

namespace haustra {

inline constexpr std::size_t kGpuRingFloats = kernels::kGpuRingFloats;
// A frame's ring data (since ABI 17): kGpuRingFloats a ring of the rings' rows, then kGpuRingFloats
// a ring of screws (kernels::screw_frame: the along-rod skin's stations; zeros for the other rings).
inline constexpr std::size_t kGpuRingDataFloats = 2 * kGpuRingFloats;
static_assert(kernels::kScrewFloats == kGpuRingFloats);
// A slot whose ring has this bit is an along-rod vertex's screw (decision 0122): the rest of its
// ring is where its screw sits in the ring data (rings + the pair's first station), and it takes
// two slots' coefficients, (t, ox, oy, oz) then (w, nx, ny, nz) — its fraction along the pair, its
// rest offset and rest normal in the screw's rest frame, and its weight (1, or 1/n on a chain's cut).
inline constexpr std::uint32_t kGpuScrewSlot = 0x80000000U;

struct GpuSkinBinding {
  std::size_t vertices = 0;               // World::mesh_buffer_size(): indexed as mesh_positions
  std::size_t rings = 0;                  // World::ring_count(): all segments' cage rings
  std::uint32_t max_slots = 0;            // the most slots a vertex has
  std::vector<float> rest_position;       // 3 a vertex (x y z), the curved rest pose
  std::vector<float> rest_normal;         // 3 a vertex: the CPU's normals at rest (zero: no normals)
  std::vector<std::uint32_t> slot_range;  // 2 a vertex: its first slot and how many
  std::vector<std::uint32_t> slot_ring;   // a slot: the ring (0 .. rings − 1), or a screw (kGpuScrewSlot)
  std::vector<float> slot_coefficient;    // 4 a slot: b, Ax, Ay, Az (a screw's: see kGpuScrewSlot)
  // The rigid-group form alone, for hosts before ABI 17 (their shader has no screw): the along-rod
  // vertices on their two stations, weights linear along the pair (decision 0117's skin). Empty
  // when no mesh skins along the rod (the arrays above are then the same).
  std::uint32_t linear_max_slots = 0;
  std::vector<std::uint32_t> linear_slot_range, linear_slot_ring;
  std::vector<float> linear_slot_coefficient;
  [[nodiscard]] std::size_t slots() const { return slot_ring.size(); }
};

// What the shader computes for vertex v, on the CPU (in double), from a frame's ring data
// (kGpuRingDataFloats × rings): in the rigid-group form x' = x + Σ_s [ΔR_g A_s + b_s Δc_g] and
// n' = cof(I + Σ_s b_s (R'_g − R_g) R_gᵀ) n; along the rod x' = Σ w T(t) o and n' = Σ w R(t) n;
// the normal normalized.
struct GpuSkinned {
  Eigen::Vector3d position, normal;
};
inline GpuSkinned gpu_skin_vertex(const GpuSkinBinding& b, std::span<const float> ring_frame, std::size_t v) {
  Eigen::Vector3d d = Eigen::Vector3d::Zero(), screw_x = Eigen::Vector3d::Zero(), screw_n = Eigen::Vector3d::Zero();
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  bool screw = false;
  const std::uint32_t first = b.slot_range[2 * v], count = b.slot_range[2 * v + 1];
  for (std::uint32_t s = first; s < first + count; ++s) {
    const float* c = b.slot_coefficient.data() + 4 * std::size_t{s};
    if ((b.slot_ring[s] & kGpuScrewSlot) != 0) {
      const float* e = c + 4;  // the second slot: weight and rest normal
      const kernels::ScrewPoint p =
          kernels::screw_point(ring_frame.data() + kGpuRingFloats * (b.slot_ring[s] & ~kGpuScrewSlot), c[0],
                               Eigen::Vector3d(c[1], c[2], c[3]), Eigen::Vector3d(e[1], e[2], e[3]));
      screw_x += double(e[0]) * p.position;
      screw_n += double(e[0]) * p.direction;
      screw = true;
      ++s;
      continue;
    }
    const float* t = ring_frame.data() + kGpuRingFloats * b.slot_ring[s];
    const double a[4] = {c[1], c[2], c[3], c[0]};  // Ax Ay Az b
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 4; ++k) d[r] += double(t[4 * r + k]) * a[k];
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 3; ++k) m(r, k) += double(c[0]) * t[12 + 4 * r + k];
  }
  if (screw) return {screw_x, screw_n.norm() > 0.0 ? Eigen::Vector3d(screw_n.normalized()) : Eigen::Vector3d::Zero()};
  const Eigen::Vector3d x(b.rest_position[3 * v], b.rest_position[3 * v + 1], b.rest_position[3 * v + 2]);
  const Eigen::Vector3d n(b.rest_normal[3 * v], b.rest_normal[3 * v + 1], b.rest_normal[3 * v + 2]);
  // Rows of the cofactor matrix, det(M) M^-T: a normal under the linear map M.
  const Eigen::Vector3d r0 = m.row(0), r1 = m.row(1), r2 = m.row(2);
  const Eigen::Vector3d turned(r1.cross(r2).dot(n), r2.cross(r0).dot(n), r0.cross(r1).dot(n));
  return {x + d, turned.norm() > 0.0 ? Eigen::Vector3d(turned.normalized()) : Eigen::Vector3d::Zero()};
}

}  // namespace haustra
