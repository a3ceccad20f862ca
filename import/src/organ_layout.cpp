// Outer walls, lumens inside them, and the order of an organ's pieces along it.
#include "organ_layout.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>

#include "haustra/tube_axis.hpp"

namespace haustra::import {
namespace {

struct Box {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = Eigen::Vector3d::Constant(-1e300);
  void add(const Eigen::Vector3d& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  [[nodiscard]] bool holds(const Box& b, double margin) const {
    return (b.lo.array() >= lo.array() - margin).all() && (b.hi.array() <= hi.array() + margin).all();
  }
};

// How much of `outer` surrounds p: its generalized winding number, the solid angle its triangles
// subtend at p over 4π (Van Oosterom and Strackee), in absolute value since a piece's winding
// may face either way. Inside a tube it is near 1 (less what its open ends let out), outside near 0.
double winding(const TriangleMesh& outer, const Eigen::Vector3d& p) {
  double total = 0.0;
  for (const auto& t : outer.triangles) {
    const Eigen::Vector3d a = outer.vertices[t[0]] - p, b = outer.vertices[t[1]] - p, c = outer.vertices[t[2]] - p;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    const double numerator = a.dot(b.cross(c));
    const double denominator = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    total += 2.0 * std::atan2(numerator, denominator);
  }
  return std::abs(total) / (4.0 * std::numbers::pi);
}

// The median over a sample of `inner`'s vertices of how much `outer` surrounds them.
double fraction_inside(const TriangleMesh& outer, const TriangleMesh& inner) {
  const std::size_t n = inner.vertices.size();
  const std::size_t stride = std::max<std::size_t>(1, n / 48);
  std::vector<double> w;
  for (std::size_t v = 0; v < n; v += stride) w.push_back(winding(outer, inner.vertices[v]));
  std::nth_element(w.begin(), w.begin() + static_cast<std::ptrdiff_t>(w.size() / 2), w.end());
  return w.empty() ? 0.0 : w[w.size() / 2];
}

double triangle_area(const TriangleMesh& m) {
  double a = 0.0;
  for (const auto& t : m.triangles)
    a += 0.5 * (m.vertices[t[1]] - m.vertices[t[0]]).cross(m.vertices[t[2]] - m.vertices[t[0]]).norm();
  return a;
}

// Marks lumens: a piece whose vertices the other surrounds (winding number over 0.3 at the median,
// and more than the other way round) is that piece's lumen.
void find_lumens(std::vector<OrganPiece>& pieces) {
  const std::size_t n = pieces.size();
  std::vector<Box> box(n);
  for (std::size_t p = 0; p < n; ++p)
    for (const auto& v : pieces[p].mesh.vertices) box[p].add(v);
  std::vector<std::vector<double>> inside(n, std::vector<double>(n, 0.0));  // [inner][outer]
  for (std::size_t a = 0; a < n; ++a) {
    const double size = (box[a].hi - box[a].lo).norm();
    for (std::size_t b = 0; b < n; ++b)
      if (a != b && box[a].holds(box[b], 0.1 * size)) inside[b][a] = fraction_inside(pieces[a].mesh, pieces[b].mesh);
  }
  for (std::size_t b = 0; b < n; ++b) {
    std::size_t best = n;
    for (std::size_t a = 0; a < n; ++a)
      if (inside[b][a] >= 0.3 && inside[b][a] > inside[a][b] && (best == n || inside[b][a] > inside[b][best])) best = a;
    if (best < n) pieces[b].inside_of = static_cast<int>(best);
  }
  // A lumen of a lumen belongs to the outer wall around both.
  for (auto& p : pieces)
    for (int guard = 0; p.inside_of >= 0 && pieces[static_cast<std::size_t>(p.inside_of)].inside_of >= 0 && guard < 64;
         ++guard)
      p.inside_of = pieces[static_cast<std::size_t>(p.inside_of)].inside_of;
}

std::vector<Junction> find_junctions(const std::vector<OrganPiece>& pieces) {
  struct Candidate {
    double distance;
    Junction j;
  };
  std::vector<std::vector<LoopShape>> shapes(pieces.size());
  for (std::size_t p = 0; p < pieces.size(); ++p)
    for (const auto& loop : pieces[p].loops) shapes[p].push_back(loop_shape(pieces[p].mesh, loop));
  std::vector<Candidate> candidates;
  for (std::size_t a = 0; a < pieces.size(); ++a)
    for (std::size_t b = a + 1; b < pieces.size(); ++b) {
      if (pieces[a].inside_of >= 0 || pieces[b].inside_of >= 0) continue;
      for (std::size_t la = 0; la < shapes[a].size(); ++la)
        for (std::size_t lb = 0; lb < shapes[b].size(); ++lb) {
          const LoopShape &x = shapes[a][la], &y = shapes[b][lb];
          const double d = (x.centre - y.centre).norm();
          const double big = std::max(x.radius, y.radius), small = std::min(x.radius, y.radius);
          if (d < 0.5 * big && small > 0.4 * big)
            candidates.push_back({d, {a, b, static_cast<int>(la), static_cast<int>(lb)}});
        }
    }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& x, const Candidate& y) { return x.distance < y.distance; });
  std::vector<Junction> out;
  std::vector<std::vector<bool>> used(pieces.size());
  for (std::size_t p = 0; p < pieces.size(); ++p) used[p].assign(pieces[p].loops.size(), false);
  for (const Candidate& c : candidates) {
    const Junction& j = c.j;
    if (used[j.a][static_cast<std::size_t>(j.loop_a)] || used[j.b][static_cast<std::size_t>(j.loop_b)]) continue;
    used[j.a][static_cast<std::size_t>(j.loop_a)] = used[j.b][static_cast<std::size_t>(j.loop_b)] = true;
    out.push_back(j);
  }
  return out;
}

// A piece's length along the organ, roughly: its area over its open ends' mean perimeter.
double piece_length(const OrganPiece& p) {
  if (p.loops.empty()) return std::sqrt(p.area);
  double perimeter = 0.0;
  for (const auto& loop : p.loops) perimeter += loop_shape(p.mesh, loop).perimeter;
  return p.area / std::max(1e-300, perimeter / static_cast<double>(p.loops.size()));
}

}  // namespace

std::string OrganLayout::text() const {
  std::string t = path.size() == 1 ? "one piece" : fmt::format("{} pieces joined end to end", path.size());
  if (!lumens.empty())
    t += fmt::format(", walled: {} lumen shell{} inside the outer wall", lumens.size(), lumens.size() == 1 ? "" : "s");
  if (!left_out.empty())
    t += fmt::format("; {} piece{} left out (side branches or pieces not joined to the organ)", left_out.size(),
                     left_out.size() == 1 ? "" : "s");
  return t;
}

OrganLayout organ_layout(std::vector<TriangleMesh> meshes) {
  OrganLayout layout;
  for (auto& m : meshes) {
    OrganPiece p;
    p.loops = boundary_loops(m);
    p.area = triangle_area(m);
    p.mesh = std::move(m);
    layout.pieces.push_back(std::move(p));
  }
  auto& pieces = layout.pieces;
  find_lumens(pieces);
  const std::vector<Junction> junctions = find_junctions(pieces);

  // The path: the chain of joined outer pieces that is longest along the organ (pieces are few;
  // every simple path is tried, with a bound).
  const std::size_t n = pieces.size();
  std::vector<std::vector<std::pair<std::size_t, std::size_t>>> next(n);  // (piece, junction)
  for (std::size_t j = 0; j < junctions.size(); ++j) {
    next[junctions[j].a].emplace_back(junctions[j].b, j);
    next[junctions[j].b].emplace_back(junctions[j].a, j);
  }
  std::vector<double> weight(n);
  for (std::size_t p = 0; p < n; ++p) weight[p] = piece_length(pieces[p]);
  std::vector<std::size_t> best, current;
  double best_length = -1.0;
  std::vector<bool> on(n, false);
  std::size_t budget = 200000;
  std::function<void(std::size_t, double)> walk = [&](std::size_t p, double length) {
    if (budget == 0) return;
    --budget;
    on[p] = true;
    current.push_back(p);
    if (length > best_length) {
      best_length = length;
      best = current;
    }
    for (const auto& [q, j] : next[p])
      if (!on[q]) walk(q, length + weight[q]);
    current.pop_back();
    on[p] = false;
  };
  for (std::size_t p = 0; p < n; ++p)
    if (pieces[p].inside_of < 0) walk(p, weight[p]);
  layout.path = best;
  for (std::size_t i = 0; i < best.size(); ++i) {
    auto loop_towards = [&](std::size_t other) {
      for (const Junction& j : junctions) {
        if (j.a == best[i] && j.b == other) return j.loop_a;
        if (j.b == best[i] && j.a == other) return j.loop_b;
      }
      return -1;
    };
    layout.start_loop.push_back(i > 0 ? loop_towards(best[i - 1]) : -1);
    layout.end_loop.push_back(i + 1 < best.size() ? loop_towards(best[i + 1]) : -1);
  }
  for (std::size_t p = 0; p < n; ++p) {
    const bool on_path = std::find(best.begin(), best.end(), p) != best.end();
    if (on_path) continue;
    const int c = pieces[p].inside_of;
    if (c >= 0 && std::find(best.begin(), best.end(), static_cast<std::size_t>(c)) != best.end())
      layout.lumens.push_back(p);
    else
      layout.left_out.push_back(p);
  }
  return layout;
}

}  // namespace haustra::import
