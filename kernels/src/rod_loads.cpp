// Node loads (gravity and point loads), the total wrench, and the drag of a free base.
#include "haustra/kernels/rod_loads.hpp"
#include "haustra/kernels/pose.hpp"

namespace haustra::kernels {
void assemble_node_loads(std::span<const double> node_mass, const Eigen::Vector3d& gravity,
                         Vec3View<const double> external_force, Vec3View<const double> external_moment,
                         Vec3View<double> force, Vec3View<double> moment) {
  const std::size_t n = node_mass.size();
  for (std::size_t k = 0; k < n; ++k) {
    force.x[k] = node_mass[k] * gravity.x() + external_force.x[k];
    force.y[k] = node_mass[k] * gravity.y() + external_force.y[k];
    force.z[k] = node_mass[k] * gravity.z() + external_force.z[k];
    moment.x[k] = external_moment.x[k];
    moment.y[k] = external_moment.y[k];
    moment.z[k] = external_moment.z[k];
  }
}

Vector6d total_wrench(Vec3View<const double> position, Vec3View<const double> force, Vec3View<const double> moment,
                      const Eigen::Vector3d& origin) {
  Eigen::Vector3d m = Eigen::Vector3d::Zero();
  Eigen::Vector3d f = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < position.size(); ++k) {
    const Eigen::Vector3d fk = force.get(k);
    f += fk;
    m += (position.get(k) - origin).cross(fk) + moment.get(k);
  }
  Vector6d w;
  w.head<3>() = m;
  w.tail<3>() = f;
  return w;
}

Matrix6d rigid_drag_resistance(Vec3View<const double> position, std::span<const double> drag,
                               std::span<const double> spin_drag, const Eigen::Vector3d& origin) {
  Matrix6d c = Matrix6d::Zero();
  for (std::size_t k = 0; k < position.size(); ++k) {
    const Eigen::Matrix3d rho = skew(position.get(k) - origin);
    // ω part: −[ρ]×[ρ]× = |ρ|² I − ρρᵀ; coupling: M gets c [ρ]× v, F gets −c [ρ]× ω.
    c.topLeftCorner<3, 3>() += -drag[k] * rho * rho + spin_drag[k] * Eigen::Matrix3d::Identity();
    c.topRightCorner<3, 3>() += drag[k] * rho;
    c.bottomLeftCorner<3, 3>() -= drag[k] * rho;
    c.bottomRightCorner<3, 3>() += drag[k] * Eigen::Matrix3d::Identity();
  }
  return c;
}

void add_rigid_drag_loads(Vec3View<const double> position, std::span<const double> drag,
                          std::span<const double> spin_drag, const Eigen::Vector3d& origin, const Vector6d& twist,
                          Vec3View<double> force, Vec3View<double> moment) {
  const Eigen::Vector3d omega = twist.head<3>();
  const Eigen::Vector3d v = twist.tail<3>();
  for (std::size_t k = 0; k < position.size(); ++k) {
    const Eigen::Vector3d velocity = v + omega.cross(position.get(k) - origin);
    force.set(k, force.get(k) - drag[k] * velocity);
    moment.set(k, moment.get(k) - spin_drag[k] * omega);
  }
}

}  // namespace haustra::kernels
