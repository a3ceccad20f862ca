// Closest points, sphere contacts with spheres, planes and capsules, and the contact penalty.
#include "haustra/kernels/contact_geometry.hpp"

#include <algorithm>
#include <cmath>

namespace haustra::kernels {

Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                          const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return a + (d1 / (d1 - d3)) * ab;
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

Eigen::Vector3d closest_point_on_segment(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double len2 = ab.squaredNorm();
  if (!(len2 > 0.0)) return a;
  return a + std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) * ab;
}

SphereContact sphere_sphere(const Eigen::Vector3d& c, double r, const Eigen::Vector3d& o, double ro) {
  const Eigen::Vector3d d = c - o;
  const double dist = d.norm();
  SphereContact k;
  k.depth = r + ro - dist;
  k.normal = dist > 0.0 ? Eigen::Vector3d(d / dist) : Eigen::Vector3d::UnitZ();
  return k;
}

SphereContact sphere_plane(const Eigen::Vector3d& c, double r, const Eigen::Vector3d& point,
                           const Eigen::Vector3d& normal) {
  return {r - (c - point).dot(normal), normal};
}

SphereContact sphere_capsule(const Eigen::Vector3d& c, double r, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                             double ra) {
  return sphere_sphere(c, r, closest_point_on_segment(c, a, b), ra);
}

Penalty contact_penalty(double depth, double k, double exponent) {
  if (!(depth > 0.0)) return {};
  const double f = k * std::pow(depth, exponent);
  return {f, exponent * f / depth};
}

}  // namespace haustra::kernels
