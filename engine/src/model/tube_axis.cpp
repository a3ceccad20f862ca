// A tube's axis from a harmonic function on its surface: the solve, its level contours, the
// sections' centroids along the longest way through them that follows one contour to the next.
#include "haustra/tube_axis.hpp"

#include <fmt/format.h>

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "haustra/error.hpp"
#include "model/surface_graph.hpp"

namespace haustra {
namespace {

using detail::edge_key;
using detail::kNoPath;

// Every boundary loop but the ends capped by a fan around its centroid (the solve needs closed
// level sets; a fan is linear in the loop's size, unlike a hole filler's search).
TriangleMesh capped(const TriangleMesh& mesh, const std::vector<std::vector<std::uint32_t>>& loops,
                    const TubeEnd& start, const TubeEnd& end, int& capped_loops) {
  TriangleMesh out = mesh;
  // Loop order follows the triangles' winding along the border: the fan is wound the other way.
  for (std::size_t l = 0; l < loops.size(); ++l) {
    if (start.has_loop(l) || end.has_loop(l)) continue;
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

// For each contour of `here`, the index of the nearest contour of `there`.
std::vector<std::size_t> nearest_contours(const std::vector<CrossSection>& here,
                                          const std::vector<CrossSection>& there) {
  std::vector<std::size_t> out(here.size(), 0);
  for (std::size_t j = 0; j < here.size(); ++j) {
    double best = kNoPath;
    for (std::size_t i = 0; i < there.size(); ++i) {
      const double d = (here[j].centre - there[i].centre).norm();
      if (d < best) {
        best = d;
        out[j] = i;
      }
    }
  }
  return out;
}

}  // namespace

std::vector<CrossSection> section_path(const std::vector<std::vector<CrossSection>>& levels, double spacing) {
  const std::size_t n = levels.size();
  if (n == 0) return {};
  // The way's worth is its length along the tube: a step between levels, which the levels' refinement
  // keeps within a spacing or so; a longer one is a jump between branches where contours split or
  // merge, allowed (so the way can enter a loop) but worth nothing (so it never jumps for the jump's
  // own length, into a bulge of the wall and back).
  auto along = [&](double d) { return d <= 4.0 * spacing ? d : 0.0; };
  std::vector<std::vector<double>> score(n);
  std::vector<std::vector<std::size_t>> from(n);
  score[0].assign(levels[0].size(), 0.0);
  from[0].assign(levels[0].size(), 0);
  for (std::size_t k = 1; k < n; ++k) {
    const std::vector<CrossSection>& below = levels[k - 1];
    const std::vector<std::size_t> down = nearest_contours(levels[k], below);
    const std::vector<std::size_t> up = nearest_contours(below, levels[k]);
    score[k].assign(levels[k].size(), -kNoPath);
    from[k].assign(levels[k].size(), 0);
    for (std::size_t j = 0; j < levels[k].size(); ++j) {
      const CrossSection& c = levels[k][j];
      for (std::size_t i = 0; i < below.size(); ++i) {
        // A step continues a contour when one of the two is the other's nearest (where contours
        // split or merge, every branch is someone's nearest) and it lies within a few spacings or
        // the larger contour's size (a branch's contour is born within the contour it leaves, whose
        // centroid lies between the branches); a step to a parallel contour is neither, however close.
        const CrossSection& p = below[i];
        const double d = (c.centre - p.centre).norm();
        const double reach = std::max(4.0 * spacing, std::max(std::sqrt(c.area), std::sqrt(p.area)));
        const bool continues = down[j] == i || up[i] == j;
        if (continues && d <= reach && score[k - 1][i] + along(d) > score[k][j]) {
          score[k][j] = score[k - 1][i] + along(d);
          from[k][j] = i;
        }
      }
      if (score[k][j] == -kNoPath) {  // nothing continues it: the nearest, so the way never breaks
        const std::size_t i = down[j];
        score[k][j] = score[k - 1][i] + along((c.centre - below[i].centre).norm());
        from[k][j] = i;
      }
    }
  }
  std::size_t j =
      static_cast<std::size_t>(std::max_element(score[n - 1].begin(), score[n - 1].end()) - score[n - 1].begin());
  std::vector<CrossSection> way(n);
  for (std::size_t k = n; k-- > 0;) {
    way[k] = levels[k][j];
    j = from[k][j];
  }
  return way;
}

TubeAxis tube_axis(const TriangleMesh& mesh, const std::vector<std::vector<std::uint32_t>>& loops, const TubeEnd& start,
                   const TubeEnd& end, double spacing) {
  TubeAxis axis;
  axis.start = start;
  axis.end = end;
  const TriangleMesh work = capped(mesh, loops, start, end, axis.capped_loops);
  {
    const std::vector<double> d = edge_distances(work, start.vertices);
    double to_end = kNoPath;
    for (std::uint32_t v : end.vertices) to_end = std::min(to_end, d[v]);
    if (!(to_end < kNoPath) || to_end <= 0.0)
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
  for (std::size_t k = 0; k <= first_levels; ++k)
    level_u.push_back(static_cast<double>(k) / static_cast<double>(first_levels));
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
  // And a level between each two consecutive values u takes at the vertices: where loops of the
  // organ are fused, the flow runs through the fusion and a whole loop hanging from it lies within
  // a sliver of u that the levels above step over (the widest contour, the flow's, moves little
  // there); a level at every vertex's own value crosses the loop all along.
  std::vector<double> at_vertices = u;
  at_vertices.resize(mesh.vertices.size());  // the caps' centres were the solve's alone
  std::sort(at_vertices.begin(), at_vertices.end());
  std::vector<std::pair<double, bool>> all_u;  // (level, one of the levels above)
  for (double l : level_u) all_u.emplace_back(l, true);
  for (std::size_t k = 1; k < at_vertices.size(); ++k)
    if (at_vertices[k] > at_vertices[k - 1] && at_vertices[k - 1] > 0.0 && at_vertices[k] < 1.0)
      all_u.emplace_back(0.5 * (at_vertices[k] + at_vertices[k - 1]), false);
  std::sort(all_u.begin(), all_u.end());
  // Levels the contour extraction found nothing at (a rounding corner) are left out.
  std::vector<std::vector<CrossSection>> found;
  std::vector<bool> kept_level;
  for (std::size_t k = 0, j = 0; k < all_u.size(); ++k) {
    std::vector<CrossSection> l;
    if (all_u[k].second) {
      while (level_u[j] < all_u[k].first) ++j;
      l = std::move(levels[j]);
    } else {
      l = level_sections(all_u[k].first);
    }
    if (l.empty()) continue;
    found.push_back(std::move(l));
    kept_level.push_back(all_u[k].second);
  }
  // The way through them; of the vertices' levels only a section `spacing` on from the one before
  // is kept (along a simple tube the levels above are already that close, and the vertices' levels
  // add nothing but the contours' jitter).
  const std::vector<CrossSection> way = section_path(found, spacing);
  for (std::size_t k = 0; k < way.size(); ++k)
    if (kept_level[k] || axis.sections.empty() || (way[k].centre - axis.sections.back().centre).norm() >= spacing)
      axis.sections.push_back(way[k]);
  u.resize(mesh.vertices.size());  // the caps' centres were the solve's alone
  axis.u = std::move(u);
  return axis;
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
