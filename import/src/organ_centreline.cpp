// An organ's centreline from its pieces' harmonic axes, joined, pulled back from closed ends, smoothed.
#include "organ_centreline.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "haustra/error.hpp"
#include "haustra/tube_axis.hpp"

namespace haustra::import {
namespace {

constexpr double kLineSpacing = 0.001;    // m between the written points
constexpr double kLevelSpacing = 0.0005;  // m, the largest gap between section centres
constexpr double kInf_gap = 1e300;

struct Stretch {
  std::vector<Eigen::Vector3d> centre;
  std::vector<double> radius;  // the section's equivalent radius, sqrt(area / π)
  bool start_open = false, end_open = false;
};

std::pair<TubeEnd, TubeEnd> piece_ends(const OrganPiece& piece, int start_loop, int end_loop) {
  auto end_of = [&](int l) { return loop_end(piece.mesh, piece.loops, l); };
  if (start_loop >= 0 && end_loop >= 0) return {end_of(start_loop), end_of(end_loop)};
  if (start_loop >= 0) return farthest_ends(piece.mesh, piece.loops, end_of(start_loop));
  if (end_loop >= 0) {
    auto [a, b] = farthest_ends(piece.mesh, piece.loops, end_of(end_loop));
    return {b, a};
  }
  return farthest_ends(piece.mesh, piece.loops, std::nullopt);
}

// The stretch from a closed end's tip to where the tube is as far from the tip as it is wide,
// taken off (at most 40 % of the line).
std::size_t tip_cut(const Stretch& s) {
  const Eigen::Vector3d tip = s.centre.front();
  std::size_t k = 1;
  for (; k < s.centre.size(); ++k)
    if ((s.centre[k] - tip).norm() >= s.radius[k]) break;
  return std::min(k, (4 * s.centre.size()) / 10);
}

// Where a wall of two shells is joined at a fold (a sleeve: the outer surface turns in at an end and
// runs back as the lumen), the line through the sections runs to the fold and back inside itself.
// The place it turns: three radii before and after it lie within half a radius of each other (two
// loops of an organ that touch are two radii apart). Returns the index, or the size if none.
std::size_t fold_back(const Stretch& s) {
  std::vector<double> arc(s.centre.size(), 0.0);
  for (std::size_t i = 1; i < s.centre.size(); ++i) arc[i] = arc[i - 1] + (s.centre[i] - s.centre[i - 1]).norm();
  std::size_t best = s.centre.size();
  double best_gap = kInf_gap;
  for (std::size_t i = 0; i < s.centre.size(); ++i) {
    const double r = std::max(s.radius[i], 1e-4);
    bool folded = true;
    double gap = 0.0;
    for (double reach : {2.0 * r, 4.0 * r, 6.0 * r}) {
      const auto before = std::lower_bound(arc.begin(), arc.end(), arc[i] - reach);
      const auto after = std::lower_bound(arc.begin(), arc.end(), arc[i] + reach);
      if (arc[i] - reach < 0.0 || after == arc.end()) {
        folded = false;
        break;
      }
      const double d = (s.centre[static_cast<std::size_t>(before - arc.begin())] -
                        s.centre[static_cast<std::size_t>(after - arc.begin())])
                           .norm();
      gap = std::max(gap, d / r);
      folded = folded && d < 0.5 * r;
    }
    if (folded && gap < best_gap) {
      best_gap = gap;
      best = i;
    }
  }
  return best;
}

// The sections' centres through every piece on the organ's path, in order.
Stretch axis_through_pieces(const OrganLayout& layout, int& capped_loops) {
  Stretch line;
  for (std::size_t i = 0; i < layout.path.size(); ++i) {
    const OrganPiece& piece = layout.pieces[layout.path[i]];
    const auto [start, end] = piece_ends(piece, layout.start_loop[i], layout.end_loop[i]);
    const TubeAxis axis = tube_axis(piece.mesh, piece.loops, start, end, kLevelSpacing);
    capped_loops += axis.capped_loops;
    if (i == 0) line.start_open = start.open;
    if (i + 1 == layout.path.size()) line.end_open = end.open;
    for (const CrossSection& s : axis.sections) {
      line.centre.push_back(s.centre);
      line.radius.push_back(std::sqrt(s.area / std::numbers::pi));
    }
  }
  return line;
}

// Folded back inside itself: the longer way from the fold is the organ, the rest its other shell.
// Returns the length left out.
double unfold(Stretch& line) {
  double folded = 0.0;
  for (int guard = 0; guard < 4; ++guard) {
    const std::size_t fold = fold_back(line);
    if (fold == line.centre.size()) break;
    const auto at = static_cast<std::ptrdiff_t>(fold);
    const double before = polyline_length(Polyline(line.centre.begin(), line.centre.begin() + at + 1));
    const double total = polyline_length(line.centre);
    if (before >= total - before) {
      line.centre.resize(fold + 1);
      line.radius.resize(fold + 1);
      line.end_open = false;
    } else {
      line.centre.erase(line.centre.begin(), line.centre.begin() + at);
      line.radius.erase(line.radius.begin(), line.radius.begin() + at);
      line.start_open = false;
    }
    folded += std::min(before, total - before);
  }
  return folded;
}

// The base is the wider open end: a tip never, the wider rim where both are open (`reverse`: the
// other way). Returns whether the line was turned round.
bool orient(Stretch& line, bool reverse) {
  const double r0 = line.radius.front(), r1 = line.radius.back();
  bool flip = (!line.start_open && line.end_open) || (line.start_open == line.end_open && r1 > r0);
  if (reverse) flip = !flip;
  if (flip) {
    std::reverse(line.centre.begin(), line.centre.end());
    std::reverse(line.radius.begin(), line.radius.end());
    std::swap(line.start_open, line.end_open);
  }
  return flip;
}

// Closed ends: the centres run onto the tip; the line stops a radius short of it. Where pieces meet,
// their rims' centres may step back a little: the line never turns back. Returns the line kept
// and, in `radius`, the median section radius along it.
Polyline cut_tips(const Stretch& line, double& radius) {
  std::size_t cut_start = 0, cut_end = 0;
  if (!line.start_open) cut_start = tip_cut(line);
  if (!line.end_open) {
    Stretch back = line;
    std::reverse(back.centre.begin(), back.centre.end());
    std::reverse(back.radius.begin(), back.radius.end());
    cut_end = tip_cut(back);
  }
  if (cut_start + cut_end + 2 > line.centre.size())
    throw Error(ErrorCode::invalid_geometry, "no tube in this mesh: its ends are closer than its radius");
  const auto first = static_cast<std::ptrdiff_t>(cut_start), last = static_cast<std::ptrdiff_t>(cut_end);
  std::vector<double> radii(line.radius.begin() + first, line.radius.end() - last);
  std::nth_element(radii.begin(), radii.begin() + static_cast<std::ptrdiff_t>(radii.size() / 2), radii.end());
  radius = radii[radii.size() / 2];
  // A line that comes back within half a radius of itself a few radii on is kept (decision 0113):
  // a tube cannot, but where a loop is fused where it starts, the line leaves and comes back
  // through the centroids of the contours round the fusion.
  return remove_backtracks(Polyline(line.centre.begin() + first, line.centre.end() - last));
}

// The last radius at each end laid straight along the line's direction one to two radii in: the
// sections next to an obliquely cut rim, or to a tip, are tilted, and their centroids hook (a hook
// at an end is a kink the rod's first sections cannot hold). Lines shorter than four radii stay.
Polyline straight_ends(const Polyline& p, double spacing, double radius) {
  const auto k = static_cast<std::size_t>(std::round(radius / spacing));
  if (k == 0 || p.size() < 4 * k + 2) return p;
  Polyline out = p;
  const Eigen::Vector3d t0 = (p[2 * k] - p[k]).normalized(),
                        t1 = (p[p.size() - 1 - k] - p[p.size() - 1 - 2 * k]).normalized();
  for (std::size_t i = 0; i < k; ++i) {
    out[i] = p[k] - static_cast<double>(k - i) * spacing * t0;
    out[p.size() - 1 - i] = p[p.size() - 1 - k] + static_cast<double>(k - i) * spacing * t1;
  }
  return out;
}

}  // namespace

OrganCentreline organ_centreline(const OrganLayout& layout, bool reverse) {
  if (layout.path.empty()) throw Error(ErrorCode::invalid_geometry, "no outer wall to follow");
  OrganCentreline out;
  Stretch line = axis_through_pieces(layout, out.capped_loops);
  out.folded = unfold(line);
  out.reversed = orient(line, reverse);
  out.open_ends = (line.start_open ? 1 : 0) + (line.end_open ? 1 : 0);
  const double before = polyline_length(line.centre);
  double radius = 0.0;
  const Polyline kept = cut_tips(line, radius);
  out.pulled_back = std::max(0.0, before - polyline_length(kept));
  out.points =
      resample(straight_ends(remove_backtracks(smooth(resample(kept, kLineSpacing), kLineSpacing, 0.5 * radius)),
                             kLineSpacing, radius),
               kLineSpacing);
  out.text = fmt::format(
      "computed: the area centroids of a harmonic function's level sets on the outer wall ({} piece{}, {} open "
      "end{}{}{}{}), smoothed over {:.1f} mm",
      layout.path.size(), layout.path.size() == 1 ? "" : "s", out.open_ends, out.open_ends == 1 ? "" : "s",
      out.capped_loops > 0
          ? fmt::format(", {} side opening{} capped for the solve", out.capped_loops, out.capped_loops == 1 ? "" : "s")
          : "",
      out.pulled_back > 0.0
          ? fmt::format(", {:.0f} mm short of the closed end{}", 1e3 * out.pulled_back, out.open_ends == 0 ? "s" : "")
          : "",
      out.folded > 0.0 ? fmt::format(", {:.0f} mm where the wall folds back inside itself (its other shell) left out",
                                     1e3 * out.folded)
                       : "",
      0.5e3 * radius);
  return out;
}

}  // namespace haustra::import
