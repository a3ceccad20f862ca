// The backward sweep: generalized forces conjugate to the node strains, from tip to base.
#include "haustra/kernels/rod_backward_sweep.hpp"

#include <algorithm>

namespace haustra::kernels {
namespace {

// h · (Rᵀ M, d3·F) for one section.
Eigen::Vector4d section_force(const Eigen::Quaterniond& mid_rot, const Eigen::Vector3d& moment_at_mid,
                              const Eigen::Vector3d& force, double h) {
  const Eigen::Matrix3d r = mid_rot.toRotationMatrix();
  Eigen::Vector4d out;
  out.head<3>() = h * (r.transpose() * moment_at_mid);
  out[3] = h * r.col(2).dot(force);
  return out;
}

}  // namespace

Wrench rod_backward_sweep(RodPoses<const double> poses, std::span<const double> section_length,
                          Vec3View<const double> node_force, Vec3View<const double> node_moment,
                          StrainView<double> generalized_force) {
  const std::size_t nodes = poses.node_count();
  Eigen::Vector3d force = Eigen::Vector3d::Zero();
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();  // about `point`
  Eigen::Vector3d point = poses.node_position.get(nodes - 1);
  Eigen::Vector4d distal_section = Eigen::Vector4d::Zero();  // section k (beyond node k)
  for (std::size_t k = nodes; k-- > 0;) {
    const Eigen::Vector3d r = poses.node_position.get(k);
    moment += (point - r).cross(force);
    point = r;
    force += node_force.get(k);
    moment += node_moment.get(k);
    Eigen::Vector4d proximal_section = Eigen::Vector4d::Zero();  // section k−1
    if (k > 0) {
      const Eigen::Vector3d mid = poses.mid_position.get(k - 1);
      proximal_section =
          section_force(poses.mid_rotation.get(k - 1), moment + (r - mid).cross(force), force, section_length[k - 1]);
    }
    generalized_force.set(k, 0.5 * (proximal_section + distal_section));
    distal_section = proximal_section;
  }
  return {force, moment};
}

Wrench rod_backward_sweep_reference(RodPoses<const double> poses, std::span<const double> section_length,
                                    Vec3View<const double> node_force, Vec3View<const double> node_moment,
                                    StrainView<double> generalized_force) {
  const std::size_t nodes = poses.node_count();
  std::fill(generalized_force.data.begin(), generalized_force.data.end(), 0.0);
  for (std::size_t k = 0; k + 1 < nodes; ++k) {
    const Eigen::Vector3d mid = poses.mid_position.get(k);
    Eigen::Vector3d force = Eigen::Vector3d::Zero();
    Eigen::Vector3d moment = Eigen::Vector3d::Zero();
    for (std::size_t i = k + 1; i < nodes; ++i) {
      force += node_force.get(i);
      moment += (poses.node_position.get(i) - mid).cross(node_force.get(i)) + node_moment.get(i);
    }
    const Eigen::Vector4d s = section_force(poses.mid_rotation.get(k), moment, force, section_length[k]);
    generalized_force.set(k, generalized_force.get(k) + 0.5 * s);
    generalized_force.set(k + 1, generalized_force.get(k + 1) + 0.5 * s);
  }
  Wrench total;
  const Eigen::Vector3d origin = poses.node_position.get(0);
  for (std::size_t i = 0; i < nodes; ++i) {
    total.force += node_force.get(i);
    total.moment += (poses.node_position.get(i) - origin).cross(node_force.get(i)) + node_moment.get(i);
  }
  return total;
}

void rod_unit_load_generalized_force(RodPoses<const double> poses, std::span<const double> section_length,
                                     std::size_t node, const Eigen::Vector3d& direction, bool is_moment,
                                     StrainView<double> generalized_force) {
  std::fill(generalized_force.data.begin(), generalized_force.data.end(), 0.0);
  if (node == 0) return;
  const Eigen::Vector3d r = poses.node_position.get(node);
  const Eigen::Vector3d force = is_moment ? Eigen::Vector3d::Zero() : direction;
  Eigen::Vector4d distal_section = Eigen::Vector4d::Zero();
  for (std::size_t k = node; k-- > 0;) {  // section k joins node k and k+1
    const Eigen::Vector3d moment =
        is_moment ? direction : Eigen::Vector3d((r - poses.mid_position.get(k)).cross(direction));
    const Eigen::Vector4d s = section_force(poses.mid_rotation.get(k), moment, force, section_length[k]);
    generalized_force.set(k + 1, 0.5 * (s + distal_section));
    distal_section = s;
  }
  generalized_force.set(0, 0.5 * distal_section);
}

}  // namespace haustra::kernels
