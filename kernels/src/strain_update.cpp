// The strain law per component (paper eq. 9-10 and their Kelvin-Voigt blend).
#include "haustra/kernels/strain_update.hpp"

#include <cmath>

namespace haustra::kernels {

Eigen::Vector4d strain_update(StrainView<const double> solved_force, StrainView<const double> rest,
                              StrainView<const double> start_of_step, const StrainLawCoefficients& law,
                              const std::array<double, kStrainComponents>& relaxation, StrainView<double> strain) {
  std::array<double, kStrainComponents> inv_total{};
  for (std::size_t c = 0; c < kStrainComponents; ++c) inv_total[c] = 1.0 / (law.stiffness[c] + law.rate[c]);
  std::array<double, kStrainComponents> max_change{};
  const std::size_t n = strain.size();
  for (std::size_t k = 0; k < n; ++k) {
    for (std::size_t c = 0; c < kStrainComponents; ++c) {
      const double fixed_point =
          (solved_force.at(k, c) + law.stiffness[c] * rest.at(k, c) + law.rate[c] * start_of_step.at(k, c)) *
          inv_total[c];
      double& q = strain.at(k, c);
      const double change = relaxation[c] * (fixed_point - q);
      q += change;
      max_change[c] = std::max(max_change[c], std::abs(change));
    }
  }
  return {max_change[0], max_change[1], max_change[2], max_change[3]};
}

}  // namespace haustra::kernels
