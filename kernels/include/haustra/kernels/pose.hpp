#pragma once
// Rigid poses and the SE(3) exponential of a constant-strain rod section.
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace haustra::kernels {

struct Pose {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();  // body to world
  Eigen::Vector3d position = Eigen::Vector3d::Zero();

  [[nodiscard]] Pose operator*(const Pose& rhs) const {
    return {rotation * rhs.rotation, position + rotation * rhs.position};
  }
};

// Pose of the end of a rod piece of rest length `length` relative to its start, for constant
// material curvature/torsion u = (κ1, κ2, τ) and axial strain ε: exp(length · [u; (1+ε) e3]).
// Closed form (Rodrigues + the SE(3) left Jacobian), with Taylor series below a small angle so
// that straight pieces are exact and no division by a tiny angle happens.
[[nodiscard]] Pose section_exp(const Eigen::Vector3d& u, double axial_strain, double length);

// The cross-product matrix: skew(a) b = a × b.
[[nodiscard]] inline Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

// Rotation vector (axis times angle, angle in [0, π]) of a unit quaternion.
[[nodiscard]] Eigen::Vector3d rotation_log(const Eigen::Quaterniond& q);

// The squared angle |rotation_log(q)|² of a unit quaternion, without atan2 for small turns (a
// series in |q.vec| exact to rounding below 0.06 rad): what a rotational drag's potential needs.
[[nodiscard]] double rotation_angle_squared(const Eigen::Quaterniond& q);

// Unit quaternion of a rotation vector.
[[nodiscard]] Eigen::Quaterniond rotation_exp(const Eigen::Vector3d& rotation_vector);

// A right-handed frame whose third axis is `tangent` (unit) and whose first axis is as close as
// possible to `normal_hint` (falls back to a fixed world axis when the hint is parallel).
[[nodiscard]] Eigen::Quaterniond frame_from_tangent(const Eigen::Vector3d& tangent, const Eigen::Vector3d& normal_hint);

}  // namespace haustra::kernels
