#pragma once
// The Newton system of the implicit strain law a_c M (q − q*) = R(q) for one rod, with dead node
// loads plus loads that follow the node's motion: the viscous drag of the surrounding medium
// (f = −c δr/Δt, m = −s δφ/Δt, which is what lets a free base move) and contact penalties
// (f = −k n nᵀ δr), given as a per-node load stiffness. In strain coordinates alone the Jacobian is
// dense (a strain change moves every distal lever arm); in mixed form it is block-tridiagonal.
// Per node k the unknowns are
//   z_k = (δq_k [4], δφ_k [3] world rotation of the frame, δr_k [3] position,
//          δM_k [3] distal moment about r_k, δF_k [3] distal force)
// and the rows are
//   0–3   node k's linearized residual:  ½ δs_{k−1} + ½ δs_k − Σ_j A_kj δq_j = −ρ_k
//   4–9   kinematics of section k−1 (node k from node k−1); at the base either δφ_0 = δr_0 = 0
//         (clamped) or the balance of the whole rod's wrench (free)
//   10–12 moment transport δM_k = δM_{k+1} + δm_{k+1} + (δr_{k+1} − δr_k) × F_k + (r_{k+1} − r_k) × δF_k
//   13–15 force transport δF_k = δF_{k+1} + δf_{k+1}   (δF_N = δM_N = 0 at the tip)
// with s_k the section generalized force of the backward sweep, F_k and M_k the force and moment
// of the loads beyond node k. The section perturbation is taken at its midpoint, as in the backward
// sweep, so this is the Jacobian of the residual the sweep defines, to O(h²) in the terms of the
// half-section itself. One factorization solves O(N) per right-hand side.
#include <array>
#include <span>

#include "haustra/kernels/block_tridiagonal.hpp"
#include "haustra/kernels/spans.hpp"

namespace haustra::kernels {

inline constexpr int kNewtonBlock = 16;
inline constexpr int kNewtonStrain = 0;
inline constexpr int kNewtonRotation = 4;
inline constexpr int kNewtonPosition = 7;
inline constexpr int kNewtonMoment = 10;
inline constexpr int kNewtonForce = 13;

using NewtonBlock = Eigen::Matrix<double, kNewtonBlock, kNewtonBlock>;
using NewtonSystem = BlockTridiagonalView<kNewtonBlock>;

struct NewtonLoadStiffness {
  std::span<const Eigen::Matrix3d> force;  // per node: −∂f/∂r (N/m); empty: none
  std::span<const double> moment;          // per node: −∂m/∂φ (N·m/rad), isotropic
};

// A nonlinear strain law's tangent per node (kernels/tissue_law): the law's rows become −M T with
// T_j node j's ∂s/∂q. Empty: the linear law's law_total for every node.
struct NodalLawTangent {
  StrainView<const double> tangent;       // per node and component
  std::span<const double> bend_coupling;  // per node, ∂s_κ1/∂κ2
};

// law_total: a_c = k_c + η_c/Δt per component. node_force/moment: all current loads, drag included.
// distal_force, distal_moment: caller scratch, N+1. free_base: the base rows balance the rod's
// total wrench instead of holding node 0 (needs a load stiffness at every node, e.g. drag). Returns that total wrench
// (moment about node 0, then force), which is the right-hand side of the free base rows, negated.
Eigen::Matrix<double, 6, 1> rod_newton_assemble(RodPoses<const double> poses, std::span<const double> section_length,
                                                Vec3View<const double> node_force, Vec3View<const double> node_moment,
                                                const std::array<double, 4>& law_total, NewtonLoadStiffness stiffness,
                                                bool free_base, Vec3View<double> distal_force,
                                                Vec3View<double> distal_moment, NewtonSystem system,
                                                NodalLawTangent nodal = {});

// ρ = R − A (q − q*), A = blockdiag(a_c M): the residual the Newton step drives to zero.
// target: q* per component; out: N+1 nodes.
void rod_strain_residual(StrainView<const double> generalized_force, StrainView<const double> strain,
                         StrainView<const double> target, std::span<const double> section_length,
                         const std::array<double, 4>& law_total, StrainView<double> residual);

// ρ = R − M s with s the law's generalized stress per node (kernels/tissue_law): the residual of a
// nonlinear law. out: N+1 nodes.
void rod_stress_residual(StrainView<const double> generalized_force, StrainView<const double> stress,
                         std::span<const double> section_length, StrainView<double> residual);

}  // namespace haustra::kernels
