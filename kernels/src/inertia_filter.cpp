// The paper's inertia filter (eq. 11-12) over a span of node positions.
#include "haustra/kernels/inertia_filter.hpp"

#include <cmath>

namespace haustra::kernels {

double inertia_filter(Vec3View<const double> previous, std::span<const double> node_mass,
                      std::span<const std::uint8_t> exempt, double zeta, double dt, Vec3View<double> node_position,
                      Vec3View<double> mid_position) {
  const std::size_t n = node_position.size();
  double max_sq = 0.0;
  for (std::size_t k = 0; k < n; ++k) max_sq = std::max(max_sq, (node_position.get(k) - previous.get(k)).squaredNorm());
  const double delta_r = std::sqrt(max_sq);
  const double scale = zeta * delta_r / (dt * dt);
  Eigen::Vector3d prev_correction = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < n; ++k) {
    Eigen::Vector3d correction = Eigen::Vector3d::Zero();
    if (exempt[k] == 0) {
      const double a = std::exp(-scale * node_mass[k]);
      const Eigen::Vector3d estimated = node_position.get(k);
      correction = (1.0 - a) * (previous.get(k) - estimated);
      node_position.set(k, estimated + correction);
    }
    if (k > 0) mid_position.set(k - 1, mid_position.get(k - 1) + 0.5 * (prev_correction + correction));
    prev_correction = correction;
  }
  return delta_r;
}

}  // namespace haustra::kernels
