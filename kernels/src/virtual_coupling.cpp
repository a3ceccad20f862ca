// The virtual coupling's capped spring: force, stiffness and energy of Huber's potential.
#include "haustra/kernels/virtual_coupling.hpp"

#include <Eigen/Dense>
#include <cmath>

namespace haustra::kernels {

CouplingResponse virtual_coupling(const Eigen::Vector3d& x, const Eigen::Vector3d& target, double k, double limit) {
  CouplingResponse r;
  const Eigen::Vector3d e = x - target;
  const double d = e.norm();
  r.unsaturated = k * d;
  if (r.unsaturated <= limit) {
    r.force = -k * e;
    r.stiffness = k * Eigen::Matrix3d::Identity();
    r.energy = 0.5 * k * d * d;
    return r;
  }
  // Beyond d₀ the force keeps its magnitude and turns with the stretch: stiffness only across it.
  const Eigen::Vector3d n = e / d;
  const double d0 = limit / k;
  r.force = -limit * n;
  r.stiffness = (limit / d) * (Eigen::Matrix3d::Identity() - n * n.transpose());
  r.energy = limit * (d - 0.5 * d0);
  return r;
}

}  // namespace haustra::kernels
