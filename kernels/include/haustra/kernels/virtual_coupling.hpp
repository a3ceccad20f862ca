#pragma once
// The virtual coupling between a commanded point and a node (Colgate's, as haptic rendering uses
// it): a spring with a force limit, as one convex potential the frame's Newton solve can minimize.
#include <Eigen/Core>

namespace haustra::kernels {

// Huber's potential of the stretch d = |x − target|: ½ k d² up to d₀ = limit / k, then
// limit (d − ½ d₀): C¹ and convex, its force −k (x − target) capped at `limit` in magnitude.
struct CouplingResponse {
  Eigen::Vector3d force = Eigen::Vector3d::Zero();      // on the node, N
  Eigen::Matrix3d stiffness = Eigen::Matrix3d::Zero();  // −∂force/∂x, positive semi-definite
  double energy = 0.0;                                  // J
  double unsaturated = 0.0;                             // k d, N: the force the spring alone would give
};

// k > 0 (N/m), limit > 0 (N; infinity: a plain spring).
CouplingResponse virtual_coupling(const Eigen::Vector3d& x, const Eigen::Vector3d& target, double k, double limit);

}  // namespace haustra::kernels
