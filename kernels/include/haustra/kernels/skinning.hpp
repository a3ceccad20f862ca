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
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <cstdint>
#include <span>

#include "haustra/kernels/cage_rings.hpp"

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

// The along-rod skin's screw (decision 0122). Between two stations a and b of a rod the section's
// strain is constant, so the frame between them is the screw T(t) = T_a exp(t log(T_a⁻¹ T_b)):
// rotation about a fixed axis ω by tθ and translation t·d along it. In T_a's frame, with P the
// part of T_a⁻¹T_b's translation across ω and Q = ω × P,
//   T_a⁻¹ T(t) o = Rot(ω, tθ) o + κ_P P + κ_Q Q + t d ω,
//   κ_P = ½(1 − cos φ) + t c sinc φ,  κ_Q = φ (t c cosc φ − ½ sinc φ),  φ = tθ,
// c = (θ/2) cot(θ/2), sinc φ = sin φ / φ, cosc φ = (1 − cos φ) / φ²: no division by θ, so θ → 0
// is the straight line T_a + t (c_b − c_a) and θ = π (the shortest turn's largest) is finite.
struct Screw {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // T_a
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();   // ω, in T_a's frame
  Eigen::Vector3d across = Eigen::Vector3d::Zero();  // P
  Eigen::Vector3d turned = Eigen::Vector3d::Zero();  // Q = ω × P
  double angle = 0.0, cot = 1.0, along = 0.0;        // θ in [0, π], c, d
};
Screw screw_between(const RingPose& a, const RingPose& b);
// T(t), in double.
RingPose screw_pose(const Screw& s, double t);

// Per station g of `station` (in arc order) the screw to station g + 1 (the last: to itself), as
// kScrewFloats floats, six rows of four: [R_a | c_a] (3 rows), [ω | θ], [P | c], [Q | d]. What the
// along-rod kernels below and the host's shader (render/shaders/haustra_skin.glsl) read.
inline constexpr std::size_t kScrewFloats = 24;
// A frame's ring scratch on the CPU: per ring its delta (kRingDeltaFloats, every ring), then per
// ring a screw (kScrewFloats, the along-rod skin's stations), in two runs.
inline constexpr std::size_t kRingScratchFloats = kRingDeltaFloats + kScrewFloats;
void screw_frame(std::span<const RingPose> station, std::span<float> out);

// One point and one direction carried by a screw's floats (screw_frame) at fraction t, in double
// (std::sin, std::cos; the limit as θ → 0 below 1e-6): position T(t) o, direction R(t) n.
struct ScrewPoint {
  Eigen::Vector3d position, direction;
};
inline ScrewPoint screw_point(const float* f, double t, const Eigen::Vector3d& o, const Eigen::Vector3d& n) {
  Eigen::Matrix3d r;
  Eigen::Vector3d c, w, p, q;
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) r(a, b) = f[4 * a + b];
    c[a] = f[4 * a + 3], w[a] = f[12 + a], p[a] = f[16 + a], q[a] = f[20 + a];
  }
  const double theta = f[15], cot = f[19], along = f[23], phi = t * theta;
  // (I − Rot φ) times the axis point ½P + ½cot(θ/2) Q; its limit t P as θ → 0.
  const bool turns = theta > 1e-6;
  const double half_cot = turns ? cot / theta : 0.5;  // ½ cot(θ/2)
  const double kp = turns ? 0.5 * (1.0 - std::cos(phi)) + std::sin(phi) * half_cot : t;
  const double kq = turns ? (1.0 - std::cos(phi)) * half_cot - 0.5 * std::sin(phi) : 0.0;
  const Eigen::AngleAxisd turn(phi, w.normalized());
  return {r * (turn * o + kp * p + kq * q + t * along * w) + c, r * (turn * n)};
}

// The along-rod skin: blocks of kSkinLanes vertices on one station pair each (one slot a block:
// ring = the pair's first station, coefficients per lane t, ox, oy, oz — the fraction along the
// pair and the rest offset in the rest frame T_rest(t)): x = T(t) o. screw: kScrewFloats a ring.
void skin_screw(const SkinBindingView& binding, std::span<const float> screw, std::size_t first, std::size_t count,
                const FloatVec3Out& out);
// Reference: the same, vertex by vertex in double, the rotation by Eigen's angle-axis and the
// translation's coefficients by std::sin and std::cos.
void skin_screw_reference(const SkinBindingView& binding, std::span<const float> screw, const FloatVec3Out& out);

}  // namespace haustra::kernels
