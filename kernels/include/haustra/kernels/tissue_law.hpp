#pragma once
// The EXP2 tissue law (Rosen et al.; the paper's eq. 1), σ(ε) = β(e^{αε²} − 1) + γε, made odd
// (compression mirrors tension, so the energy is convex and every strain has one stress), and its
// resultants over the thin-walled tube of the paper's §4.2 (radius R, wall h_w):
//   axial force   N(ε) = 2πR h_w σ(ε)
//   bending moment M(κ) = ∫ σ(κ y) y dA = γ πR³h_w κ + 4βR²h_w (J(ακ²R²) − 1),
//                  J(a) = ∫₀¹ e^{a(1−u²)} du = e^a √π erf(√a) / (2√a)
// (a fibre at angle θ round the wall is at y = R sin θ). With β = 0 both reduce to Hooke's EA ε
// and EI κ with E = γ. Torsion (shear) stays Hooke's.
//
// Per node, the elastic and viscous parts of the strain law give a generalized stress
//   s_c(q) = f_c(q − q̂) + (η_c/Δt)(q − q_start)
// and its tangent ∂s/∂q: diagonal per component, plus the coupling of κ1 and κ2 through |κ| (an
// isotropic section bends about any axis alike). The rod's residual is R − M s (the hat
// functions' mass matrix M interpolating the stress, which for Hooke is exactly k M (q − q̂)).
#include <array>
#include <span>

#include "haustra/kernels/spans.hpp"

namespace haustra::kernels {

struct Exp2Tissue {
  double alpha = 0.0;  // 1 (dimensionless: multiplies ε²)
  double beta = 0.0;   // Pa
  double gamma = 0.0;  // Pa, the slope at zero strain
};

struct TubeSection {
  double radius = 0.0;  // m, centreline to the wall
  double wall = 0.0;    // m, wall thickness
};

struct LawResponse {
  double value = 0.0;  // stress (Pa), force (N) or moment (N·m)
  double slope = 0.0;  // its derivative by the strain or curvature
};

LawResponse exp2_stress(const Exp2Tissue& tissue, double strain);
LawResponse exp2_tube_axial_force(const Exp2Tissue& tissue, const TubeSection& tube, double strain);
// curvature ≥ 0: the magnitude of the bend; the moment acts about the bend's axis.
LawResponse exp2_tube_bending_moment(const Exp2Tissue& tissue, const TubeSection& tube, double curvature);
// Stored energy per length of rod (J/m) at a strain or a bend: ∫ N dε, ∫ M dκ.
double exp2_tube_axial_energy(const Exp2Tissue& tissue, const TubeSection& tube, double strain);
double exp2_tube_bending_energy(const Exp2Tissue& tissue, const TubeSection& tube, double curvature);

struct NodalLaw {
  std::array<double, kStrainComponents> stiffness{};  // Hooke's k_c (0 for viscous components)
  std::array<double, kStrainComponents> rate{};       // η_c / Δt
  bool exp2 = false;  // the elastic part of bending and axial strain follows `tissue` on `tube`
  Exp2Tissue tissue;
  TubeSection tube;
};

// stress, tangent: per node and component; bend_coupling: per node, ∂s_κ1/∂κ2 = ∂s_κ2/∂κ1.
void nodal_law_evaluate(StrainView<const double> strain, StrainView<const double> rest,
                        StrainView<const double> start_of_step, const NodalLaw& law, StrainView<double> stress,
                        StrainView<double> tangent, std::span<double> bend_coupling);

// Lumped elastic energy of the EXP2 components (bending and axial), J: Σ_k w_k W(q_k − q̂_k) with
// w_k each node's share of the rod's length.
// Nodes [first, end) only where end > 0 (each node's share from the whole rod's sections).
double nodal_law_exp2_energy(StrainView<const double> strain, StrainView<const double> rest,
                             std::span<const double> section_length, const NodalLaw& law, std::size_t first = 0,
                             std::size_t end = 0);

}  // namespace haustra::kernels
