// A rod's configuration as a continuous curve (pose at any arc length).
#include "haustra/rod_curve.hpp"

#include <algorithm>

namespace haustra {

RodCurve::RodCurve(std::span<const double> section_length, std::span<const double> strain, const kernels::Pose& base) {
  const std::size_t sections = section_length.size();
  arc_.assign(sections + 1, 0.0);
  node_.assign(sections + 1, base);
  section_strain_.resize(sections);
  for (std::size_t k = 0; k < sections; ++k) {
    Eigen::Vector4d xi;
    for (int c = 0; c < 4; ++c)
      xi[c] = 0.5 * (strain[4 * k + static_cast<std::size_t>(c)] + strain[4 * k + 4 + static_cast<std::size_t>(c)]);
    section_strain_[k] = xi;
    node_[k + 1] = node_[k] * kernels::section_exp(xi.head<3>(), xi[3], section_length[k]);
    arc_[k + 1] = arc_[k] + section_length[k];
  }
}

std::size_t RodCurve::section_of(double s) const {
  const auto it = std::upper_bound(arc_.begin(), arc_.end(), s);
  const auto k = static_cast<std::size_t>(std::max<std::ptrdiff_t>(it - arc_.begin() - 1, 0));
  return std::min(k, section_strain_.size() - 1);
}

kernels::Pose RodCurve::pose_at(double s) const {
  s = std::clamp(s, 0.0, length());
  const std::size_t k = section_of(s);
  const Eigen::Vector4d& xi = section_strain_[k];
  return node_[k] * kernels::section_exp(xi.head<3>(), xi[3], s - arc_[k]);
}

kernels::Pose RodCurve::extend(double s) const {
  if (s >= 0.0 && s <= length()) return pose_at(s);
  const kernels::Pose& end = s < 0.0 ? node_.front() : node_.back();
  const double beyond = s < 0.0 ? s : s - length();
  return {end.rotation, end.position + beyond * (end.rotation * Eigen::Vector3d::UnitZ())};
}

double RodCurve::curvature_at(double s) const {
  return section_strain_[section_of(std::clamp(s, 0.0, length()))].head<2>().norm();
}

}  // namespace haustra
