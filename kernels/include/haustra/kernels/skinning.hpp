#pragma once
// Skinning the organ mesh from the cage rings.
//
// Mean value coordinates bind a mesh vertex x to the cage vertices p_j: x = Σ w_j p_j. Every cage
// vertex moves rigidly with its ring g (p_j = c_g + R_g o_j), so the sum regroups by ring:
//   x' = x + Σ_g [ (R'_g − R_g) A_g + b_g (c'_g − c_g) ],  b_g = Σ_{j∈g} w_j,  A_g = Σ_{j∈g} w_j o_j.
// That is the rigid-group form: 4 floats per (vertex, ring) and a 3×4 delta per ring, applied in
// displacement form so that the rest pose is reproduced exactly whatever rings are kept. Linear
// blend skinning has the same shape (b_g its joint weights, A_g = b_g R_gᵀ(x − c_g)), so one
// kernel serves both.
//
// Layout: vertices in blocks of kSkinLanes that share the same rings (the binding sorts vertices by
// their ring set, so a ring's delta is broadcast to all lanes and the sum is plain 8-wide FMAs, no
// gathers); a block has as many slots as its vertices keep rings (slot_start: offsets, so blocks
// that need more rings pay for them alone); per slot one ring index and 4 × kSkinLanes
// coefficients (b, Ax, Ay, Az), lane-contiguous; per lane the mesh vertex it writes (kNoVertex for
// padding).
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <span>

namespace haustra::kernels {

inline constexpr std::size_t kSkinLanes = 8;
inline constexpr std::size_t kSkinCoefficients = 4;  // b, Ax, Ay, Az
inline constexpr std::uint32_t kNoVertex = 0xFFFFFFFFU;

struct SkinBindingView {
  std::span<const std::uint32_t> slot_start;      // blocks + 1: block b's slots are [start[b], start[b + 1])
  std::span<const float> rest_x, rest_y, rest_z;  // blocks × kSkinLanes
  std::span<const std::uint32_t> vertex;          // blocks × kSkinLanes: output index, or kNoVertex
  std::span<const std::uint32_t> ring;            // per slot
  std::span<const float> coefficient;             // per slot: 4 × kSkinLanes
  [[nodiscard]] std::size_t blocks() const { return rest_x.size() / kSkinLanes; }
};

struct FloatVec3Out {
  std::span<float> x, y, z;  // indexed by mesh vertex
};

// Blocks [first, first + count) of the binding; ring_delta: kRingDeltaFloats per ring.
void skin_rigid_groups(const SkinBindingView& binding, std::span<const float> ring_delta, std::size_t first,
                       std::size_t count, const FloatVec3Out& out);

// Reference: the same sum, vertex by vertex and slot by slot, accumulated in double.
void skin_rigid_groups_reference(const SkinBindingView& binding, std::span<const float> ring_delta,
                                 const FloatVec3Out& out);

// Reference of the binding itself: the plain sparse product over cage vertices (CSR rows of
// (cage vertex, weight)), in double and displacement form: x' = x + Σ_j w_j (p'_j − p_j).
void skin_csr_reference(std::span<const std::uint32_t> row_start, std::span<const std::uint32_t> column,
                        std::span<const double> weight, std::span<const Eigen::Vector3d> rest_mesh,
                        std::span<const Eigen::Vector3d> rest_cage, std::span<const Eigen::Vector3d> cage,
                        std::span<Eigen::Vector3d> out);

}  // namespace haustra::kernels
