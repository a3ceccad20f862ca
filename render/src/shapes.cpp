// Tubes, spheres, capsules as triangle soups with per-vertex normals; the colour map.
#include "haustra/render/shapes.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>

namespace haustra::render {

Rgb mix(Rgb a, Rgb b, float t) { return {a.r + (b.r - a.r) * t, a.g + (b.g - a.g) * t, a.b + (b.b - a.b) * t}; }

Rgb colormap(double t) {
  static const Rgb stops[5] = {{0.07f, 0.02f, 0.25f},
                               {0.05f, 0.22f, 0.45f},
                               {0.04f, 0.45f, 0.40f},
                               {0.35f, 0.70f, 0.15f},
                               {0.98f, 0.85f, 0.05f}};
  t = std::clamp(t, 0.0, 1.0) * 4.0;
  const int i = std::min(3, static_cast<int>(t));
  return mix(stops[i], stops[i + 1], static_cast<float>(t - i));
}

// An orthonormal pair across `axis`.
std::pair<Eigen::Vector3d, Eigen::Vector3d> across(const Eigen::Vector3d& axis) {
  Eigen::Vector3d a = axis.unitOrthogonal();
  return {a, axis.cross(a).normalized()};
}

void add_tube(Soup& g, const std::vector<Eigen::Vector3d>& points, double radius, int sides) {
  if (points.size() < 2) return;
  Eigen::Vector3d prev_side = Eigen::Vector3d::Zero();
  std::vector<std::uint32_t> ring_start;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d t = (points[std::min(i + 1, points.size() - 1)] - points[i > 0 ? i - 1 : 0]).normalized();
    // Parallel transport of the side vector keeps the tube from twisting.
    Eigen::Vector3d side = i == 0 ? across(t).first : (prev_side - prev_side.dot(t) * t).normalized();
    if (!side.allFinite() || side.norm() < 0.5) side = across(t).first;
    prev_side = side;
    const Eigen::Vector3d up = t.cross(side);
    ring_start.push_back(static_cast<std::uint32_t>(g.vertices.size()));
    for (int k = 0; k < sides; ++k) {
      const double a = 2.0 * std::numbers::pi * k / sides;
      const Eigen::Vector3d n = std::cos(a) * side + std::sin(a) * up;
      g.vertices.push_back(points[i] + radius * n);
      g.normals.push_back(n);
    }
  }
  for (std::size_t i = 0; i + 1 < points.size(); ++i)
    for (int k = 0; k < sides; ++k) {
      const std::uint32_t a = ring_start[i] + static_cast<std::uint32_t>(k);
      const std::uint32_t b = ring_start[i] + static_cast<std::uint32_t>((k + 1) % sides);
      const std::uint32_t c = ring_start[i + 1] + static_cast<std::uint32_t>(k);
      const std::uint32_t d = ring_start[i + 1] + static_cast<std::uint32_t>((k + 1) % sides);
      g.triangles.push_back({a, b, c});
      g.triangles.push_back({c, b, d});
    }
}

void add_sphere(Soup& g, const Eigen::Vector3d& centre, double radius, int bands) {
  const auto first = static_cast<std::uint32_t>(g.vertices.size());
  const int around = 2 * bands;
  for (int i = 0; i <= bands; ++i) {
    const double phi = std::numbers::pi * i / bands;
    for (int k = 0; k < around; ++k) {
      const double th = 2.0 * std::numbers::pi * k / around;
      const Eigen::Vector3d n(std::sin(phi) * std::cos(th), std::sin(phi) * std::sin(th), std::cos(phi));
      g.vertices.push_back(centre + radius * n);
      g.normals.push_back(n);
    }
  }
  for (int i = 0; i < bands; ++i)
    for (int k = 0; k < around; ++k) {
      const auto a = first + static_cast<std::uint32_t>(i * around + k);
      const auto b = first + static_cast<std::uint32_t>(i * around + (k + 1) % around);
      const auto c = a + static_cast<std::uint32_t>(around), d = b + static_cast<std::uint32_t>(around);
      g.triangles.push_back({a, c, b});
      g.triangles.push_back({b, c, d});
    }
}

void add_capsule(Soup& g, const Eigen::Vector3d& a, const Eigen::Vector3d& b, double radius) {
  add_tube(g, {a, b}, radius, 16);
  add_sphere(g, a, radius, 6);
  add_sphere(g, b, radius, 6);
}

}  // namespace haustra::render
