// The orbit camera's geometry: eye from angles, a right-handed look-at with z up, a perspective
// projection, pixels to rays and back.
#include "orbit_camera.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace haustra::view {
namespace {

struct Basis {
  Eigen::Vector3d right, up, forward;
};

Basis basis(const OrbitCamera& c) {
  const Eigen::Vector3d f = c.forward();
  Eigen::Vector3d r = f.cross(Eigen::Vector3d::UnitZ());
  if (r.norm() < 1e-9) r = Eigen::Vector3d::UnitX();
  r.normalize();
  return {r, r.cross(f).normalized(), f};
}

double tan_half_fov(const OrbitCamera& c) { return std::tan(0.5 * c.fov_degrees * std::numbers::pi / 180.0); }
double aspect(const OrbitCamera& c) { return static_cast<double>(c.width) / std::max(c.height, 1); }

}  // namespace

Eigen::Vector3d OrbitCamera::forward() const {
  return -Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
                          std::sin(elevation));
}

Eigen::Vector3d OrbitCamera::eye() const { return target - distance * forward(); }

Eigen::Matrix4f OrbitCamera::view_projection() const {
  const Basis b = basis(*this);
  const Eigen::Vector3d e = eye();
  Eigen::Matrix4d view = Eigen::Matrix4d::Identity();
  view.block<1, 3>(0, 0) = b.right.transpose();
  view.block<1, 3>(1, 0) = b.up.transpose();
  view.block<1, 3>(2, 0) = -b.forward.transpose();
  view(0, 3) = -b.right.dot(e);
  view(1, 3) = -b.up.dot(e);
  view(2, 3) = b.forward.dot(e);
  const double n = 0.01 * distance, f = 100.0 * distance, t = tan_half_fov(*this);
  Eigen::Matrix4d proj = Eigen::Matrix4d::Zero();
  proj(0, 0) = 1.0 / (t * aspect(*this));
  proj(1, 1) = 1.0 / t;
  proj(2, 2) = -(f + n) / (f - n);
  proj(2, 3) = -2.0 * f * n / (f - n);
  proj(3, 2) = -1.0;
  return (proj * view).cast<float>();
}

Ray OrbitCamera::ray(double x, double y) const {
  const Basis b = basis(*this);
  const double t = tan_half_fov(*this);
  const double u = (2.0 * x / width - 1.0) * t * aspect(*this);
  const double v = (1.0 - 2.0 * y / height) * t;
  return {eye(), (b.forward + u * b.right + v * b.up).normalized()};
}

Eigen::Vector2d OrbitCamera::project(const Eigen::Vector3d& p) const {
  const Basis b = basis(*this);
  const Eigen::Vector3d d = p - eye();
  const double depth = d.dot(b.forward), t = tan_half_fov(*this);
  const double u = d.dot(b.right) / (depth * t * aspect(*this)), v = d.dot(b.up) / (depth * t);
  return {0.5 * (u + 1.0) * width, 0.5 * (1.0 - v) * height};
}

void OrbitCamera::orbit(double dx, double dy) {
  azimuth -= 0.005 * dx;
  elevation = std::clamp(elevation + 0.005 * dy, -1.5, 1.5);
}

void OrbitCamera::pan(double dx, double dy) {
  const Basis b = basis(*this);
  const double metres_per_pixel = 2.0 * distance * tan_half_fov(*this) / height;
  target += metres_per_pixel * (-dx * b.right + dy * b.up);
}

void OrbitCamera::zoom(double steps) { distance = std::clamp(distance * std::pow(0.9, steps), 1e-3, 1e4); }

void OrbitCamera::fit(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double free_width) {
  target = 0.5 * (lo + hi);
  const double radius = std::max(0.5 * (hi - lo).norm(), 0.02);
  const double shown = free_width > 0.0 ? std::min(free_width, static_cast<double>(width)) / height : aspect(*this);
  const double half = std::atan(tan_half_fov(*this) * std::min(1.0, shown));
  distance = 1.1 * radius / std::sin(half);
}

Eigen::Vector3d intersect_plane(const Ray& ray, const Eigen::Vector3d& point, const Eigen::Vector3d& normal) {
  const double denom = ray.direction.dot(normal);
  if (std::abs(denom) < 1e-12) return ray.origin;
  return ray.origin + ((point - ray.origin).dot(normal) / denom) * ray.direction;
}

}  // namespace haustra::view
