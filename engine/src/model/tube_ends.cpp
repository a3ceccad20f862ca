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
  // Border half-edges (an edge one triangle uses), followed head to tail. A walk through a vertex
  // where loops touch (a pinch no repair split) may go round several loops: wherever it comes
  // back to a vertex it has passed, the stretch since is a loop of its own, cut off there.
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
  constexpr std::ptrdiff_t kNotOnWalk = -1;
  std::vector<std::ptrdiff_t> place(mesh.vertices.size(), kNotOnWalk);  // a vertex's index in the walk
  std::vector<std::vector<std::uint32_t>> loops;
  for (std::size_t first = 0; first < border.size(); ++first) {
    if (used[first] != 0) continue;
    std::vector<std::uint32_t> walk;
    std::size_t e = first;
    for (;;) {
      used[e] = 1;
      const std::uint32_t from = border[e].first;
      if (place[from] != kNotOnWalk) {  // back at a pinch: the stretch since is one loop
        const auto seen = walk.begin() + place[from];
        for (auto v = seen; v != walk.end(); ++v) place[*v] = kNotOnWalk;
        loops.emplace_back(seen, walk.end());
        walk.erase(seen, walk.end());
      }
      place[from] = static_cast<std::ptrdiff_t>(walk.size());
      walk.push_back(from);
      const std::uint32_t to = border[e].second;
      auto it = std::lower_bound(border.begin(), border.end(), std::pair{to, 0U});
      while (it != border.end() && it->first == to && used[static_cast<std::size_t>(it - border.begin())] != 0) ++it;
      if (it == border.end() || it->first != to) break;
      e = static_cast<std::size_t>(it - border.begin());
    }
    for (std::uint32_t v : walk) place[v] = kNotOnWalk;
    loops.push_back(std::move(walk));
  }
  return loops;
}

LoopShape loop_shape(const TriangleMesh& mesh, const std::vector<std::uint32_t>& loop) {
  LoopShape s;
  if (loop.empty()) return s;
  for (std::uint32_t v : loop) s.centre += mesh.vertices[v];
  s.centre /= static_cast<double>(loop.size());
  for (std::size_t i = 0; i < loop.size(); ++i) {
    s.radius += (mesh.vertices[loop[i]] - s.centre).norm() / static_cast<double>(loop.size());
    s.perimeter += (mesh.vertices[loop[(i + 1) % loop.size()]] - mesh.vertices[loop[i]]).norm();
  }
  return s;
}

std::vector<int> loop_groups(const TriangleMesh& mesh, const std::vector<std::vector<std::uint32_t>>& loops) {
  std::vector<LoopShape> shape;
  for (const auto& loop : loops) shape.push_back(loop_shape(mesh, loop));
  std::vector<int> group(loops.size());
  std::iota(group.begin(), group.end(), 0);
  for (std::size_t a = 0; a < loops.size(); ++a)
    for (std::size_t b = a + 1; b < loops.size(); ++b)
      if ((shape[a].centre - shape[b].centre).norm() < 0.5 * std::max(shape[a].radius, shape[b].radius)) {
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

namespace {

// The search for a tube's two ends over one mesh: its boundary loops, their groups (concentric rims)
// and lengths, the open ends worth ending at, and the surface's edge graph.
class EndSearch {
 public:
  EndSearch(const TriangleMesh& mesh, const std::vector<std::vector<std::uint32_t>>& loops)
      : loops_(loops), adj_(adjacency(mesh)), n_(mesh.vertices.size()), group_(loop_groups(mesh, loops)) {
    for (const auto& loop : loops) perimeter_.push_back(loop_shape(mesh, loop).perimeter);
    loop_of_.assign(n_, -1);
    for (std::size_t l = 0; l < loops.size(); ++l)
      for (std::uint32_t v : loops[l]) loop_of_[v] = static_cast<int>(l);
    ends_ = significant_ends();
  }

  [[nodiscard]] const std::vector<int>& ends() const { return ends_; }
  [[nodiscard]] TubeEnd end(int loop) const { return group_end(loops_, group_, loop); }
  [[nodiscard]] TubeEnd farthest_from_any() const {
    return TubeEnd{{farthest_vertex(dijkstra(adj_, n_, {0}))}, false, {}};
  }

  // From an end: the farthest vertex's own open end when it lies on one (an oblique rim's far
  // side); else the farthest other open end, unless the farthest vertex (a closed end) is a fifth
  // farther again — a hole in the wall along the way is no end of the tube.
  TubeEnd far_end(const TubeEnd& from, double& distance) const {
    const std::vector<double> d = dijkstra(adj_, n_, from.vertices);
    const std::uint32_t tip = farthest_vertex(d);
    const int tip_loop = loop_of_[tip];
    auto own = [&](int e) { return from.open && from.has_loop(static_cast<std::size_t>(e)); };
    for (int e : ends_)
      if (tip_loop >= 0 && group_of(e) == group_of(tip_loop) && !own(e)) {
        distance = d[tip];
        return end(e);
      }
    TubeEnd best;
    distance = -1.0;
    for (int e : ends_) {
      if (own(e) || wall_beyond(e, d)) continue;
      double reach = 0.0;  // to the loop's far side: an obliquely cut rim reaches as far as it goes
      for (std::uint32_t v : loops_[static_cast<std::size_t>(e)]) reach = std::max(reach, d[v]);
      if (reach < kNoPath && reach > distance) {
        distance = reach;
        best = end(e);
      }
    }
    if (distance < 0.0 || d[tip] > 1.2 * distance) {
      distance = d[tip];
      best = TubeEnd{{tip}, false, {}};
    }
    return best;
  }

 private:
  [[nodiscard]] int group_of(int loop) const { return group_[static_cast<std::size_t>(loop)]; }

  // The open ends worth ending at, one loop per group (its first): groups at least a quarter as
  // long as the longest (a hole of a few triangles in the wall is a defect, not an end). A wall of
  // two shells is cut through both at each end, so where two ends have concentric rims, those are
  // the ends (a lone loop is a hole in one shell; the shells, fused here and there, make paths
  // along the surface that are no guide).
  [[nodiscard]] std::vector<int> significant_ends() const {
    const double longest = perimeter_.empty() ? 0.0 : *std::max_element(perimeter_.begin(), perimeter_.end());
    std::vector<int> ends;
    for (std::size_t l = 0; l < loops_.size(); ++l) {
      bool seen = false;
      for (int e : ends) seen = seen || group_of(e) == group_[l];
      if (seen) continue;
      double widest = 0.0;
      for (std::size_t k = 0; k < loops_.size(); ++k)
        if (group_[k] == group_[l]) widest = std::max(widest, perimeter_[k]);
      if (widest >= 0.25 * longest) ends.push_back(static_cast<int>(l));
    }
    std::vector<int> walled;
    for (int e : ends)
      if (std::count(group_.begin(), group_.end(), group_of(e)) >= 2) walled.push_back(e);
    return walled.size() >= 2 ? walled : ends;
  }

  // A hole in the wall has wall beyond it: within twice its perimeter of it (along the surface),
  // the distance `d` runs on past the hole's own by more than three quarters of its perimeter. An
  // open end, oblique as it may be, has nothing beyond it.
  [[nodiscard]] bool wall_beyond(int e, const std::vector<double>& d) const {
    const auto& loop = loops_[static_cast<std::size_t>(e)];
    const double perimeter = perimeter_[static_cast<std::size_t>(e)];
    double reach = kNoPath;
    for (std::uint32_t v : loop) reach = std::min(reach, d[v]);
    const double around = 2.0 * perimeter;
    const std::vector<double> near = dijkstra_within(adj_, n_, loop, around);
    double beyond = reach;
    for (std::size_t v = 0; v < n_; ++v)
      if (near[v] <= around) beyond = std::max(beyond, d[v]);
    return beyond - reach > 0.75 * perimeter;
  }

  const std::vector<std::vector<std::uint32_t>>& loops_;
  Adjacency adj_;
  std::size_t n_;
  std::vector<int> group_;
  std::vector<double> perimeter_;
  std::vector<int> loop_of_;
  std::vector<int> ends_;
};

}  // namespace

std::pair<TubeEnd, TubeEnd> farthest_ends(const TriangleMesh& mesh,
                                          const std::vector<std::vector<std::uint32_t>>& loops,
                                          const std::optional<TubeEnd>& start) {
  const EndSearch search(mesh, loops);
  double distance = 0.0;
  if (start) return {*start, search.far_end(*start, distance)};
  if (search.ends().empty()) {  // closed: two sweeps, the farthest from vertex 0 and the farthest from that
    const TubeEnd a = search.farthest_from_any();
    return {a, search.far_end(a, distance)};
  }
  // Open: the pair of ends farthest apart along the surface.
  std::pair<TubeEnd, TubeEnd> best;
  double farthest = -1.0;
  for (int e : search.ends()) {
    const TubeEnd a = search.end(e);
    TubeEnd b = search.far_end(a, distance);
    if (distance > farthest) {
      farthest = distance;
      best = {a, std::move(b)};
    }
  }
  return best;
}

}  // namespace haustra
