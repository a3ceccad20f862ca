// The EXP2 tissue law (paper eq. 1): stress, its slope and their integrals over the tube wall.
#include "haustra/kernels/tissue_law.hpp"

#include <cmath>
#include <numbers>

namespace haustra::kernels {
namespace {

// J(a) − 1 and J'(a), J(a) = ∫₀¹ e^{a(1−u²)} du. The series Σ aⁿ cₙ/n!, cₙ = ∫₀¹ (1−u²)ⁿ du,
// avoids the cancellation of the closed form near a = 0.
LawResponse j_minus_one(double a) {
  if (a < 1.0) {
    double value = 0.0, slope = 0.0;
    double c = 1.0;     // cₙ
    double term = 1.0;  // aⁿ⁻¹/(n−1)!
    for (int n = 1; n < 40; ++n) {
      c *= 2.0 * n / (2.0 * n + 1.0);
      slope += term * c;
      term *= a / n;
      value += term * c;
      if (term * c <= 1e-17 * value) break;
    }
    return {value, slope};
  }
  const double root = std::sqrt(a);
  const double j = std::exp(a) * std::sqrt(std::numbers::pi) * std::erf(root) / (2.0 * root);
  return {j - 1.0, j - (j - 1.0) / (2.0 * a)};
}

// ∫₀ˣ f with 8-point Gauss–Legendre: the integrands here are smooth and monotone.
template <class F>
double integrate_from_zero(F f, double x) {
  static constexpr std::array<double, 4> node = {0.1834346424956498, 0.5255324099163290, 0.7966664774136267,
                                                 0.9602898564975363};
  static constexpr std::array<double, 4> weight = {0.3626837833783620, 0.3137066458778873, 0.2223810344533745,
                                                   0.1012285362903763};
  const double half = 0.5 * x;
  double sum = 0.0;
  for (std::size_t i = 0; i < 4; ++i) sum += weight[i] * (f(half * (1.0 - node[i])) + f(half * (1.0 + node[i])));
  return half * sum;
}

}  // namespace

LawResponse exp2_stress(const Exp2Tissue& tissue, double strain) {
  const double grow = std::exp(tissue.alpha * strain * strain);
  const double sign = strain < 0.0 ? -1.0 : 1.0;
  return {sign * tissue.beta * (grow - 1.0) + tissue.gamma * strain,
          2.0 * tissue.alpha * tissue.beta * std::abs(strain) * grow + tissue.gamma};
}

LawResponse exp2_tube_axial_force(const Exp2Tissue& tissue, const TubeSection& tube, double strain) {
  const double area = 2.0 * std::numbers::pi * tube.radius * tube.wall;
  const LawResponse s = exp2_stress(tissue, strain);
  return {area * s.value, area * s.slope};
}

LawResponse exp2_tube_bending_moment(const Exp2Tissue& tissue, const TubeSection& tube, double curvature) {
  const double r2 = tube.radius * tube.radius;
  const double linear = tissue.gamma * std::numbers::pi * r2 * tube.radius * tube.wall;
  const double a = tissue.alpha * curvature * curvature * r2;
  const LawResponse j = j_minus_one(a);
  const double scale = 4.0 * tissue.beta * r2 * tube.wall;
  return {linear * curvature + scale * j.value, linear + scale * j.slope * 2.0 * tissue.alpha * curvature * r2};
}

double exp2_tube_axial_energy(const Exp2Tissue& tissue, const TubeSection& tube, double strain) {
  return integrate_from_zero([&](double e) { return exp2_tube_axial_force(tissue, tube, e).value; }, strain);
}

double exp2_tube_bending_energy(const Exp2Tissue& tissue, const TubeSection& tube, double curvature) {
  return integrate_from_zero([&](double k) { return exp2_tube_bending_moment(tissue, tube, k).value; }, curvature);
}

void nodal_law_evaluate(StrainView<const double> strain, StrainView<const double> rest,
                        StrainView<const double> start_of_step, const NodalLaw& law, StrainView<double> stress,
                        StrainView<double> tangent, std::span<double> bend_coupling) {
  const bool exp2_bending = law.exp2 && law.stiffness[0] != 0.0;
  const bool exp2_axial = law.exp2 && law.stiffness[3] != 0.0;
  for (std::size_t k = 0; k < strain.size(); ++k) {
    std::array<double, kStrainComponents> elastic{}, slope{};
    for (std::size_t c = 0; c < kStrainComponents; ++c) {
      elastic[c] = law.stiffness[c] * (strain.at(k, c) - rest.at(k, c));
      slope[c] = law.stiffness[c];
    }
    double coupling = 0.0;
    if (exp2_axial) {
      const LawResponse n = exp2_tube_axial_force(law.tissue, law.tube, strain.at(k, 3) - rest.at(k, 3));
      elastic[3] = n.value;
      slope[3] = n.slope;
    }
    if (exp2_bending) {
      // m = M(|Δκ|) Δκ/|Δκ|; ∂m/∂κ = M' n nᵀ + (M/|Δκ|)(I − n nᵀ).
      const double d1 = strain.at(k, 0) - rest.at(k, 0);
      const double d2 = strain.at(k, 1) - rest.at(k, 1);
      const double bend = std::hypot(d1, d2);
      const LawResponse m = exp2_tube_bending_moment(law.tissue, law.tube, bend);
      double secant = m.slope;  // M/|Δκ| → M'(0) as the bend vanishes
      double n1 = 1.0, n2 = 0.0;
      if (bend > 0.0) {
        secant = m.value / bend;
        n1 = d1 / bend;
        n2 = d2 / bend;
      }
      const double spread = m.slope - secant;
      elastic[0] = secant * d1;
      elastic[1] = secant * d2;
      slope[0] = secant + spread * n1 * n1;
      slope[1] = secant + spread * n2 * n2;
      coupling = spread * n1 * n2;
    }
    for (std::size_t c = 0; c < kStrainComponents; ++c) {
      stress.at(k, c) = elastic[c] + law.rate[c] * (strain.at(k, c) - start_of_step.at(k, c));
      tangent.at(k, c) = slope[c] + law.rate[c];
    }
    bend_coupling[k] = coupling;
  }
}

double nodal_law_exp2_energy(StrainView<const double> strain, StrainView<const double> rest,
                             std::span<const double> section_length, const NodalLaw& law, std::size_t first,
                             std::size_t end) {
  if (!law.exp2) return 0.0;
  const std::size_t n = strain.size();
  double energy = 0.0;
  for (std::size_t k = first; k < (end > 0 ? end : n); ++k) {
    const double share = 0.5 * ((k > 0 ? section_length[k - 1] : 0.0) + (k + 1 < n ? section_length[k] : 0.0));
    if (law.stiffness[3] != 0.0)
      energy += share * exp2_tube_axial_energy(law.tissue, law.tube, strain.at(k, 3) - rest.at(k, 3));
    if (law.stiffness[0] != 0.0)
      energy += share *
                exp2_tube_bending_energy(law.tissue, law.tube,
                                         std::hypot(strain.at(k, 0) - rest.at(k, 0), strain.at(k, 1) - rest.at(k, 1)));
  }
  return energy;
}

}  // namespace haustra::kernels
