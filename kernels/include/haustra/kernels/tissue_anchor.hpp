#pragma once
// Connective tissue's anchor: a spring with slack from a node to where the anatomy holds it, and a
// damper on the node's motion, as one convex potential the frame's implicit step minimizes.
#include <Eigen/Core>

namespace haustra::kernels {

struct AnchorResponse {
  Eigen::Vector3d force = Eigen::Vector3d::Zero();      // on the node, N
  Eigen::Matrix3d stiffness = Eigen::Matrix3d::Zero();  // −∂force/∂x, positive semi-definite
  double energy = 0.0;                                  // J
  double tension = 0.0;                                 // N: the spring's pull, k (|x − target| − slack)⁺
};

// The spring: ½ k (|d| − s)² beyond the slack s (d = x − target), nothing within it; its Hessian
// k d̂d̂ᵀ + k (1 − s/|d|)(I − d̂d̂ᵀ). The damper: ½ damping_rate |x − x_start|², damping_rate = c/Δt
// (the target is fixed, so the node's own velocity is the relative one). k, slack, damping_rate ≥ 0.
AnchorResponse tissue_anchor(const Eigen::Vector3d& x, const Eigen::Vector3d& x_start, const Eigen::Vector3d& target,
                             double k, double slack, double damping_rate);

// The spring's tension alone, N (for tearing and reports).
double tissue_anchor_tension(const Eigen::Vector3d& x, const Eigen::Vector3d& target, double k, double slack);

}  // namespace haustra::kernels
