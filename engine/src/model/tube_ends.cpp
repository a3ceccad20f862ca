// A tube's ends: its boundary loops, grouped where concentric, and the two ends farthest apart.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "haustra/error.hpp"
#include "haustra/tube_axis.hpp"
#include "model/surface_graph.hpp"

namespace haustra {
namespace {

using detail::adjacency;
using detail::Adjacency;
using detail::dijkstra;
using detail::dijkstra_within;
using detail::edge_key;
using detail::farthest_vertex;
using detail::kNoPath;

TubeEnd group_end(const std::vector<std::vector<std::uint32_t>>& loops, const std::vector<int>& group, int loop) {
  TubeEnd e;
  e.open = true;
  for (std::size_t l = 0; l < loops.size(); ++l)
    if (group[l] == group[static_cast<std::size_t>(loop)]) {
      e.loops.push_back(static_cast<int>(l));
      e.vertices.insert(e.vertices.end(), loops[l].begin(), loops[l].end());
    }
  return e;
}

}  // namespace

std::vector<std::vector<std::uint32_t>> boundary_loops(const TriangleMesh& mesh) {
  // Border half-edges (an edge one triangle uses), followed head to tail; a vertex where two loops
  // touch (a pinch the repair did not split) starts a new loop at the lower unused half-edge.
  std::vector<std::pair<std::uint64_t, std::uint32_t>> half;  // (edge key, triangle·3 + corner)
  half.reserve(3 * mesh.triangles.size());
  for (std::uint32_t t = 0; t < mesh.triangles.size(); ++t)
    for (std::uint32_t i = 0; i < 3; ++i)
      half.emplace_back(edge_key(mesh.triangles[t][i], mesh.triangles[t][(i + 1) % 3]), 3 * t + i);
  std::sort(half.begin(), half.end());
  std::vector<std::pair<std::uint32_t, std::uint32_t>> border;  // (from, to) in the triangle's winding
  for (std::size_t i = 0; i < half.size();) {
    std::size_t j = i + 1;
    while (j < half.size() && half[j].first == half[i].first) ++j;
    if (j - i == 1) {
      const std::uint32_t t = half[i].second / 3, c = half[i].second % 3;
      border.emplace_back(mesh.triangles[t][c], mesh.triangles[t][(c + 1) % 3]);
    }
    i = j;
  }
  std::sort(border.begin(), border.end());
  std::vector<std::uint8_t> used(border.size(), 0);
  std::vector<std::vector<std::uint32_t>> loops;
  for (std::size_t first = 0; first < border.size(); ++first) {
    if (used[first] != 0) continue;
    std::vector<std::uint32_t> loop;
    std::size_t e = first;
    for (;;) {
      used[e] = 1;
      loop.push_back(border[e].first);
      const std::uint32_t to = border[e].second;
      auto it = std::lower_bound(border.begin(), border.end(), std::pair{to, 0U});
      while (it != border.end() && it->first == to && used[static_cast<std::size_t>(it - border.begin())] != 0) ++it;
      if (it == border.end() || it->first != to) break;
      e = static_cast<std::size_t>(it - border.begin());
    }
    loops.push_back(std::move(loop));
  }
  return loops;
}

std::vector<int> loop_groups(const TriangleMesh& mesh, const std::vector<std::vector<std::uint32_t>>& loops) {
  std::vector<Eigen::Vector3d> centre(loops.size(), Eigen::Vector3d::Zero());
  std::vector<double> radius(loops.size(), 0.0);
  for (std::size_t l = 0; l < loops.size(); ++l) {
    for (std::uint32_t v : loops[l]) centre[l] += mesh.vertices[v];
    centre[l] /= static_cast<double>(loops[l].size());
    for (std::uint32_t v : loops[l]) radius[l] += (mesh.vertices[v] - centre[l]).norm();
    radius[l] /= static_cast<double>(loops[l].size());
  }
  std::vector<int> group(loops.size());
  std::iota(group.begin(), group.end(), 0);
  for (std::size_t a = 0; a < loops.size(); ++a)
    for (std::size_t b = a + 1; b < loops.size(); ++b)
      if ((centre[a] - centre[b]).norm() < 0.5 * std::max(radius[a], radius[b])) {
        const int from = group[b], to = group[a];
        for (int& g : group)
          if (g == from) g = to;
      }
  return group;
}

TubeEnd loop_end(const TriangleMesh& mesh, const std::vector<std::vector<std::uint32_t>>& loops, int loop) {
  return group_end(loops, loop_groups(mesh, loops), loop);
}

std::vector<double> edge_distances(const TriangleMesh& mesh, const std::vector<std::uint32_t>& from) {
  return dijkstra(adjacency(mesh), mesh.vertices.size(), from);
}

std::pair<TubeEnd, TubeEnd> farthest_ends(const TriangleMesh& mesh, const std::vector<std::vector<std::uint32_t>>& loops,
                                          const std::optional<TubeEnd>& start) {
  const Adjacency adj = adjacency(mesh);
  const std::size_t n = mesh.vertices.size();
  const std::vector<int> group = loop_groups(mesh, loops);
  // The open ends worth ending at: groups of loops at least a quarter as long as the longest
  // (a hole of a few triangles in the wall is a defect, not an end).
  std::vector<double> perimeter(loops.size(), 0.0);
  for (std::size_t l = 0; l < loops.size(); ++l)
    for (std::size_t i = 0; i < loops[l].size(); ++i)
      perimeter[l] += (mesh.vertices[loops[l][(i + 1) % loops[l].size()]] - mesh.vertices[loops[l][i]]).norm();
  const double longest = loops.empty() ? 0.0 : *std::max_element(perimeter.begin(), perimeter.end());
  std::vector<int> ends;  // one loop per significant group, the group's first
  for (std::size_t l = 0; l < loops.size(); ++l) {
    bool seen = false;
    for (int e : ends) seen = seen || group[static_cast<std::size_t>(e)] == group[l];
    if (seen) continue;
    double widest = 0.0;
    for (std::size_t k = 0; k < loops.size(); ++k)
      if (group[k] == group[l]) widest = std::max(widest, perimeter[k]);
    if (widest >= 0.25 * longest) ends.push_back(static_cast<int>(l));
  }
  // A wall of two shells is cut through both at each end, so where two ends have concentric
  // rims, those are the ends (a lone loop is a hole in one shell; the shells, fused here and
  // there, make paths along the surface that are no guide).
  std::vector<int> walled;
  for (int e : ends)
    if (std::count(group.begin(), group.end(), group[static_cast<std::size_t>(e)]) >= 2) walled.push_back(e);
  if (walled.size() >= 2) ends = walled;
  // From an end: the farthest vertex's own open end when it lies on one (an oblique rim's far
  // side); else the farthest other open end, unless the farthest vertex (a closed end) is a fifth
  // farther again — a hole in the wall along the way is no end of the tube.
  std::vector<int> loop_of(n, -1);
  for (std::size_t l = 0; l < loops.size(); ++l)
    for (std::uint32_t v : loops[l]) loop_of[v] = static_cast<int>(l);
  // A hole in the wall has wall beyond it: within twice its perimeter of it (along the surface),
  // the distance from `from` runs on past the hole's own by more than three quarters of its
  // perimeter. An open end, oblique as it may be, has nothing beyond it.
  auto wall_beyond = [&](int e, const std::vector<double>& d) {
    const auto& loop = loops[static_cast<std::size_t>(e)];
    double reach = kNoPath;
    for (std::uint32_t v : loop) reach = std::min(reach, d[v]);
    const double around = 2.0 * perimeter[static_cast<std::size_t>(e)];
    const std::vector<double> near = dijkstra_within(adj, n, loop, around);
    double beyond = reach;
    for (std::size_t v = 0; v < n; ++v)
      if (near[v] <= around) beyond = std::max(beyond, d[v]);
    return beyond - reach > 0.75 * perimeter[static_cast<std::size_t>(e)];
  };
  auto far_end = [&](const TubeEnd& from, double& distance) {
    const std::vector<double> d = dijkstra(adj, n, from.vertices);
    const std::uint32_t tip = farthest_vertex(d);
    const int tip_loop = loop_of[tip];
    for (int e : ends)
      if (tip_loop >= 0 && group[static_cast<std::size_t>(e)] == group[static_cast<std::size_t>(tip_loop)] &&
          !(from.open && from.has_loop(static_cast<std::size_t>(e)))) {
        distance = d[tip];
        return group_end(loops, group, e);
      }
    TubeEnd best;
    distance = -1.0;
    for (int e : ends) {
      if (from.open && from.has_loop(static_cast<std::size_t>(e))) continue;
      if (wall_beyond(e, d)) continue;
      double reach = 0.0;  // to the loop's far side: an obliquely cut rim reaches as far as it goes
      for (std::uint32_t v : loops[static_cast<std::size_t>(e)]) reach = std::max(reach, d[v]);
      if (reach < kNoPath && reach > distance) {
        distance = reach;
        best = group_end(loops, group, e);
      }
    }
    if (distance < 0.0 || d[tip] > 1.2 * distance) {
      distance = d[tip];
      best = TubeEnd{{tip}, false, {}};
    }
    return best;
  };
  double distance = 0.0;
  if (start) return {*start, far_end(*start, distance)};
  if (ends.empty()) {
    // Closed: two sweeps, the farthest from vertex 0 and the farthest from that.
    const TubeEnd a{{farthest_vertex(dijkstra(adj, n, {0}))}, false, {}};
    return {a, far_end(a, distance)};
  }
  std::pair<TubeEnd, TubeEnd> best;
  double farthest = -1.0;
  for (int e : ends) {
    const TubeEnd a = group_end(loops, group, e);
    TubeEnd b = far_end(a, distance);
    if (distance > farthest) {
      farthest = distance;
      best = {a, std::move(b)};
    }
  }
  return best;
}

}  // namespace haustra
