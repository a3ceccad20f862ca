// Rigid poses and the SE(3) exponential of a constant-strain section.
#include "haustra/kernels/pose.hpp"

#include <cmath>

namespace haustra::kernels {
namespace {

// Below this rotation angle the closed forms lose digits to cancellation; the series (to θ⁸)
// are exact to rounding there.
constexpr double kSeriesAngle = 0.05;

struct ExpCoefficients {
  double one_minus_cos_over_sq;    // (1 − cos θ)/θ²
  double theta_minus_sin_over_cu;  // (θ − sin θ)/θ³
  double half_sin_over_theta;      // sin(θ/2)/θ
  double cos_half;                 // cos(θ/2)
};

ExpCoefficients exp_coefficients(double theta_sq) {
  ExpCoefficients c{};
  const double theta = std::sqrt(theta_sq);
  c.cos_half = std::cos(0.5 * theta);
  if (theta < kSeriesAngle) {
    const double t2 = theta_sq;
    c.one_minus_cos_over_sq = 1.0 / 2 - t2 * (1.0 / 24 - t2 * (1.0 / 720 - t2 * (1.0 / 40320 - t2 / 3628800)));
    c.theta_minus_sin_over_cu = 1.0 / 6 - t2 * (1.0 / 120 - t2 * (1.0 / 5040 - t2 * (1.0 / 362880 - t2 / 39916800)));
    c.half_sin_over_theta = 1.0 / 2 - t2 * (1.0 / 48 - t2 * (1.0 / 3840 - t2 * (1.0 / 645120 - t2 / 185794560)));
  } else {
    const double s_half = std::sin(0.5 * theta);
    c.one_minus_cos_over_sq = 2.0 * s_half * s_half / theta_sq;
    c.theta_minus_sin_over_cu = (theta - std::sin(theta)) / (theta_sq * theta);
    c.half_sin_over_theta = s_half / theta;
  }
  return c;
}

}  // namespace

Pose section_exp(const Eigen::Vector3d& u, double axial_strain, double length) {
  const Eigen::Vector3d w = u * length;
  const ExpCoefficients c = exp_coefficients(w.squaredNorm());
  const Eigen::Vector3d nu(0.0, 0.0, (1.0 + axial_strain) * length);
  const Eigen::Vector3d w_x_nu = w.cross(nu);
  Pose p;
  p.rotation = Eigen::Quaterniond(c.cos_half, c.half_sin_over_theta * w.x(), c.half_sin_over_theta * w.y(),
                                  c.half_sin_over_theta * w.z());
  p.position = nu + c.one_minus_cos_over_sq * w_x_nu + c.theta_minus_sin_over_cu * w.cross(w_x_nu);
  return p;
}

Eigen::Vector3d rotation_log(const Eigen::Quaterniond& q_in) {
  // Take the representative with w ≥ 0 so the angle is in [0, π].
  const Eigen::Quaterniond q = q_in.w() < 0.0 ? Eigen::Quaterniond(-q_in.coeffs()) : q_in;
  const Eigen::Vector3d v = q.vec();
  const double s = v.norm();
  if (s < 1e-12) return 2.0 * v / q.w();  // angle ≈ 2 s; exact to rounding at this size
  const double angle = 2.0 * std::atan2(s, q.w());
  return v * (angle / s);
}

double rotation_angle_squared(const Eigen::Quaterniond& q) {
  const double s2 = q.vec().squaredNorm();
  if (s2 < 1e-3) {
    // angle = 2 asin(s) = 2 s (1 + s²/6 + 3s⁴/40 + 5s⁶/112 + 35s⁸/1152 + …); the next term is
    // 63 s¹⁰/2816 < 3·10⁻¹⁷ here.
    const double series = 1.0 + s2 * (1.0 / 6.0 + s2 * (3.0 / 40.0 + s2 * (5.0 / 112.0 + s2 * (35.0 / 1152.0))));
    return 4.0 * s2 * series * series;
  }
  return rotation_log(q).squaredNorm();
}

Eigen::Quaterniond rotation_exp(const Eigen::Vector3d& rotation_vector) {
  const ExpCoefficients c = exp_coefficients(rotation_vector.squaredNorm());
  return {c.cos_half, c.half_sin_over_theta * rotation_vector.x(), c.half_sin_over_theta * rotation_vector.y(),
          c.half_sin_over_theta * rotation_vector.z()};
}

Eigen::Quaterniond frame_from_tangent(const Eigen::Vector3d& tangent, const Eigen::Vector3d& normal_hint) {
  const Eigen::Vector3d t = tangent.normalized();
  Eigen::Vector3d d1 = normal_hint - normal_hint.dot(t) * t;
  if (d1.norm() < 1e-9 * std::max(1.0, normal_hint.norm())) {
    // The hint is along the tangent: take the world axis least aligned with it.
    Eigen::Index axis = 0;
    t.cwiseAbs().minCoeff(&axis);
    const Eigen::Vector3d e = Eigen::Vector3d::Unit(axis);
    d1 = e - e.dot(t) * t;
  }
  d1.normalize();
  Eigen::Matrix3d r;
  r.col(0) = d1;
  r.col(1) = t.cross(d1);
  r.col(2) = t;
  return Eigen::Quaterniond(r).normalized();
}

}  // namespace haustra::kernels
