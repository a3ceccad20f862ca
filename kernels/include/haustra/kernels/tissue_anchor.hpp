#pragma once
// Connective tissue's anchor: a spring with slack from a node to where the anatomy holds it, and a
// damper on the node's motion, as one convex potential the frame's implicit step minimizes.
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace haustra::kernels {

struct AnchorResponse {
  Eigen::Vector3d force = Eigen::Vector3d::Zero();      // on the node, N
  Eigen::Matrix3d stiffness = Eigen::Matrix3d::Zero();  // −∂force/∂x, positive semi-definite
  double energy = 0.0;                                  // J
  double tension = 0.0;                                 // N: the spring's pull, k (|x − target| − slack)⁺
};

// The spring: ½ k (|d| − s)² beyond the slack s (d = x − target), nothing within it; its Hessian
// k d̂d̂ᵀ + k (1 − s/|d|)(I − d̂d̂ᵀ). The damper: ½ damping_rate |x − x_start|², damping_rate = c/Δt
// (the target is fixed, so the node's own velocity is the relative one). The support: ½ support
// (d·down)² while the node is below its target along `down` (a unit vector, gravity's; what lies
// under the organ carries it, and does not hold it down). k, slack, damping_rate, support ≥ 0.
AnchorResponse tissue_anchor(const Eigen::Vector3d& x, const Eigen::Vector3d& x_start, const Eigen::Vector3d& target,
                             double k, double slack, double damping_rate, double support = 0.0,
                             const Eigen::Vector3d& down = Eigen::Vector3d::Zero());

// The anchor's hold on the node's frame (tissue fixed round the tube holds it from turning): a
// torsion spring ½ k θ² towards the rest frame and a damper ½ rate φ² on the turn over the
// substep, θ and φ the angles of R R_restᵀ and R R_startᵀ. Its moment in world axes, and its
// stiffness k + rate about any axis (the frame's implicit step takes it as isotropic, like the
// medium's spin drag).
struct AnchorTurn {
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();  // on the node, N·m
  double stiffness = 0.0;                            // N·m/rad
  double energy = 0.0;                               // J
};
AnchorTurn tissue_anchor_turn(const Eigen::Quaterniond& rotation, const Eigen::Quaterniond& rotation_start,
                              const Eigen::Quaterniond& rest, double k, double damping_rate);

// The spring's tension alone, N (for tearing and reports).
double tissue_anchor_tension(const Eigen::Vector3d& x, const Eigen::Vector3d& target, double k, double slack);

}  // namespace haustra::kernels
