#pragma once
// The strain law per component c (paper eq. 9–10, and their Kelvin–Voigt blend):
//   k_c M (q − q̂) + (η_c/Δt) M (q − q_start) = R
// ⇒ q_fixed_point = (M⁻¹R + k_c q̂ + (η_c/Δt) q_start) / (k_c + η_c/Δt).
// Elastic: η = 0. Viscous: k = 0 (the strain rate replaces the strain). The relaxed update
// q ← q + ω (q_fixed_point − q) is the damped fixed-point iteration the robust mode uses.
#include <array>

#include "haustra/kernels/spans.hpp"

namespace haustra::kernels {

struct StrainLawCoefficients {
  std::array<double, kStrainComponents> stiffness{};  // k_c: B, B, T, EA
  std::array<double, kStrainComponents> rate{};       // η_c / Δt
};

// strain: in, the current iterate; out, the updated strain. solved_force = M⁻¹R. relaxation: ω
// per component. Returns the largest |change| per component.
Eigen::Vector4d strain_update(StrainView<const double> solved_force, StrainView<const double> rest,
                              StrainView<const double> start_of_step, const StrainLawCoefficients& law,
                              const std::array<double, kStrainComponents>& relaxation, StrainView<double> strain);

}  // namespace haustra::kernels
