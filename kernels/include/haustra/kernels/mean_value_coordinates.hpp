#pragma once
// Mean value coordinates of a point with respect to a closed triangle cage (Ju, Schaefer and
// Warren 2005): weights w_j ≥ … summing to 1 with Σ w_j p_j = x (linear precision), smooth inside,
// exact barycentric coordinates on a face and interpolating at the vertices.
//
// Per triangle the point sees a spherical triangle with unit directions u_i and edge angles β_k;
// its mean vector m = ½ Σ β_k ν_k (ν_k the unit normal of the plane through the point and edge k)
// is split along the u_i: λ_i = ((u_{i+1} × u_{i+2}) · m) / det(u_0, u_1, u_2), w_i += λ_i / d_i.
// That form never takes sqrt(1 − c²) (the paper's c_i/s_i form loses half the digits near faces).
// Angles come from atan2; a face containing the point (within a threshold relative to the cage
// size) gives exact barycentric coordinates; a triangle whose signed solid angle is negligible
// (the point numerically in its plane, outside it) contributes nothing, which is its limit.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <span>

namespace haustra::kernels {

struct CageView {
  std::span<const Eigen::Vector3d> vertices;  // consistently oriented, closed
  std::span<const std::array<std::uint32_t, 3>> triangles;
};

// Where the query point is, and how far the coordinates are from positive.
enum class MvcLocation : std::uint8_t { general, on_vertex, on_face };

struct MvcResult {
  MvcLocation location = MvcLocation::general;
  double min_weight = 0.0;     // the most negative (or smallest) weight
  double negative_mass = 0.0;  // Σ |w_j| over negative w_j: 0 for a point that sees the cage convex
  double total_weight = 0.0;   // Σ of the unnormalized weights (their scale; 0 on a vertex or face)
};

// The cage's centroid and size (bounding-box diagonal): coordinates are taken relative to the
// centroid, and the on-vertex and on-face thresholds are relative to the size.
struct CageFrame {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double size = 1.0;
};
[[nodiscard]] CageFrame cage_frame(std::span<const Eigen::Vector3d> vertices);

// weights: one per cage vertex (written). scratch: 4 per cage vertex (unit direction and
// distance). A point outside the cage gets the coordinates' extension (still affine-exact).
MvcResult mean_value_coordinates(const Eigen::Vector3d& point, const CageView& cage, const CageFrame& frame,
                                 std::span<double> scratch, std::span<double> weights);

}  // namespace haustra::kernels
