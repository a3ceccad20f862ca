#pragma once
// Closed, consistently oriented triangle cages for the MVC and skinning tests, built here by hand
// so that the tests depend on nothing they check.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <span>
#include <vector>

namespace haustra::test {

struct Cage {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;
};

inline Cage tetrahedron() {
  Cage c;
  c.vertices = {{0.1, -0.2, 0.0}, {1.3, 0.1, 0.2}, {0.2, 1.1, -0.1}, {0.3, 0.4, 1.2}};
  c.triangles = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}};  // outward
  return c;
}

inline Cage box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  Cage c;
  for (int i = 0; i < 8; ++i)
    c.vertices.emplace_back((i & 1) ? hi.x() : lo.x(), (i & 2) ? hi.y() : lo.y(), (i & 4) ? hi.z() : lo.z());
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    c.triangles.push_back(
        {static_cast<std::uint32_t>(q[0]), static_cast<std::uint32_t>(q[1]), static_cast<std::uint32_t>(q[2])});
    c.triangles.push_back(
        {static_cast<std::uint32_t>(q[0]), static_cast<std::uint32_t>(q[2]), static_cast<std::uint32_t>(q[3])});
  }
  return c;
}

// A tube of `rings` rings of `m` vertices along a half circle of radius `bend` (a U: strongly
// non-convex), ring radius `r`, both ends capped with a centre vertex.
inline Cage u_tube(int rings = 9, int m = 6, double bend = 1.0, double r = 0.35) {
  Cage c;
  for (int g = 0; g < rings; ++g) {
    const double phi = std::numbers::pi * g / (rings - 1);
    const Eigen::Vector3d centre(bend * std::cos(phi), bend * std::sin(phi), 0.0);
    const Eigen::Vector3d radial(std::cos(phi), std::sin(phi), 0.0);
    const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
    for (int i = 0; i < m; ++i) {
      const double th = 2.0 * std::numbers::pi * i / m;
      c.vertices.push_back(centre + r * (std::cos(th) * radial + std::sin(th) * up));
    }
  }
  auto id = [&](int g, int i) { return static_cast<std::uint32_t>(g * m + (i % m)); };
  for (int g = 0; g + 1 < rings; ++g)
    for (int i = 0; i < m; ++i) {
      c.triangles.push_back({id(g, i), id(g + 1, i), id(g + 1, i + 1)});
      c.triangles.push_back({id(g, i), id(g + 1, i + 1), id(g, i + 1)});
    }
  const auto first_cap = static_cast<std::uint32_t>(c.vertices.size());
  c.vertices.emplace_back(bend, -0.3 * r, 0.0);
  c.vertices.emplace_back(-bend, -0.3 * r, 0.0);
  for (int i = 0; i < m; ++i) {
    c.triangles.push_back({first_cap, id(0, i), id(0, i + 1)});
    c.triangles.push_back({first_cap + 1, id(rings - 1, i + 1), id(rings - 1, i)});
  }
  return c;
}

// Every edge used once in each direction: closed and consistently oriented.
inline bool closed_and_oriented(const Cage& c) {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> edges;
  for (const auto& t : c.triangles)
    for (int i = 0; i < 3; ++i)
      edges.emplace_back(t[static_cast<std::size_t>(i)], t[static_cast<std::size_t>((i + 1) % 3)]);
  std::sort(edges.begin(), edges.end());
  if (std::adjacent_find(edges.begin(), edges.end()) != edges.end()) return false;
  for (const auto& [a, b] : edges)
    if (!std::binary_search(edges.begin(), edges.end(), std::make_pair(b, a))) return false;
  return true;
}

// Signed volume: positive when the triangles face outward.
inline double signed_volume(const Cage& c) {
  double v = 0.0;
  for (const auto& t : c.triangles) v += c.vertices[t[0]].dot(c.vertices[t[1]].cross(c.vertices[t[2]])) / 6.0;
  return v;
}

// Σ of the solid angles the triangles subtend at p, over 4π (van Oosterom and Strackee): 1 inside a
// closed, outward-oriented surface, 0 outside. Independent of any closest-point or normal logic.
inline double winding_number(std::span<const Eigen::Vector3d> vertices,
                             std::span<const std::array<std::uint32_t, 3>> triangles, const Eigen::Vector3d& p) {
  double total = 0.0;
  for (const auto& t : triangles) {
    const Eigen::Vector3d a = vertices[t[0]] - p, b = vertices[t[1]] - p, d = vertices[t[2]] - p;
    const double la = a.norm(), lb = b.norm(), ld = d.norm();
    const double num = a.dot(b.cross(d));
    const double den = la * lb * ld + a.dot(b) * ld + b.dot(d) * la + d.dot(a) * lb;
    total += 2.0 * std::atan2(num, den);
  }
  return total / (4.0 * std::numbers::pi);
}

inline double winding_number(const Cage& c, const Eigen::Vector3d& p) {
  return winding_number(c.vertices, c.triangles, p);
}

}  // namespace haustra::test
