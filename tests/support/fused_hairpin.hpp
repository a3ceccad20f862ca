#pragma once
// A procedural tube whose loop is fused where it starts, as loops of the atlas's small intestine are
// where they touch (decision 0113): for the tube axis and the import's centreline.
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <utility>
#include <vector>

#include "haustra/mesh_io.hpp"

namespace haustra::test {

// A tube of radius r (rings of 16 vertices, 12 to its half turn) along a hairpin: in along +x for 60
// rings, `leg_rings` more, half a turn of diameter d, back along -x beside itself and out; the two
// legs fused where the loop starts (the walls facing each other cut away over 8 rings and 6 of 16
// sectors, the two rims joined by a short sleeve). `axis` gets the tube's own centreline.
inline TriangleMesh fused_hairpin(double r, double d, int leg_rings, std::vector<Eigen::Vector3d>& axis) {
  constexpr int m = 16, w = 4, q = 3, sleeve = 3;
  const double h = std::numbers::pi * d / 2.0 / 12.0, straight = 60.0 * h, leg = leg_rings * h;
  const double turn = std::numbers::pi * d / 2.0, total = 2.0 * (straight + leg) + turn;
  const int rings = static_cast<int>(std::lround(total / h)) + 1;
  TriangleMesh mesh;
  for (int i = 0; i < rings; ++i) {
    const double s = i * h;
    Eigen::Vector3d c, t;
    if (s <= straight + leg) {
      c = {s - straight, 0, 0}, t = {1, 0, 0};
    } else if (s <= straight + leg + turn) {
      const double a = (s - straight - leg) / (d / 2.0);
      c = {leg + d / 2.0 * std::sin(a), d / 2.0 * (1.0 - std::cos(a)), 0}, t = {std::cos(a), std::sin(a), 0};
    } else {
      c = {leg - (s - straight - leg - turn), d, 0}, t = {-1, 0, 0};
    }
    axis.push_back(c);
    const Eigen::Vector3d n = Eigen::Vector3d::UnitZ().cross(t);
    for (int j = 0; j < m; ++j) {
      const double th = 2.0 * std::numbers::pi * j / m;
      mesh.vertices.push_back(c + r * (std::cos(th) * n + std::sin(th) * Eigen::Vector3d::UnitZ()));
    }
  }
  const int in = static_cast<int>(std::lround(straight / h)), out = rings - 1 - in;  // the legs' rings at x = 0
  auto vertex = [&](int i, int j) { return static_cast<std::uint32_t>(i * m + ((j % m) + m) % m); };
  auto in_window = [&](int i, int j) {
    const int jj = j < m / 2 ? j : j - m;
    return jj >= -q && jj < q && ((i >= in - w && i < in + w) || (i >= out - w && i < out + w));
  };
  for (int i = 0; i + 1 < rings; ++i)
    for (int j = 0; j < m; ++j)
      if (!in_window(i, j)) {
        mesh.triangles.push_back({vertex(i, j), vertex(i, j + 1), vertex(i + 1, j + 1)});
        mesh.triangles.push_back({vertex(i, j), vertex(i + 1, j + 1), vertex(i + 1, j)});
      }
  // The window's rim on the first leg, and the same points on the second (mirrored across the gap).
  std::vector<std::pair<int, int>> rim;
  for (int k = -q; k < q; ++k) rim.emplace_back(in - w, k);
  for (int i = in - w; i < in + w; ++i) rim.emplace_back(i, q);
  for (int k = q; k > -q; --k) rim.emplace_back(in + w, k);
  for (int i = in + w; i > in - w; --i) rim.emplace_back(i, -q);
  std::vector<std::uint32_t> from, to, prev;
  for (auto [i, j] : rim) {
    from.push_back(vertex(i, j));
    to.push_back(vertex(out - (i - in), j));
  }
  prev = from;
  const std::size_t n = rim.size();
  for (int l = 1; l <= sleeve; ++l) {
    std::vector<std::uint32_t> cur = to;
    if (l < sleeve)
      for (std::size_t k = 0; k < n; ++k) {
        cur[k] = static_cast<std::uint32_t>(mesh.vertices.size());
        mesh.vertices.push_back(mesh.vertices[from[k]] + (mesh.vertices[to[k]] - mesh.vertices[from[k]]) * l / sleeve);
      }
    for (std::size_t k = 0; k < n; ++k) {
      mesh.triangles.push_back({prev[k], prev[(k + 1) % n], cur[(k + 1) % n]});
      mesh.triangles.push_back({prev[k], cur[(k + 1) % n], cur[k]});
    }
    prev = cur;
  }
  // The window's inner vertices are no longer on the surface: dropped.
  std::vector<std::int64_t> index(mesh.vertices.size(), -1);
  TriangleMesh used;
  for (auto& t : mesh.triangles)
    for (auto& v : t) {
      if (index[v] < 0) {
        index[v] = static_cast<std::int64_t>(used.vertices.size());
        used.vertices.push_back(mesh.vertices[v]);
      }
      v = static_cast<std::uint32_t>(index[v]);
    }
  used.triangles = mesh.triangles;
  return used;
}

}  // namespace haustra::test
