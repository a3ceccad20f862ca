// Connective tissue's anchor: force, stiffness and energy of a spring with slack and a damper.
#include "haustra/kernels/tissue_anchor.hpp"

#include <Eigen/Dense>
#include <cmath>

#include "haustra/kernels/pose.hpp"

namespace haustra::kernels {

AnchorTurn tissue_anchor_turn(const Eigen::Quaterniond& rotation, const Eigen::Quaterniond& rotation_start,
                              const Eigen::Quaterniond& rest, double k, double damping_rate) {
  AnchorTurn t;
  const Eigen::Vector3d off = rotation_log(rotation * rest.conjugate());
  const Eigen::Vector3d turned = rotation_log(rotation * rotation_start.conjugate());
  t.moment = -k * off - damping_rate * turned;
  t.stiffness = k + damping_rate;
  t.energy = 0.5 * k * off.squaredNorm() + 0.5 * damping_rate * turned.squaredNorm();
  return t;
}

double tissue_anchor_tension(const Eigen::Vector3d& x, const Eigen::Vector3d& target, double k, double slack) {
  return k * std::max(0.0, (x - target).norm() - slack);
}

AnchorResponse tissue_anchor(const Eigen::Vector3d& x, const Eigen::Vector3d& x_start, const Eigen::Vector3d& target,
                             double k, double slack, double damping_rate, double support, const Eigen::Vector3d& down) {
  AnchorResponse r;
  const Eigen::Vector3d moved = x - x_start;
  r.force = -damping_rate * moved;
  r.stiffness = damping_rate * Eigen::Matrix3d::Identity();
  r.energy = 0.5 * damping_rate * moved.squaredNorm();
  const Eigen::Vector3d d = x - target;
  if (const double sunk = d.dot(down); support > 0.0 && sunk > 0.0) {
    r.force -= support * sunk * down;
    r.stiffness += support * down * down.transpose();
    r.energy += 0.5 * support * sunk * sunk;
  }
  if (slack == 0.0) {  // a plain spring: linear, its stiffness k I wherever the node is
    r.force -= k * d;
    r.stiffness += k * Eigen::Matrix3d::Identity();
    r.energy += 0.5 * k * d.squaredNorm();
    r.tension = k * d.norm();
    return r;
  }
  const double length = d.norm();
  if (length <= slack) return r;
  const Eigen::Vector3d n = d / length;
  const double stretch = length - slack;
  r.tension = k * stretch;
  r.force -= r.tension * n;
  // Along the anchor its full k; across it the tension over the length (it turns with the node).
  const Eigen::Matrix3d along = n * n.transpose();
  r.stiffness += k * along + (r.tension / length) * (Eigen::Matrix3d::Identity() - along);
  r.energy += 0.5 * k * stretch * stretch;
  return r;
}

}  // namespace haustra::kernels
