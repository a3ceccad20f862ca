#pragma once
// Closest points and sphere contacts with simple shapes: what the narrow phase and the penalty
// force need (penetration depth and the separating direction).
#include <Eigen/Core>

namespace haustra::kernels {

// The point of triangle (a, b, c) closest to p (Ericson, Real-Time Collision Detection, 5.1.5).
[[nodiscard]] Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                                        const Eigen::Vector3d& b, const Eigen::Vector3d& c);

// The point of segment [a, b] closest to p.
[[nodiscard]] Eigen::Vector3d closest_point_on_segment(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                                       const Eigen::Vector3d& b);

struct SphereContact {
  double depth = 0.0;                                 // > 0: the spheres overlap by this much
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // pushes the first sphere out
};

// A sphere (centre c, radius r) against another sphere (centre o, radius ro). Coincident centres
// separate along +z.
[[nodiscard]] SphereContact sphere_sphere(const Eigen::Vector3d& c, double r, const Eigen::Vector3d& o, double ro);

// Against the half-space behind a plane through `point` with unit `normal` (the free side is +normal).
[[nodiscard]] SphereContact sphere_plane(const Eigen::Vector3d& c, double r, const Eigen::Vector3d& point,
                                         const Eigen::Vector3d& normal);

// Against a capsule: segment [a, b] grown by radius ra.
[[nodiscard]] SphereContact sphere_capsule(const Eigen::Vector3d& c, double r, const Eigen::Vector3d& a,
                                           const Eigen::Vector3d& b, double ra);

// The paper's penalty (eq. 13), generalized: f = coefficient × E × depth^exponent, and its
// derivative with respect to depth (the contact stiffness an implicit solve needs).
struct Penalty {
  double force = 0.0;
  double stiffness = 0.0;
};
[[nodiscard]] Penalty contact_penalty(double depth, double coefficient_times_e, double exponent);

}  // namespace haustra::kernels
