#pragma once
// A rod's configuration as a continuous curve: the pose at any arc length, exactly as the forward
// sweep builds it (the node pose, then the section's constant strain over the remaining length).
// For building things around a rod outside a world: procedural organ meshes, cages, tests.
#include <span>
#include <vector>

#include "haustra/kernels/pose.hpp"

namespace haustra {

class RodCurve {
 public:
  // section_length: N values (rest lengths); strain: 4 (N+1) values (κ1, κ2, τ, ε interleaved).
  RodCurve(std::span<const double> section_length, std::span<const double> strain, const kernels::Pose& base);

  [[nodiscard]] double length() const { return arc_.back(); }  // rest arc length
  [[nodiscard]] std::size_t nodes() const { return arc_.size(); }
  [[nodiscard]] double node_arc(std::size_t k) const { return arc_[k]; }
  [[nodiscard]] const kernels::Pose& node_pose(std::size_t k) const { return node_[k]; }
  // s in rest arc length, clamped to [0, length]; beyond the ends use extend().
  [[nodiscard]] kernels::Pose pose_at(double s) const;
  // The pose continued straight along the end tangent for s < 0 or s > length.
  [[nodiscard]] kernels::Pose extend(double s) const;
  // Curvature |(κ1, κ2)| of the section holding s, 1/m.
  [[nodiscard]] double curvature_at(double s) const;

 private:
  [[nodiscard]] std::size_t section_of(double s) const;
  std::vector<double> arc_;
  std::vector<kernels::Pose> node_;
  std::vector<Eigen::Vector4d> section_strain_;
};

}  // namespace haustra
