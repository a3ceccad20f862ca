// A tube's axis pieces on shapes whose answer is known: the path through the level contours
// (parallel contours, a handle with a longer branch), boundary loops that touch at a pinch, a tube
// whose loop is fused where it starts (the axis follows the loop round); and the cut of fused loops
// (decision 0118) on a coarse tube and a jump.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <optional>
#include <utility>
#include <vector>

#include "fused_hairpin.hpp"
#include "haustra/tube_axis.hpp"
#include "model/binding_arcs.hpp"
#include "model/fused_contacts.hpp"

using namespace haustra;

namespace {

constexpr double kSpacing = 1e-3;
constexpr double kRadius = 0.01;

CrossSection contour(double x, double z) {
  CrossSection c;
  c.centre = Eigen::Vector3d(x, 0.0, z);
  c.area = std::numbers::pi * kRadius * kRadius;
  return c;
}

int switches(const std::vector<CrossSection>& way, double split_x) {
  int n = 0;
  for (std::size_t k = 1; k < way.size(); ++k)
    n += (way[k].centre.x() > split_x) != (way[k - 1].centre.x() > split_x) ? 1 : 0;
  return n;
}

}  // namespace

TEST_CASE("section path: two parallel contours closer than the tube's size are never crossed between") {
  // Two contours per level, 15 mm apart (a tube of radius 10 mm whose walls are fused alongside
  // another's): a step across is within reach but continues neither, so the path stays on one.
  std::vector<std::vector<CrossSection>> levels;
  for (int k = 0; k <= 40; ++k) levels.push_back({contour(0.0, k * kSpacing), contour(0.015, k * kSpacing)});
  const std::vector<CrossSection> way = section_path(levels, kSpacing);
  REQUIRE(way.size() == levels.size());
  CHECK(switches(way, 0.0075) == 0);
}

TEST_CASE("section path: through a handle it takes the longer branch, entering and leaving once") {
  // One contour for 10 levels, then two (a straight branch at x = 0 and a bulging one from 15 mm
  // out to 25 mm and back) for 20, then one again: the tube went round its loop the long way.
  std::vector<std::vector<CrossSection>> levels;
  for (int k = 0; k <= 40; ++k) {
    const double z = k * kSpacing;
    if (k < 10 || k >= 30) {
      levels.push_back({contour(0.0, z)});
      continue;
    }
    const double bulge = 0.015 + 0.01 * std::sin(std::numbers::pi * (k - 10) / 19.0);
    levels.push_back({contour(0.0, z), contour(bulge, z)});
  }
  const std::vector<CrossSection> way = section_path(levels, kSpacing);
  REQUIRE(way.size() == levels.size());
  for (int k = 10; k < 30; ++k) CHECK(way[static_cast<std::size_t>(k)].centre.x() > 0.01);
  CHECK(switches(way, 0.0075) == 2);
}

TEST_CASE("boundary loops: two squares touching at one corner are two loops of four, not one of eight") {
  TriangleMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {2, 1, 0}, {2, 2, 0}, {1, 2, 0}};
  // The squares share vertex 2 (the first's top right, the second's bottom left).
  m.triangles = {{0, 1, 2}, {0, 2, 3}, {2, 4, 5}, {2, 5, 6}};
  const auto loops = boundary_loops(m);
  REQUIRE(loops.size() == 2);
  for (const auto& loop : loops) {
    CHECK(loop.size() == 4);
    CHECK(std::count(loop.begin(), loop.end(), 2U) == 1);
  }
}

namespace {

double polyline_length(const std::vector<Eigen::Vector3d>& p) {
  double l = 0.0;
  for (std::size_t k = 1; k < p.size(); ++k) l += (p[k] - p[k - 1]).norm();
  return l;
}

}  // namespace

TEST_CASE("tube axis: a tube whose loop is fused where it starts is followed round the loop, not across") {
  // The harmonic flow runs through the fusion and the whole loop (more than half the tube) lies
  // within a sliver of u that evenly spaced levels step over: the axis cut across and left the loop
  // out (measured before levels at the vertices: its sections 437 mm of the tube's 855 mm, the wall
  // from its place on them 20.3 mm at the median, 196 mm at the 90th percentile, 234 mm at the
  // 99th, the loop placed at the fusion). Levels at the vertices' own u cross the loop all along.
  const double r = 0.01, d = 0.024;
  std::vector<Eigen::Vector3d> truth;
  const TriangleMesh mesh = test::fused_hairpin(r, d, 70, truth);
  const auto loops = boundary_loops(mesh);
  REQUIRE(loops.size() == 2);
  const auto [start, end] = farthest_ends(mesh, loops, std::nullopt);
  REQUIRE(start.open);
  REQUIRE(end.open);
  const TubeAxis axis = tube_axis(mesh, loops, start, end, 5e-4);
  std::vector<Eigen::Vector3d> line;
  for (const CrossSection& s : axis.sections) line.push_back(s.centre);
  const double length = polyline_length(line), tube = polyline_length(truth);
  // The wall's places along that line (the binding's), evenly resampled as the engine samples it.
  std::vector<double> arc{0.0};
  for (std::size_t k = 1; k < line.size(); ++k) arc.push_back(arc.back() + (line[k] - line[k - 1]).norm());
  const auto samples = static_cast<std::size_t>(std::ceil(length * 2000.0));
  std::vector<Eigen::Vector3d> even(samples + 1);
  for (std::size_t i = 0, k = 0; i <= samples; ++i) {
    const double a = length * static_cast<double>(i) / static_cast<double>(samples);
    while (k + 2 < arc.size() && arc[k + 1] < a) ++k;
    const double t = std::clamp((a - arc[k]) / std::max(arc[k + 1] - arc[k], 1e-300), 0.0, 1.0);
    even[i] = line[k] + t * (line[k + 1] - line[k]);
  }
  const detail::BindingArcs places = detail::harmonic_binding_arcs(mesh, even, length);
  std::vector<double> off;
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    const double x =
        std::clamp(places.arc[v] / length * static_cast<double>(samples), 0.0, static_cast<double>(samples));
    const auto i = std::min(static_cast<std::size_t>(x), samples - 1);
    const Eigen::Vector3d at = even[i] + (x - static_cast<double>(i)) * (even[i + 1] - even[i]);
    off.push_back((at - mesh.vertices[v]).norm());
  }
  std::sort(off.begin(), off.end());
  const double median = off[off.size() / 2], p99 = off[off.size() * 99 / 100];
  MESSAGE("axis " << length * 1e3 << " mm of the tube's " << tube * 1e3 << " mm; wall from its place: median "
                  << median * 1e3 << " mm, 99th percentile " << p99 * 1e3 << " mm (radius " << r * 1e3 << " mm)");
  CHECK(length > 0.95 * tube);
  CHECK(length < 1.05 * tube);
  const double p90 = off[off.size() * 9 / 10];
  CHECK(median < 1.1 * r);  // 1.00 r measured
  CHECK(p90 < 1.5 * r);     // 1.06 r
  CHECK(p99 < 4.0 * r);     // 2.14 r: the sleeve across the fusion, placed on one leg or the other
}

// Decision 0118's cut is for a neck, not a coarse mesh: a tube of two rings (a CAD cylinder's eight
// long triangles) has places 0 and L at its ends, L more than 4 radii, but no edge is cut — the jump
// is no longer than the triangles. A sleeve whose places jump by 60 edge lengths is cut.
TEST_CASE("the fused cut leaves a coarse tube whole and cuts a jump of many edge lengths") {
  const double r = 0.01, length = 0.1;
  TriangleMesh tube;
  for (int ring = 0; ring < 2; ++ring)
    for (int j = 0; j < 8; ++j) {
      const double a = 2.0 * std::numbers::pi * j / 8.0;
      tube.vertices.emplace_back(r * std::cos(a), r * std::sin(a), ring * length);
    }
  for (std::uint32_t j = 0; j < 8; ++j) {
    const std::uint32_t k = (j + 1) % 8;
    tube.triangles.push_back({j, k, 8 + k});
    tube.triangles.push_back({j, 8 + k, 8 + j});
  }
  std::vector<Eigen::Vector3d> samples;
  for (int i = 0; i <= 200; ++i) samples.emplace_back(0.0, 0.0, length * i / 200.0);
  std::vector<double> place(16);
  for (std::size_t v = 0; v < 16; ++v) place[v] = v < 8 ? 0.0 : length;
  TriangleMesh coarse = tube;
  const detail::FusedCut none = detail::cut_fused_contacts(coarse, place, 4.0 * r, samples, length);
  CHECK(none.copies == 0);
  CHECK(coarse.vertices.size() == 16);
  // The same tube 2 mm across and 1 mm long: its edges are at most 1.2 mm, its places still jump by
  // 0.1 m across every triangle: every vertex is cut once (its triangles of the other ring's place
  // take a copy), each triangle's corners then share its place, and nothing moves.
  TriangleMesh fine = tube;
  for (auto& x : fine.vertices) x = Eigen::Vector3d(0.1 * x.x(), 0.1 * x.y(), x.z() < 0.5 * length ? 0.0 : 0.001);
  std::vector<double> fine_place(place);
  const detail::FusedCut cut = detail::cut_fused_contacts(fine, fine_place, 4.0 * r, samples, length);
  CHECK(cut.vertices_cut == 16);
  CHECK(cut.copies == 16);
  REQUIRE(fine.vertices.size() == 32);
  REQUIRE(fine_place.size() == 32);
  for (const auto& t : fine.triangles) {
    const auto [lo, hi] = std::minmax({fine_place[t[0]], fine_place[t[1]], fine_place[t[2]]});
    CHECK(hi - lo <= 4.0 * r + 1e-12);  // a copy is placed within the jump of its group's place
  }
  for (std::size_t v = 16; v < 32; ++v) {
    bool twin = false;
    for (std::size_t u = 0; u < 16; ++u) twin = twin || fine.vertices[u] == fine.vertices[v];
    CHECK(twin);
  }
}
