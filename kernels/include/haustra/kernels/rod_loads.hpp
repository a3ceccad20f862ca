#pragma once
// Node loads and the rigid-body drag of a free base.
#include <span>

#include "haustra/kernels/rod_backward_sweep.hpp"
#include "haustra/kernels/spans.hpp"

namespace haustra::kernels {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;  // twist (ω, v) or wrench (M, F), angular first

// force = m_k g + external force; moment = external moment.
void assemble_node_loads(std::span<const double> node_mass, const Eigen::Vector3d& gravity,
                         Vec3View<const double> external_force, Vec3View<const double> external_moment,
                         Vec3View<double> force, Vec3View<double> moment);

// Total wrench of the node loads about `origin`, as (M, F).
Vector6d total_wrench(Vec3View<const double> position, Vec3View<const double> force, Vec3View<const double> moment,
                      const Eigen::Vector3d& origin);

// Resistance of the rod moving rigidly with twist (ω, v) about `origin` through a viscous medium:
// node k feels −c_k (v + ω × ρ_k) and the moment −s_k ω, ρ_k = r_k − origin. Returns C with
// drag wrench = −C (ω, v). C is symmetric positive definite when some s_k > 0.
Matrix6d rigid_drag_resistance(Vec3View<const double> position, std::span<const double> drag,
                               std::span<const double> spin_drag, const Eigen::Vector3d& origin);

// Adds the drag loads of the rigid twist (ω, v) about `origin` to force and moment.
void add_rigid_drag_loads(Vec3View<const double> position, std::span<const double> drag,
                          std::span<const double> spin_drag, const Eigen::Vector3d& origin, const Vector6d& twist,
                          Vec3View<double> force, Vec3View<double> moment);

}  // namespace haustra::kernels
