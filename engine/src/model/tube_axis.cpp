// A tube's axis from a harmonic function on its surface: ends, the solve, level contours, centroids.
#include "haustra/tube_axis.hpp"

#include <fmt/format.h>

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <queue>

#include "haustra/error.hpp"

namespace haustra {
namespace {

using Triangles = std::vector<std::array<std::uint32_t, 3>>;
constexpr double kInf = std::numeric_limits<double>::infinity();

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  return (static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
}

// Vertex neighbours with edge lengths (CSR), each list ascending.
struct Adjacency {
  std::vector<std::uint32_t> start, to;
  std::vector<double> length;
};

Adjacency adjacency(const TriangleMesh& mesh) {
  std::vector<std::uint64_t> keys;
  keys.reserve(3 * mesh.triangles.size());
  for (const auto& t : mesh.triangles)
    for (int i = 0; i < 3; ++i) keys.push_back(edge_key(t[static_cast<std::size_t>(i)], t[(i + 1) % 3]));
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  const std::size_t n = mesh.vertices.size();
  Adjacency a;
  a.start.assign(n + 1, 0);
  for (std::uint64_t k : keys) {
    ++a.start[(k >> 32) + 1];
    ++a.start[(k & 0xffffffffU) + 1];
  }
  std::partial_sum(a.start.begin(), a.start.end(), a.start.begin());
  a.to.resize(a.start.back());
  a.length.resize(a.start.back());
  std::vector<std::uint32_t> fill(a.start.begin(), a.start.end() - 1);
  for (std::uint64_t k : keys) {
    const auto u = static_cast<std::uint32_t>(k >> 32), v = static_cast<std::uint32_t>(k & 0xffffffffU);
    const double len = (mesh.vertices[u] - mesh.vertices[v]).norm();
    a.to[fill[u]] = v;
    a.length[fill[u]++] = len;
    a.to[fill[v]] = u;
    a.length[fill[v]++] = len;
  }
  return a;
}

std::vector<double> dijkstra(const Adjacency& adj, std::size_t n, const std::vector<std::uint32_t>& from) {
  std::vector<double> dist(n, kInf);
  using Item = std::pair<double, std::uint32_t>;  // ties broken by vertex index: deterministic
  std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
  for (std::uint32_t v : from) {
    dist[v] = 0.0;
    queue.push({0.0, v});
  }
  while (!queue.empty()) {
    const auto [d, v] = queue.top();
    queue.pop();
    if (d > dist[v]) continue;
    for (std::uint32_t e = adj.start[v]; e < adj.start[v + 1]; ++e) {
      const std::uint32_t w = adj.to[e];
      if (d + adj.length[e] < dist[w]) {
        dist[w] = d + adj.length[e];
        queue.push({dist[w], w});
      }
    }
  }
  return dist;
}

std::uint32_t farthest_vertex(const std::vector<double>& dist) {
  std::uint32_t best = 0;
  double far = -1.0;
  for (std::size_t v = 0; v < dist.size(); ++v)
    if (dist[v] < kInf && dist[v] > far) {
      far = dist[v];
      best = static_cast<std::uint32_t>(v);
    }
  return best;
}

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

bool is_end_loop(const TubeEnd& e, std::size_t l) {
  return std::find(e.loops.begin(), e.loops.end(), static_cast<int>(l)) != e.loops.end();
}

// Every boundary loop but the ends capped by a fan around its centroid (the solve needs closed
// level sets; a fan is linear in the loop's size, unlike a hole filler's search).
TriangleMesh capped(const TriangleMesh& mesh, const std::vector<std::vector<std::uint32_t>>& loops,
                    const TubeEnd& start, const TubeEnd& end, int& capped_loops) {
  TriangleMesh out = mesh;
  // Loop order follows the triangles' winding along the border: the fan is wound the other way.
  for (std::size_t l = 0; l < loops.size(); ++l) {
    if (is_end_loop(start, l) || is_end_loop(end, l)) continue;
    const auto& loop = loops[l];
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (std::uint32_t v : loop) c += mesh.vertices[v];
    c /= static_cast<double>(loop.size());
    const auto centre = static_cast<std::uint32_t>(out.vertices.size());
    out.vertices.push_back(c);
    for (std::size_t i = 0; i < loop.size(); ++i)
      out.triangles.push_back({loop[(i + 1) % loop.size()], loop[i], centre});
    ++capped_loops;
  }
  return out;
}

// Laplace's equation with cotangent weights (clamped positive, so that the discrete maximum
// principle holds and u has no interior extremum), u = 0 on the start, 1 on the end.
std::vector<double> harmonic(const TriangleMesh& mesh, const TubeEnd& start, const TubeEnd& end) {
  const std::size_t n = mesh.vertices.size();
  std::vector<double> u(n, 0.0);
  std::vector<int> fixed(n, 0);
  for (std::uint32_t v : start.vertices) fixed[v] = 1;
  for (std::uint32_t v : end.vertices) {
    fixed[v] = 1;
    u[v] = 1.0;
  }
  std::vector<Eigen::Triplet<double>> weights;
  weights.reserve(3 * mesh.triangles.size());
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t i = t[(k + 1) % 3], j = t[(k + 2) % 3], o = t[static_cast<std::size_t>(k)];
      const Eigen::Vector3d a = mesh.vertices[i] - mesh.vertices[o], b = mesh.vertices[j] - mesh.vertices[o];
      const double s = a.cross(b).norm();
      const double cot = s > 0.0 ? a.dot(b) / s : 0.0;
      weights.emplace_back(std::min(i, j), std::max(i, j), 0.5 * cot);
    }
  Eigen::SparseMatrix<double> w(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
  w.setFromTriplets(weights.begin(), weights.end());  // duplicates summed: an edge's two corners
  std::vector<Eigen::Index> unknown_index(n, -1);
  Eigen::Index unknowns = 0;
  for (std::size_t v = 0; v < n; ++v)
    if (fixed[v] == 0) unknown_index[v] = unknowns++;
  std::vector<Eigen::Triplet<double>> entries;
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(unknowns);
  std::vector<double> diagonal(static_cast<std::size_t>(unknowns), 0.0);
  for (Eigen::Index col = 0; col < w.outerSize(); ++col)
    for (Eigen::SparseMatrix<double>::InnerIterator it(w, col); it; ++it) {
      const auto i = static_cast<std::size_t>(it.row()), j = static_cast<std::size_t>(it.col());
      const double wij = std::clamp(it.value(), 1e-3, 1e3);
      for (auto [p, q] : {std::pair{i, j}, std::pair{j, i}}) {
        if (fixed[p] != 0) continue;
        diagonal[static_cast<std::size_t>(unknown_index[p])] += wij;
        if (fixed[q] != 0)
          rhs[unknown_index[p]] += wij * u[q];
        else
          entries.emplace_back(unknown_index[p], unknown_index[q], -wij);
      }
    }
  for (Eigen::Index k = 0; k < unknowns; ++k) entries.emplace_back(k, k, diagonal[static_cast<std::size_t>(k)]);
  Eigen::SparseMatrix<double> l(unknowns, unknowns);
  l.setFromTriplets(entries.begin(), entries.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(l);
  if (solver.info() != Eigen::Success)
    throw Error(ErrorCode::invalid_geometry, "the surface is not connected to both of its ends");
  const Eigen::VectorXd x = solver.solve(rhs);
  for (std::size_t v = 0; v < n; ++v)
    if (fixed[v] == 0) u[v] = std::clamp(x[unknown_index[v]], 0.0, 1.0);
  return u;
}

// The area centroid of a closed polyline over its best plane (a fan from its mean point), its
// enclosed area and its length.
CrossSection loop_section(const std::vector<Eigen::Vector3d>& loop, double u) {
  CrossSection s;
  s.u = u;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : loop) mean += p;
  mean /= static_cast<double>(loop.size());
  Eigen::Vector3d vector_area = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < loop.size(); ++i) {
    const Eigen::Vector3d& p = loop[i];
    const Eigen::Vector3d& q = loop[(i + 1) % loop.size()];
    vector_area += 0.5 * (p - mean).cross(q - mean);
    s.perimeter += (q - p).norm();
  }
  s.area = vector_area.norm();
  s.centre = mean;
  if (s.area > 0.0) {
    const Eigen::Vector3d n = vector_area / s.area;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double total = 0.0;
    for (std::size_t i = 0; i < loop.size(); ++i) {
      const Eigen::Vector3d& p = loop[i];
      const Eigen::Vector3d& q = loop[(i + 1) % loop.size()];
      const double a = 0.5 * (p - mean).cross(q - mean).dot(n);
      sum += a * (mean + p + q) / 3.0;
      total += a;
    }
    if (total > 0.0) s.centre = sum / total;
  }
  return s;
}

// The contours of u at one level: each triangle that the level crosses gives a segment between the
// points where it crosses two of its edges; segments sharing an edge's point join into loops.
class Contours {
 public:
  Contours(const TriangleMesh& mesh, const std::vector<double>& u) : mesh_(mesh), u_(u) {
    // Triangles bucketed by the range of u they span, so a level visits only its own.
    buckets_.assign(kBuckets, {});
    for (std::uint32_t t = 0; t < mesh.triangles.size(); ++t) {
      const auto& tri = mesh.triangles[t];
      const double lo = std::min({u[tri[0]], u[tri[1]], u[tri[2]]});
      const double hi = std::max({u[tri[0]], u[tri[1]], u[tri[2]]});
      if (!(hi > lo)) continue;
      for (std::size_t b = bucket(lo); b <= bucket(hi); ++b) buckets_[b].push_back(t);
    }
  }

  // Every closed contour at `level` (a tube has one; where its loops are fused into handles, more).
  std::vector<CrossSection> sections(double level) const {
    struct Point {
      std::uint64_t edge;
      Eigen::Vector3d x;
    };
    std::vector<std::array<Point, 2>> segments;
    for (std::uint32_t t : buckets_[bucket(level)]) {
      const auto& tri = mesh_.triangles[t];
      std::array<Point, 2> seg;
      int found = 0;
      for (int i = 0; i < 3; ++i) {
        const std::uint32_t a = tri[static_cast<std::size_t>(i)], b = tri[(i + 1) % 3];
        if ((u_[a] >= level) == (u_[b] >= level)) continue;
        const double t_ab = (level - u_[a]) / (u_[b] - u_[a]);
        if (found < 2)
          seg[static_cast<std::size_t>(found)] = {edge_key(a, b),
                                                  mesh_.vertices[a] + t_ab * (mesh_.vertices[b] - mesh_.vertices[a])};
        ++found;
      }
      if (found == 2) segments.push_back(seg);
    }
    // Join: each point's edge is met by two segments on a closed contour.
    constexpr auto kNone = std::numeric_limits<std::uint32_t>::max();
    std::vector<std::pair<std::uint64_t, std::uint32_t>> ends;  // (edge, 2·segment + side)
    for (std::uint32_t i = 0; i < segments.size(); ++i)
      for (std::uint32_t side = 0; side < 2; ++side) ends.emplace_back(segments[i][side].edge, 2 * i + side);
    std::sort(ends.begin(), ends.end());
    std::vector<std::uint32_t> partner(ends.size(), kNone);
    for (std::size_t i = 0; i + 1 < ends.size(); ++i)
      if (ends[i].first == ends[i + 1].first) {
        partner[ends[i].second] = ends[i + 1].second;
        partner[ends[i + 1].second] = ends[i].second;
      }
    std::vector<std::uint8_t> used(segments.size(), 0);
    std::vector<CrossSection> out;
    for (std::uint32_t first = 0; first < segments.size(); ++first) {
      if (used[first] != 0) continue;
      std::vector<Eigen::Vector3d> loop;
      std::uint32_t seg = first, entry_side = 0;
      for (;;) {
        used[seg] = 1;
        loop.push_back(segments[seg][entry_side].x);
        const std::uint32_t next = partner[2 * seg + (1 - entry_side)];
        if (next == kNone) break;  // open: a contour ending on a border
        seg = next / 2;
        entry_side = next % 2;
        if (used[seg] != 0) break;
      }
      if (loop.size() >= 3) out.push_back(loop_section(loop, level));
    }
    for (CrossSection& c : out) c.pieces = static_cast<int>(out.size());
    return out;
  }

 private:
  static constexpr std::size_t kBuckets = 8192;
  static std::size_t bucket(double u) {
    return std::min(kBuckets - 1, static_cast<std::size_t>(std::max(0.0, u) * static_cast<double>(kBuckets)));
  }
  const TriangleMesh& mesh_;
  const std::vector<double>& u_;
  std::vector<std::vector<std::uint32_t>> buckets_;
};

// An end's section: a tip's point, or the widest of its rims.
CrossSection end_section(const TriangleMesh& mesh, const std::vector<std::vector<std::uint32_t>>& loops,
                         const TubeEnd& end, double u) {
  CrossSection best;
  best.u = u;
  best.centre = mesh.vertices[end.vertices.front()];
  best.area = -1.0;
  for (int l : end.loops) {
    std::vector<Eigen::Vector3d> loop;
    for (std::uint32_t v : loops[static_cast<std::size_t>(l)]) loop.push_back(mesh.vertices[v]);
    const CrossSection s = loop_section(loop, u);
    if (s.area > best.area) best = s;
  }
  best.area = std::max(best.area, 0.0);
  return best;
}

// The sections along the tube: one contour per level, chosen so that the line through their
// centres is the longest that steps only between nearby contours of neighbouring levels. Where the
// tube's loops are fused into handles a level has several contours; the longest way follows the
// tube round its loops rather than across the fusion.
std::vector<CrossSection> longest_way(const std::vector<std::vector<CrossSection>>& levels, double spacing) {
  const std::size_t n = levels.size();
  std::vector<std::vector<double>> score(n);
  std::vector<std::vector<std::size_t>> from(n);
  score[0].assign(levels[0].size(), 0.0);
  from[0].assign(levels[0].size(), 0);
  for (std::size_t k = 1; k < n; ++k) {
    score[k].assign(levels[k].size(), -kInf);
    from[k].assign(levels[k].size(), 0);
    for (std::size_t j = 0; j < levels[k].size(); ++j) {
      const CrossSection& c = levels[k][j];
      double nearest = kInf;
      std::size_t nearest_i = 0;
      for (std::size_t i = 0; i < levels[k - 1].size(); ++i) {
        const CrossSection& p = levels[k - 1][i];
        const double d = (c.centre - p.centre).norm();
        if (d < nearest) {
          nearest = d;
          nearest_i = i;
        }
        // A step within a few spacings, or within the contours' own size, continues a contour.
        const double reach = std::max(4.0 * spacing, 0.5 * (std::sqrt(c.area) + std::sqrt(p.area)));
        if (d <= reach && score[k - 1][i] + d > score[k][j]) {
          score[k][j] = score[k - 1][i] + d;
          from[k][j] = i;
        }
      }
      if (score[k][j] == -kInf) {  // nothing near: the nearest, so the way never breaks
        score[k][j] = score[k - 1][nearest_i] + nearest;
        from[k][j] = nearest_i;
      }
    }
  }
  std::vector<CrossSection> way(n);
  std::size_t j = 0;
  for (std::size_t k = n; k-- > 0;) {
    way[k] = levels[k][j];
    j = from[k][j];
  }
  return way;
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
  // From an end: the farthest other open end, or the farthest vertex (a closed end) where that is
  // half as far again (a tube closed at one end with a side opening near the other).
  auto far_end = [&](const TubeEnd& from, double& distance) {
    const std::vector<double> d = dijkstra(adj, n, from.vertices);
    TubeEnd best;
    distance = -1.0;
    for (int e : ends) {
      if (from.open && is_end_loop(from, static_cast<std::size_t>(e))) continue;
      double reach = kInf;
      for (std::uint32_t v : loops[static_cast<std::size_t>(e)]) reach = std::min(reach, d[v]);
      if (reach < kInf && reach > distance) {
        distance = reach;
        best = group_end(loops, group, e);
      }
    }
    const std::uint32_t tip = farthest_vertex(d);
    if (distance < 0.0 || d[tip] > 1.5 * distance) {
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

TubeAxis tube_axis(const TriangleMesh& mesh, const std::vector<std::vector<std::uint32_t>>& loops,
                   const TubeEnd& start, const TubeEnd& end, double spacing) {
  TubeAxis axis;
  axis.start = start;
  axis.end = end;
  const TriangleMesh work = capped(mesh, loops, start, end, axis.capped_loops);
  {
    const std::vector<double> d = edge_distances(work, start.vertices);
    double to_end = kInf;
    for (std::uint32_t v : end.vertices) to_end = std::min(to_end, d[v]);
    if (!(to_end < kInf) || to_end <= 0.0)
      throw Error(ErrorCode::invalid_geometry,
                  "the surface does not connect its two ends (or they coincide): it is not one tube");
    axis.geodesic_length = to_end;
  }
  std::vector<double> u = harmonic(work, start, end);
  const Contours contours(work, u);

  // Levels: evenly spaced in u, then halved wherever consecutive contours lie farther apart than
  // `spacing` (u runs faster where the tube is narrow), a bounded number of times.
  const auto first_levels = static_cast<std::size_t>(std::clamp(axis.geodesic_length / spacing, 64.0, 20000.0));
  std::vector<double> level_u;
  for (std::size_t k = 0; k <= first_levels; ++k) level_u.push_back(static_cast<double>(k) / static_cast<double>(first_levels));
  std::vector<std::vector<CrossSection>> levels(level_u.size());
  auto level_sections = [&](double l) {
    if (l <= 0.0) return std::vector<CrossSection>{end_section(mesh, loops, start, 0.0)};
    if (l >= 1.0) return std::vector<CrossSection>{end_section(mesh, loops, end, 1.0)};
    return contours.sections(l);
  };
  for (std::size_t k = 0; k < level_u.size(); ++k) levels[k] = level_sections(level_u[k]);
  // Judged on each level's widest contour (the tube's; others come and go at handles).
  auto widest = [](const std::vector<CrossSection>& l) {
    return std::max_element(l.begin(), l.end(),
                            [](const CrossSection& x, const CrossSection& y) { return x.area < y.area; });
  };
  auto far_apart = [&](const std::vector<CrossSection>& a, const std::vector<CrossSection>& b) {
    return !a.empty() && !b.empty() && (widest(a)->centre - widest(b)->centre).norm() > spacing;
  };
  for (int round = 0; round < 8; ++round) {
    std::vector<double> refined_u{level_u.front()};
    std::vector<std::vector<CrossSection>> refined{levels.front()};
    bool split = false;
    for (std::size_t k = 1; k < levels.size(); ++k) {
      if (level_u[k] - level_u[k - 1] > 1e-9 && far_apart(levels[k - 1], levels[k])) {
        const double mid = 0.5 * (level_u[k] + level_u[k - 1]);
        std::vector<CrossSection> m = level_sections(mid);
        if (!m.empty()) {
          refined_u.push_back(mid);
          refined.push_back(std::move(m));
          split = true;
        }
      }
      refined_u.push_back(level_u[k]);
      refined.push_back(std::move(levels[k]));
    }
    level_u.swap(refined_u);
    levels.swap(refined);
    if (!split) break;
  }
  // Levels the contour extraction found nothing at (a rounding corner) are left out.
  std::vector<std::vector<CrossSection>> found;
  for (auto& l : levels)
    if (!l.empty()) found.push_back(std::move(l));
  std::vector<CrossSection> sections = longest_way(found, spacing);
  axis.sections = std::move(sections);
  u.resize(mesh.vertices.size());  // the caps' centres were the solve's alone
  axis.u = std::move(u);
  return axis;
}

std::vector<double> section_arcs(const std::vector<CrossSection>& sections) {
  std::vector<double> arc(sections.size(), 0.0);
  for (std::size_t k = 1; k < sections.size(); ++k)
    arc[k] = arc[k - 1] + (sections[k].centre - sections[k - 1].centre).norm();
  return arc;
}

namespace {

// The closest point's arc among the centreline's samples [first, last).
double closest_arc_between(std::span<const Eigen::Vector3d> samples, double length, const Eigen::Vector3d& x,
                           std::size_t first, std::size_t last) {
  const std::size_t segments = samples.size() - 1;
  double best = kInf, best_s = 0.0;
  for (std::size_t i = first; i < std::min(last, segments); ++i) {
    const Eigen::Vector3d d = samples[i + 1] - samples[i];
    const double t = std::clamp((x - samples[i]).dot(d) / std::max(d.squaredNorm(), 1e-300), 0.0, 1.0);
    const double dist = (samples[i] + t * d - x).squaredNorm();
    if (dist < best) {
      best = dist;
      best_s = length * (static_cast<double>(i) + t) / static_cast<double>(segments);
    }
  }
  return best_s;
}

}  // namespace

double closest_arc(std::span<const Eigen::Vector3d> samples, double length, const Eigen::Vector3d& x) {
  return closest_arc_between(samples, length, x, 0, samples.size());
}

namespace {

// One connected piece's arcs from its harmonic u; throws Error where it has no two ends.
std::vector<double> piece_arcs(const TriangleMesh& piece, std::span<const Eigen::Vector3d> samples, double length) {
  const auto loops = boundary_loops(piece);
  auto centre_arc = [&](const std::vector<std::uint32_t>& vs) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (std::uint32_t v : vs) c += piece.vertices[v];
    return closest_arc(samples, length, c / static_cast<double>(vs.size()));
  };
  // Its two ends as along any surface (farthest apart), the one nearer the centreline's start first.
  auto [start, end] = farthest_ends(piece, loops, std::nullopt);
  if (centre_arc(start.vertices) > centre_arc(end.vertices)) std::swap(start, end);
  const TubeAxis axis = tube_axis(piece, loops, start, end, std::max(1e-4, length / 4000.0));
  // The sections' places, followed along the centreline from the start's: each looks near the one
  // before (within twice the step between them, and a millimetre), so a section beside another
  // loop of the organ stays on its own, and a wall that folds back runs back along the line.
  std::vector<double> us, arcs;
  const std::size_t segments = samples.size() - 1;
  const double per_sample = length / static_cast<double>(segments);
  for (std::size_t k = 0; k < axis.sections.size(); ++k) {
    const CrossSection& s = axis.sections[k];
    us.push_back(s.u);
    if (k == 0) {
      arcs.push_back(closest_arc(samples, length, s.centre));
      continue;
    }
    const double reach = 2.0 * (s.centre - axis.sections[k - 1].centre).norm() + 1e-3;
    const double lo = std::max(0.0, arcs.back() - reach), hi = std::min(length, arcs.back() + reach);
    arcs.push_back(closest_arc_between(samples, length, s.centre, static_cast<std::size_t>(lo / per_sample),
                                       static_cast<std::size_t>(std::ceil(hi / per_sample)) + 1));
  }
  std::vector<double> out(piece.vertices.size());
  for (std::size_t v = 0; v < out.size(); ++v) out[v] = interpolate(us, arcs, axis.u[v]);
  return out;
}

// Where u is all but constant, a part of the surface the harmonic function's flow passes by (a
// pouch, a shell that folds back, a loop fused into a handle) has one place for all its vertices,
// far from most of them. Such a vertex (farther from its place on the centreline than twice its
// distance to the line, and 2 mm) takes instead the closest place near a neighbour's, the
// neighbours followed outward from the vertices that are well placed (Dijkstra, ties by index).
std::size_t follow_dead_ends(const TriangleMesh& piece, std::span<const Eigen::Vector3d> samples, double length,
                             std::vector<double>& arc) {
  const std::size_t n = piece.vertices.size(), segments = samples.size() - 1;
  const double per_sample = length / static_cast<double>(segments);
  auto at = [&](double s) {
    const double x = std::clamp(s / per_sample, 0.0, static_cast<double>(segments));
    const auto i = std::min(static_cast<std::size_t>(x), segments - 1);
    return samples[i] + (x - static_cast<double>(i)) * (samples[i + 1] - samples[i]);
  };
  std::vector<std::uint8_t> placed(n, 1);
  std::size_t misplaced = 0;
  for (std::size_t v = 0; v < n; ++v) {
    const Eigen::Vector3d& x = piece.vertices[v];
    const double nearest = (at(closest_arc(samples, length, x)) - x).norm();
    if ((at(arc[v]) - x).norm() > 2.0 * nearest + 2e-3) {
      placed[v] = 0;
      ++misplaced;
    }
  }
  if (misplaced == 0 || misplaced == n) return 0;
  const Adjacency adj = adjacency(piece);
  using Item = std::pair<double, std::uint32_t>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
  std::vector<double> dist(n, kInf);
  for (std::uint32_t v = 0; v < n; ++v)
    if (placed[v] != 0) {
      dist[v] = 0.0;
      queue.push({0.0, v});
    }
  while (!queue.empty()) {
    const auto [d, v] = queue.top();
    queue.pop();
    if (d > dist[v]) continue;
    for (std::uint32_t e = adj.start[v]; e < adj.start[v + 1]; ++e) {
      const std::uint32_t w = adj.to[e];
      if (placed[w] != 0 || d + adj.length[e] >= dist[w]) continue;
      dist[w] = d + adj.length[e];
      const double reach = 2.0 * adj.length[e] + 1e-3;
      const double lo = std::max(0.0, arc[v] - reach), hi = std::min(length, arc[v] + reach);
      arc[w] = closest_arc_between(samples, length, piece.vertices[w], static_cast<std::size_t>(lo / per_sample),
                                   static_cast<std::size_t>(std::ceil(hi / per_sample)) + 1);
      queue.push({dist[w], w});
    }
  }
  return misplaced;
}

}  // namespace

BindingArcs harmonic_binding_arcs(const TriangleMesh& mesh, std::span<const Eigen::Vector3d> samples, double length) {
  // Connected pieces (union–find over the triangles' corners), each in ascending vertex order.
  const std::size_t n = mesh.vertices.size();
  std::vector<std::uint32_t> parent(n);
  std::iota(parent.begin(), parent.end(), 0U);
  auto root = [&](std::uint32_t v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  for (const auto& t : mesh.triangles)
    for (int i = 1; i < 3; ++i) {
      const std::uint32_t a = root(t[0]), b = root(t[static_cast<std::size_t>(i)]);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  std::vector<std::uint32_t> piece_of(n), local(n);
  std::vector<TriangleMesh> pieces;
  std::vector<std::vector<std::uint32_t>> members;
  std::vector<std::int64_t> index_of_root(n, -1);
  for (std::uint32_t v = 0; v < n; ++v) {
    const std::uint32_t r = root(v);
    if (index_of_root[r] < 0) {
      index_of_root[r] = static_cast<std::int64_t>(pieces.size());
      pieces.emplace_back();
      members.emplace_back();
    }
    piece_of[v] = static_cast<std::uint32_t>(index_of_root[r]);
    local[v] = static_cast<std::uint32_t>(members[piece_of[v]].size());
    members[piece_of[v]].push_back(v);
    pieces[piece_of[v]].vertices.push_back(mesh.vertices[v]);
  }
  for (const auto& t : mesh.triangles) pieces[piece_of[t[0]]].triangles.push_back({local[t[0]], local[t[1]], local[t[2]]});
  BindingArcs out;
  out.arc.assign(n, 0.0);
  out.pieces = pieces.size();
  for (std::size_t p = 0; p < pieces.size(); ++p) {
    std::vector<double> arcs;
    try {
      if (pieces[p].triangles.empty()) throw Error(ErrorCode::invalid_geometry, "no triangles");
      arcs = piece_arcs(pieces[p], samples, length);
      out.followed += follow_dead_ends(pieces[p], samples, length, arcs);
    } catch (const Error&) {
      ++out.closest_pieces;
      arcs.resize(pieces[p].vertices.size());
      for (std::size_t v = 0; v < arcs.size(); ++v) arcs[v] = closest_arc(samples, length, pieces[p].vertices[v]);
    }
    for (std::size_t v = 0; v < arcs.size(); ++v) out.arc[members[p][v]] = arcs[v];
  }
  return out;
}

double interpolate(const std::vector<double>& xs, const std::vector<double>& ys, double x) {
  if (xs.empty()) return 0.0;
  if (x <= xs.front()) return ys.front();
  if (x >= xs.back()) return ys.back();
  const auto it = std::upper_bound(xs.begin(), xs.end(), x);
  const auto k = static_cast<std::size_t>(it - xs.begin());
  const double t = xs[k] > xs[k - 1] ? (x - xs[k - 1]) / (xs[k] - xs[k - 1]) : 0.0;
  return ys[k - 1] + t * (ys[k] - ys[k - 1]);
}

}  // namespace haustra
