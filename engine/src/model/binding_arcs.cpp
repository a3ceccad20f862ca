// Each mesh vertex's place along the rest centreline for the binding pose (decision 0049).
#include "model/binding_arcs.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>

#include "haustra/error.hpp"
#include "haustra/tube_axis.hpp"
#include "model/surface_graph.hpp"

namespace haustra::detail {
namespace {

// The closest point's arc among the centreline's samples [first, last).
double closest_arc_between(std::span<const Eigen::Vector3d> samples, double length, const Eigen::Vector3d& x,
                           std::size_t first, std::size_t last) {
  const std::size_t segments = samples.size() - 1;
  double best = kNoPath, best_s = 0.0;
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

double closest_arc_within(std::span<const Eigen::Vector3d> samples, double length, const Eigen::Vector3d& x, double lo,
                          double hi) {
  const double per_sample = length / static_cast<double>(samples.size() - 1);
  const double first = std::clamp(lo, 0.0, length) / per_sample, last = std::clamp(hi, 0.0, length) / per_sample;
  return closest_arc_between(samples, length, x, static_cast<std::size_t>(first),
                             static_cast<std::size_t>(std::ceil(last)) + 1);
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
  if (misplaced == 0) return 0;
  // Nothing well placed to follow from (the ends' order guessed wrong on a short piece): the
  // caller places the piece by closest points.
  if (misplaced == n) throw Error(ErrorCode::invalid_geometry, "every vertex astray of its harmonic place");
  std::vector<std::uint32_t> well_placed;
  for (std::uint32_t v = 0; v < n; ++v)
    if (placed[v] != 0) well_placed.push_back(v);
  // Out from the well-placed vertices: each vertex reached looks near the place of the one it was
  // reached from (within twice the edge, and a millimetre).
  dijkstra_within(adjacency(piece), n, well_placed, kNoPath, [&](std::uint32_t v, std::uint32_t w, double edge) {
    const double reach = 2.0 * edge + 1e-3;
    const double lo = std::max(0.0, arc[v] - reach), hi = std::min(length, arc[v] + reach);
    arc[w] = closest_arc_between(samples, length, piece.vertices[w], static_cast<std::size_t>(lo / per_sample),
                                 static_cast<std::size_t>(std::ceil(hi / per_sample)) + 1);
  });
  // Where even that runs astray (a surface whose topology is no tube's), the closest point.
  for (std::size_t v = 0; v < n; ++v) {
    const Eigen::Vector3d& x = piece.vertices[v];
    const double closest = closest_arc(samples, length, x);
    if ((at(arc[v]) - x).norm() > 2.0 * (at(closest) - x).norm() + 2e-3) arc[v] = closest;
  }
  return misplaced;
}

}  // namespace

std::vector<Eigen::Vector3d> centreline_samples(const RodCurve& curve) {
  constexpr double kSamplesPerMetre = 2000.0;
  const double length = curve.length();
  const auto samples = static_cast<std::size_t>(std::max(64.0, std::ceil(length * kSamplesPerMetre)));
  std::vector<Eigen::Vector3d> point(samples + 1);
  for (std::size_t i = 0; i <= samples; ++i)
    point[i] = curve.pose_at(length * static_cast<double>(i) / static_cast<double>(samples)).position;
  return point;
}

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
  for (const auto& t : mesh.triangles)
    pieces[piece_of[t[0]]].triangles.push_back({local[t[0]], local[t[1]], local[t[2]]});
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

}  // namespace haustra::detail
