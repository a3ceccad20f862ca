// The viewer's drawn levels of detail (tools/view/src/organ_lod.hpp) on a closed torus: level 0 is
// the mesh itself, each coarser level has about a quarter of the triangles (until the rings shared
// between chunks are most of what is left), any mix of levels over
// the chunks stays closed (no cracks), every original vertex lies within a cell of a drawn one,
// and the per-frame choice keeps to its budget, refines what is near first and drops what is
// behind the eye.
#include <doctest/doctest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <set>
#include <vector>

#include "../../tools/view/src/organ_lod.hpp"

namespace {

using haustra::view::OrganLod;
using Triangle = std::array<std::uint32_t, 3>;

struct Torus {
  std::vector<Eigen::Vector3d> positions, normals, nodes;
  std::vector<Triangle> triangles;
  std::vector<std::uint32_t> vertex_node;
};

// Major radius R about z, minor radius r; `around` × `across` vertices; `node_count` nodes on the
// centre circle (each vertex's node the nearest).
Torus torus(double R, double r, int around, int across, int node_count) {
  Torus t;
  for (int k = 0; k < node_count; ++k) {
    const double a = 2.0 * std::numbers::pi * k / node_count;
    t.nodes.emplace_back(R * std::cos(a), R * std::sin(a), 0.0);
  }
  for (int i = 0; i < around; ++i)
    for (int j = 0; j < across; ++j) {
      const double a = 2.0 * std::numbers::pi * i / around, b = 2.0 * std::numbers::pi * j / across;
      const Eigen::Vector3d radial(std::cos(a), std::sin(a), 0.0);
      const Eigen::Vector3d n = std::cos(b) * radial + std::sin(b) * Eigen::Vector3d::UnitZ();
      t.positions.push_back(R * radial + r * n);
      t.normals.push_back(n);
      t.vertex_node.push_back(
          static_cast<std::uint32_t>(std::lround(a / (2.0 * std::numbers::pi) * node_count) % node_count));
    }
  auto id = [&](int i, int j) {
    return static_cast<std::uint32_t>(((i + around) % around) * across + (j + across) % across);
  };
  for (int i = 0; i < around; ++i)
    for (int j = 0; j < across; ++j) {
      t.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      t.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return t;
}

// The drawn triangles (mesh vertex indices) with chunk c at level levels[c].
std::vector<Triangle> drawn(const OrganLod& lod, const std::vector<int>& levels) {
  std::vector<Triangle> out;
  for (std::size_t c = 0; c < lod.chunks.size(); ++c) {
    if (levels[c] < 0) continue;
    const auto& b = lod.chunks[c].levels[static_cast<std::size_t>(levels[c])];
    for (std::uint32_t i = 0; i < b.index_count; i += 3)
      out.push_back({lod.source[b.first_vertex + lod.indices[b.first_index + i]],
                     lod.source[b.first_vertex + lod.indices[b.first_index + i + 1]],
                     lod.source[b.first_vertex + lod.indices[b.first_index + i + 2]]});
  }
  return out;
}

// Edges used an odd number of times: none on a closed surface.
std::size_t open_edges(const std::vector<Triangle>& triangles) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> uses;
  for (const Triangle& t : triangles)
    for (int e = 0; e < 3; ++e) {
      const std::uint32_t a = t[static_cast<std::size_t>(e)], b = t[static_cast<std::size_t>((e + 1) % 3)];
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  return static_cast<std::size_t>(
      std::count_if(uses.begin(), uses.end(), [](const auto& u) { return u.second % 2 == 1; }));
}

}  // namespace

TEST_CASE("the organ's levels of detail: a quarter of the triangles a level, closed in any mix, within a cell") {
  const Torus t = torus(0.1, 0.02, 240, 48, 120);  // 11,520 vertices, 23,040 triangles, edges ~2.6 mm
  const OrganLod lod =
      haustra::view::build_organ_lod(t.positions, t.normals, t.triangles, t.vertex_node, t.nodes, 2000);
  REQUIRE(lod.chunks.size() >= 10);
  CHECK(lod.mean_edge == doctest::Approx(0.0029).epsilon(0.15));
  // Level 0 is the mesh.
  std::vector<int> levels(lod.chunks.size(), 0);
  auto level0 = drawn(lod, levels), original = t.triangles;
  auto sorted = [](std::vector<Triangle> v) {
    std::sort(v.begin(), v.end());
    return v;
  };
  CHECK(sorted(level0) == sorted(original));
  std::size_t previous = level0.size();
  for (int level = 1; level < haustra::view::kLodLevels; ++level) {
    std::fill(levels.begin(), levels.end(), level);
    const auto tris = drawn(lod, levels);
    INFO("level " << level << ": " << tris.size() << " triangles after " << previous);
    // Cells twice as wide: about a quarter of the vertices, until the rings a chunk shares with its
    // neighbours (kept at every level) are most of what is left.
    if (level <= 2) {
      CHECK(tris.size() < previous / 2);
      CHECK(tris.size() > previous / 8);
    } else {
      CHECK(tris.size() <= previous);
    }
    CHECK(open_edges(tris) == 0);
    // Every vertex of the mesh within a cell's diagonal of a drawn vertex (nothing left uncovered).
    std::set<std::uint32_t> kept;
    for (const Triangle& tri : tris) kept.insert(tri.begin(), tri.end());
    double worst = 0.0;
    for (const Eigen::Vector3d& p : t.positions) {
      double nearest = 1e300;
      for (std::uint32_t v : kept) nearest = std::min(nearest, (t.positions[v] - p).norm());
      worst = std::max(worst, nearest);
    }
    CHECK(worst <= std::sqrt(3.0) * lod.cell(level));
    CHECK(worst >= 0.2 * lod.cell(level));  // the bound is not empty: vertices do move
    previous = tris.size();
  }
  CHECK(previous < t.triangles.size() / 10);  // the coarsest: 1,560 of 23,040 when measured
  // Mixed: neighbouring chunks at any two levels meet without a crack.
  for (int shift = 0; shift < 5; ++shift) {
    for (std::size_t c = 0; c < levels.size(); ++c) levels[c] = static_cast<int>((c * 3 + shift) % 5);
    CHECK(open_edges(drawn(lod, levels)) == 0);
  }
}

TEST_CASE("the organ's levels chosen a frame: within the budget, the near part finest, what is behind left out") {
  const Torus t = torus(0.1, 0.02, 240, 48, 120);
  const OrganLod lod =
      haustra::view::build_organ_lod(t.positions, t.normals, t.triangles, t.vertex_node, t.nodes, 2000);
  // The eye just outside the ring on +x, looking along -x at a 35 degree field of view.
  const Eigen::Vector3d eye(0.16, 0.0, 0.0), target(0.0, 0.0, 0.0);
  const Eigen::Vector3d f = (target - eye).normalized(), up = Eigen::Vector3d::UnitZ(), s = f.cross(up).normalized(),
                        u = s.cross(f);
  Eigen::Matrix4d view = Eigen::Matrix4d::Identity();
  view.block<1, 3>(0, 0) = s.transpose();
  view.block<1, 3>(1, 0) = u.transpose();
  view.block<1, 3>(2, 0) = -f.transpose();
  view(0, 3) = -s.dot(eye);
  view(1, 3) = -u.dot(eye);
  view(2, 3) = f.dot(eye);
  const double fov = 35.0 * std::numbers::pi / 180.0, aspect = 16.0 / 9.0, n = 0.001, far = 10.0;
  Eigen::Matrix4d projection = Eigen::Matrix4d::Zero();
  projection(0, 0) = 1.0 / (aspect * std::tan(fov / 2));
  projection(1, 1) = 1.0 / std::tan(fov / 2);
  projection(2, 2) = -(far + n) / (far - n);
  projection(2, 3) = -2.0 * far * n / (far - n);
  projection(3, 2) = -1.0;
  const haustra::view::LodView lod_view{projection * view, eye, 720.0 / fov};
  std::vector<int> levels(lod.chunks.size());
  auto triangles_at = [&](const std::vector<int>& ls) {
    std::size_t sum = 0;
    for (std::size_t c = 0; c < ls.size(); ++c)
      if (ls[c] >= 0) sum += lod.chunks[c].levels[static_cast<std::size_t>(ls[c])].index_count / 3;
    return sum;
  };
  // A generous budget: everything in view at full detail where a cell would span a pixel or more.
  haustra::view::choose_lod_levels(lod, t.nodes, lod_view, 1'000'000, levels);
  // The chunk at +x (under the eye) is in view; the ring's far side is in front of the eye too, so
  // nothing here is behind. A tight budget coarsens, keeps to it and still refines the near chunk
  // most.
  const std::size_t full = triangles_at(levels);
  CHECK(full > 0);
  for (std::size_t budget : {4000u, 8000u, 12000u}) {
    haustra::view::choose_lod_levels(lod, t.nodes, lod_view, budget, levels);
    INFO("budget " << budget);
    CHECK(triangles_at(levels) <= budget);
    CHECK(triangles_at(levels) > budget / 2);  // it spends the budget
    // The chunk nearest the eye is at least as fine as the one farthest away.
    std::size_t near = 0, far_chunk = 0;
    auto distance = [&](std::size_t c) {
      return (t.nodes[lod.chunks[c].first_node + lod.chunks[c].node_count / 2] - eye).norm();
    };
    for (std::size_t c = 0; c < levels.size(); ++c) {
      if (distance(c) < distance(near)) near = c;
      if (distance(c) > distance(far_chunk)) far_chunk = c;
    }
    CHECK(levels[near] <= levels[far_chunk]);
    CHECK(levels[near] < haustra::view::kLodLevels - 1);
  }
  // Turned around (looking along +x from the same eye): the whole ring is behind, nothing drawn.
  const Eigen::Matrix4d turn = Eigen::Vector4d(-1.0, 1.0, -1.0, 1.0).asDiagonal();  // 180 degrees about up
  Eigen::Matrix4d back_view = view;
  back_view.block<3, 4>(0, 0) = (turn.block<3, 3>(0, 0) * view.block<3, 4>(0, 0)).eval();
  haustra::view::choose_lod_levels(lod, t.nodes, {projection * back_view, eye, 720.0 / fov}, 1'000'000, levels);
  CHECK(std::count(levels.begin(), levels.end(), -1) == static_cast<std::ptrdiff_t>(levels.size()));
}
