#pragma once
// Backward sweep: the generalized forces R conjugate to the node strains, for point loads (force
// and moment, world frame) at the nodes.
//
// A change δξ of section k's strain acts, to second order in h, as a body twist h·δξ applied at the
// section's midpoint frame (exp(h(ξ+δ)) = exp(hξ/2)·exp(hδ)·exp(hξ/2) + O(h³)). Its conjugate force
// is therefore h_k times the wrench of everything distal to the midpoint, in the midpoint's
// material axes: (d1·M, d2·M, d3·M, d3·F). Node k gets half of sections k−1 and k, because
// ξ_k = ½(q_k + q_{k+1}). Distal force and moment accumulate from the tip to the base in one pass.
#include <span>

#include "haustra/kernels/spans.hpp"

namespace haustra::kernels {

struct Wrench {
  Eigen::Vector3d force = Eigen::Vector3d::Zero();
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();  // about the point it is reported at
};

// Writes R for all N+1 nodes. Returns the total wrench of the loads about node 0.
Wrench rod_backward_sweep(RodPoses<const double> poses, std::span<const double> section_length,
                          Vec3View<const double> node_force, Vec3View<const double> node_moment,
                          StrainView<double> generalized_force);

// Reference: each section's distal wrench summed directly over all distal loads (O(N²)).
Wrench rod_backward_sweep_reference(RodPoses<const double> poses, std::span<const double> section_length,
                                    Vec3View<const double> node_force, Vec3View<const double> node_moment,
                                    StrainView<double> generalized_force);

// R for a single unit load at `node`: a force along `direction` (is_moment = false) or a moment
// about it. Only nodes 0..node are non-zero; the rest are written as zero. This is one row of the
// constraint Jacobian J: the same numbers give J·δq, the linearized displacement (or rotation) of
// that node along `direction` for a strain change δq.
void rod_unit_load_generalized_force(RodPoses<const double> poses, std::span<const double> section_length,
                                     std::size_t node, const Eigen::Vector3d& direction, bool is_moment,
                                     StrainView<double> generalized_force);

}  // namespace haustra::kernels
