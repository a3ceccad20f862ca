// The forward sweep: node and midpoint poses from the base pose and the strains.
#include "haustra/kernels/rod_forward_sweep.hpp"

#include <unsupported/Eigen/MatrixFunctions>

namespace haustra::kernels {

void rod_forward_sweep(const Pose& base, std::span<const double> section_length, StrainView<const double> strain,
                       RodPoses<double> out) {
  const std::size_t sections = section_length.size();
  assert(strain.size() == sections + 1 && out.node_count() == sections + 1);
  Eigen::Quaterniond rot = base.rotation;
  Eigen::Vector3d pos = base.position;
  out.node_position.set(0, pos);
  out.node_rotation.set(0, rot);
  const double* q = strain.data.data();
  for (std::size_t k = 0; k < sections; ++k) {
    const double* qa = q + 4 * k;
    const double* qb = qa + 4;
    const Eigen::Vector3d u(0.5 * (qa[0] + qb[0]), 0.5 * (qa[1] + qb[1]), 0.5 * (qa[2] + qb[2]));
    const double eps = 0.5 * (qa[3] + qb[3]);
    const Pose half = section_exp(u, eps, 0.5 * section_length[k]);
    // Midpoint.
    pos += rot * half.position;
    rot = rot * half.rotation;
    out.mid_position.set(k, pos);
    out.mid_rotation.set(k, rot);
    // End node. Renormalize once per node so rounding cannot accumulate over 10⁴ sections.
    pos += rot * half.position;
    rot = (rot * half.rotation).normalized();
    out.node_position.set(k + 1, pos);
    out.node_rotation.set(k + 1, rot);
  }
}

namespace {

Eigen::Matrix4d twist_matrix(const Eigen::Vector4d& xi, double length) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  const Eigen::Vector3d w = xi.head<3>() * length;
  m(0, 1) = -w.z();
  m(0, 2) = w.y();
  m(1, 0) = w.z();
  m(1, 2) = -w.x();
  m(2, 0) = -w.y();
  m(2, 1) = w.x();
  m(2, 3) = (1.0 + xi[3]) * length;
  return m;
}

Eigen::Matrix4d homogeneous(const Pose& p) {
  Eigen::Matrix4d g = Eigen::Matrix4d::Identity();
  g.topLeftCorner<3, 3>() = p.rotation.toRotationMatrix();
  g.topRightCorner<3, 1>() = p.position;
  return g;
}

void store(const Eigen::Matrix4d& g, Vec3View<double> pos, RotationView<double> rot, std::size_t i) {
  pos.set(i, g.topRightCorner<3, 1>());
  rot.set(i, Eigen::Quaterniond(Eigen::Matrix3d(g.topLeftCorner<3, 3>())).normalized());
}

}  // namespace

void rod_forward_sweep_reference(const Pose& base, std::span<const double> section_length,
                                 StrainView<const double> strain, RodPoses<double> out) {
  Eigen::Matrix4d g = homogeneous(base);
  store(g, out.node_position, out.node_rotation, 0);
  for (std::size_t k = 0; k < section_length.size(); ++k) {
    const Eigen::Vector4d xi = 0.5 * (strain.get(k) + strain.get(k + 1));
    const Eigen::Matrix4d mid = g * twist_matrix(xi, 0.5 * section_length[k]).exp();
    store(mid, out.mid_position, out.mid_rotation, k);
    g = g * twist_matrix(xi, section_length[k]).exp();
    store(g, out.node_position, out.node_rotation, k + 1);
  }
}

}  // namespace haustra::kernels
