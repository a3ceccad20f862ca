// Outer walls, lumens inside them, and the order of an organ's pieces along it.
#include "organ_layout.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
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

// Per piece, its loops worth joining at: open ends at least a quarter as long as its longest loop
// (as the tube's ends are chosen: a smaller opening is a side hole, where a branch may meet the
// organ but the organ does not run on).
std::vector<std::vector<bool>> open_ends(const std::vector<std::vector<LoopShape>>& shapes) {
  std::vector<std::vector<bool>> end(shapes.size());
  for (std::size_t p = 0; p < shapes.size(); ++p) {
    double longest = 0.0;
    for (const LoopShape& s : shapes[p]) longest = std::max(longest, s.perimeter);
    for (const LoopShape& s : shapes[p]) end[p].push_back(s.perimeter >= 0.25 * longest);
  }
  return end;
}

// Open ends of pieces from different surfaces that share points (surfaces cut from one
// segmentation: the same points on both sides of a cut) in at least a quarter of the smaller rim,
// each pair of loops once, after `joined` (which already meet). Not exclusive: a wedge cut at a
// flexure shares its one rim with the pieces on both sides, which also share points with each other.
std::vector<Junction> shared_rims(const std::vector<OrganPiece>& pieces, const std::vector<std::vector<bool>>& ends,
                                  const std::vector<Junction>& joined) {
  using Key = std::array<float, 3>;  // a point as a reader that joins identical vertices sees it
  std::map<Key, std::vector<std::pair<std::size_t, std::size_t>>> at;  // (piece, loop) through each point
  for (std::size_t p = 0; p < pieces.size(); ++p) {
    if (pieces[p].inside_of >= 0) continue;
    for (std::size_t l = 0; l < pieces[p].loops.size(); ++l) {
      if (!ends[p][l]) continue;
      for (std::uint32_t v : pieces[p].loops[l]) {
        const Eigen::Vector3d& x = pieces[p].mesh.vertices[v];
        at[Key{static_cast<float>(x.x()), static_cast<float>(x.y()), static_cast<float>(x.z())}].emplace_back(p, l);
      }
    }
  }
  std::map<std::array<std::size_t, 4>, std::size_t> shared;  // (a, loop a, b, loop b), a < b: points
  for (const auto& [point, owners] : at)
    for (std::size_t i = 0; i < owners.size(); ++i)
      for (std::size_t k = i + 1; k < owners.size(); ++k) {
        auto [a, la] = owners[i];
        auto [b, lb] = owners[k];
        if (pieces[a].source == pieces[b].source) continue;
        if (b < a) std::swap(a, b), std::swap(la, lb);
        ++shared[{a, la, b, lb}];
      }
  std::vector<Junction> out;
  for (const auto& [rims, count] : shared) {
    const auto [a, la, b, lb] = rims;
    const std::size_t smaller = std::min(pieces[a].loops[la].size(), pieces[b].loops[lb].size());
    bool known = false;
    for (const Junction& j : joined)
      known = known || (j.a == a && j.b == b && j.loop_a == static_cast<int>(la) && j.loop_b == static_cast<int>(lb));
    if (!known && 4 * count >= smaller) out.push_back({a, b, static_cast<int>(la), static_cast<int>(lb)});
  }
  return out;
}

// Junctions: open ends whose rims' centres lie within half a radius (radii within 0.4×), each loop
// with its nearest only; then, between surfaces, rims that share points.
std::vector<Junction> find_junctions(const std::vector<OrganPiece>& pieces) {
  struct Candidate {
    double distance;
    Junction j;
  };
  std::vector<std::vector<LoopShape>> shapes(pieces.size());
  for (std::size_t p = 0; p < pieces.size(); ++p)
    for (const auto& loop : pieces[p].loops) shapes[p].push_back(loop_shape(pieces[p].mesh, loop));
  const std::vector<std::vector<bool>> ends = open_ends(shapes);
  std::vector<Candidate> candidates;
  for (std::size_t a = 0; a < pieces.size(); ++a)
    for (std::size_t b = a + 1; b < pieces.size(); ++b) {
      if (pieces[a].inside_of >= 0 || pieces[b].inside_of >= 0) continue;
      for (std::size_t la = 0; la < shapes[a].size(); ++la)
        for (std::size_t lb = 0; lb < shapes[b].size(); ++lb) {
          if (!ends[a][la] || !ends[b][lb]) continue;
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
  const std::vector<Junction> shared = shared_rims(pieces, ends, out);
  out.insert(out.end(), shared.begin(), shared.end());
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
  const std::size_t off = left_out.size() - joined_off_path.size();  // left out and not skinned
  if (off > 0)
    t += fmt::format("; {} piece{} left out (side branches or pieces not joined to the organ)", off,
                     off == 1 ? "" : "s");
  if (!joined_off_path.empty())
    t += fmt::format("; {} piece{} joined off its path (a flexure's wedge, a branch): skinned with it",
                     joined_off_path.size(), joined_off_path.size() == 1 ? "" : "s");
  return t;
}

namespace {

// The pieces of a surface (or of several: source[p]), their loops and areas, lumens marked.
std::vector<OrganPiece> sorted_pieces(std::vector<TriangleMesh> meshes, const std::vector<std::size_t>& source) {
  std::vector<OrganPiece> pieces;
  for (std::size_t i = 0; i < meshes.size(); ++i) {
    OrganPiece p;
    p.loops = boundary_loops(meshes[i]);
    p.area = triangle_area(meshes[i]);
    p.mesh = std::move(meshes[i]);
    p.source = source.empty() ? 0 : source[i];
    pieces.push_back(std::move(p));
  }
  find_lumens(pieces);
  return pieces;
}

// An organ's path: its pieces in order, and per piece the loops it meets the one before and the one
// after at (−1: a free end).
struct Path {
  std::vector<std::size_t> pieces;
  std::vector<int> start_loop, end_loop;
};

// The chain of joined outer pieces, among those `allowed`, that is longest along the organ (pieces
// are few; every simple path is tried, with a bound). A piece is left by another loop than the one
// it was entered by.
Path longest_path(const std::vector<OrganPiece>& pieces, const std::vector<Junction>& junctions,
                  const std::vector<bool>& allowed) {
  const std::size_t n = pieces.size();
  std::vector<std::vector<std::pair<std::size_t, std::size_t>>> next(n);  // (piece, junction)
  for (std::size_t j = 0; j < junctions.size(); ++j) {
    next[junctions[j].a].emplace_back(junctions[j].b, j);
    next[junctions[j].b].emplace_back(junctions[j].a, j);
  }
  auto loop_of = [&](std::size_t j, std::size_t p) {
    return junctions[j].a == p ? junctions[j].loop_a : junctions[j].loop_b;
  };
  std::vector<double> weight(n);
  for (std::size_t p = 0; p < n; ++p) weight[p] = piece_length(pieces[p]);
  std::vector<std::size_t> best, current, best_via, via;  // via: the junction each piece was entered by
  double best_length = -1.0;
  std::vector<bool> on(n, false);
  std::size_t budget = 200000;
  std::function<void(std::size_t, int, double)> walk = [&](std::size_t p, int entered, double length) {
    if (budget == 0) return;
    --budget;
    on[p] = true;
    current.push_back(p);
    if (length > best_length) {
      best_length = length;
      best = current;
      best_via = via;
    }
    for (const auto& [q, j] : next[p]) {
      if (on[q] || !allowed[q] || (entered >= 0 && loop_of(j, p) == entered)) continue;
      via.push_back(j);
      walk(q, loop_of(j, q), length + weight[q]);
      via.pop_back();
    }
    current.pop_back();
    on[p] = false;
  };
  for (std::size_t p = 0; p < n; ++p)
    if (pieces[p].inside_of < 0 && allowed[p]) walk(p, -1, weight[p]);
  Path path;
  path.pieces = best;
  for (std::size_t i = 0; i < best.size(); ++i) {
    path.start_loop.push_back(i > 0 ? loop_of(best_via[i - 1], best[i]) : -1);
    path.end_loop.push_back(i + 1 < best.size() ? loop_of(best_via[i], best[i]) : -1);
  }
  return path;
}

bool on_path(const Path& path, std::size_t p) {
  return std::find(path.pieces.begin(), path.pieces.end(), p) != path.pieces.end();
}

// The pieces joined to a path through junctions, directly or through others, among those
// `allowed` (the path's own included), ascending.
std::vector<std::size_t> joined_to(const Path& path, const std::vector<Junction>& junctions,
                                   const std::vector<bool>& allowed) {
  std::vector<bool> in(allowed.size(), false);
  std::vector<std::size_t> stack(path.pieces.begin(), path.pieces.end());
  for (std::size_t p : stack) in[p] = true;
  while (!stack.empty()) {
    const std::size_t p = stack.back();
    stack.pop_back();
    for (const Junction& j : junctions) {
      const std::size_t q = j.a == p ? j.b : (j.b == p ? j.a : p);
      if (q == p || in[q] || !allowed[q]) continue;
      in[q] = true;
      stack.push_back(q);
    }
  }
  std::vector<std::size_t> out;
  for (std::size_t p = 0; p < in.size(); ++p)
    if (in[p]) out.push_back(p);
  return out;
}

}  // namespace

OrganLayout organ_layout(std::vector<TriangleMesh> meshes) {
  OrganLayout layout;
  layout.pieces = sorted_pieces(std::move(meshes), {});
  const auto& pieces = layout.pieces;
  const Path path = longest_path(pieces, find_junctions(pieces), std::vector<bool>(pieces.size(), true));
  layout.path = path.pieces;
  layout.start_loop = path.start_loop;
  layout.end_loop = path.end_loop;
  for (std::size_t p = 0; p < pieces.size(); ++p) {
    if (on_path(path, p)) continue;
    const int c = pieces[p].inside_of;
    if (c >= 0 && on_path(path, static_cast<std::size_t>(c)))
      layout.lumens.push_back(p);
    else
      layout.left_out.push_back(p);
  }
  return layout;
}

namespace {

// The organ of `path` with its own pieces: the path's, the lumens inside them, and `left_out`,
// moved out of `pieces` and numbered anew.
OrganLayout organ_of(std::vector<OrganPiece>& pieces, const Path& path, const std::vector<std::size_t>& lumens,
                     const std::vector<std::size_t>& left_out, const std::vector<std::size_t>& joined) {
  OrganLayout layout;
  std::map<std::size_t, std::size_t> renumbered;
  auto take = [&](std::size_t p) {
    renumbered[p] = layout.pieces.size();
    layout.pieces.push_back(std::move(pieces[p]));
    return layout.pieces.size() - 1;
  };
  for (std::size_t p : path.pieces) layout.path.push_back(take(p));
  for (std::size_t p : lumens) layout.lumens.push_back(take(p));
  for (std::size_t p : left_out) {
    layout.left_out.push_back(take(p));
    if (std::find(joined.begin(), joined.end(), p) != joined.end()) layout.joined_off_path.push_back(renumbered[p]);
  }
  for (OrganPiece& piece : layout.pieces)
    if (piece.inside_of >= 0) {
      const auto it = renumbered.find(static_cast<std::size_t>(piece.inside_of));
      piece.inside_of = it == renumbered.end() ? -1 : static_cast<int>(it->second);
    }
  layout.start_loop = path.start_loop;
  layout.end_loop = path.end_loop;
  return layout;
}

}  // namespace

std::vector<OrganLayout> organ_layouts(std::vector<TriangleMesh> meshes, const std::vector<std::size_t>& source) {
  std::vector<OrganPiece> pieces = sorted_pieces(std::move(meshes), source);
  const std::size_t n = pieces.size();
  const std::vector<Junction> junctions = find_junctions(pieces);
  // Organs one after another, the longest first, each from surfaces no organ has taken.
  std::vector<Path> paths;
  std::vector<int> taker(n == 0 ? 0 : 1 + *std::max_element(source.begin(), source.end()), -1);  // per surface
  for (;;) {
    std::vector<bool> allowed(n, false);
    bool any = false;
    for (std::size_t p = 0; p < n; ++p) {
      allowed[p] = pieces[p].inside_of < 0 && taker[pieces[p].source] < 0;
      any = any || allowed[p];
    }
    if (!any) break;
    Path path = longest_path(pieces, junctions, allowed);
    // Every surface joined to it, on its path or off it, is this organ's.
    for (const std::size_t p : joined_to(path, junctions, allowed))
      taker[pieces[p].source] = static_cast<int>(paths.size());
    paths.push_back(std::move(path));
  }
  // Each other piece goes with the organ around it (a lumen), or with the organ of its surface.
  std::vector<int> organ(n, -1);
  for (std::size_t o = 0; o < paths.size(); ++o)
    for (std::size_t p : paths[o].pieces) organ[p] = static_cast<int>(o);
  std::vector<std::vector<std::size_t>> lumens(paths.size()), left_out(paths.size()), joined(paths.size());
  for (std::size_t o = 0; o < paths.size(); ++o) {
    std::vector<bool> its(n, false);  // the outer pieces of the surfaces it took
    for (std::size_t p = 0; p < n; ++p)
      its[p] = pieces[p].inside_of < 0 && taker[pieces[p].source] == static_cast<int>(o);
    for (const std::size_t p : joined_to(paths[o], junctions, its))
      if (organ[p] < 0) joined[o].push_back(p);
  }
  for (std::size_t p = 0; p < n; ++p) {
    if (organ[p] >= 0) continue;
    const int around = pieces[p].inside_of >= 0 ? organ[static_cast<std::size_t>(pieces[p].inside_of)] : -1;
    if (around >= 0) {
      lumens[static_cast<std::size_t>(around)].push_back(p);
      continue;
    }
    if (taker[pieces[p].source] >= 0) left_out[static_cast<std::size_t>(taker[pieces[p].source])].push_back(p);
  }
  // In the order of their first surface.
  std::vector<std::size_t> order(paths.size());
  std::vector<std::size_t> first(paths.size(), std::numeric_limits<std::size_t>::max());
  for (std::size_t o = 0; o < paths.size(); ++o)
    for (std::size_t p : paths[o].pieces) first[o] = std::min(first[o], pieces[p].source);
  for (std::size_t o = 0; o < order.size(); ++o) order[o] = o;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return first[a] < first[b]; });
  std::vector<OrganLayout> out;
  for (std::size_t o : order) out.push_back(organ_of(pieces, paths[o], lumens[o], left_out[o], joined[o]));
  return out;
}

}  // namespace haustra::import
