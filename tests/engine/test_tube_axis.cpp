// A tube's axis pieces on shapes whose answer is known: the path through the level contours
// (parallel contours, a handle with a longer branch) and boundary loops that touch at a pinch.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "haustra/tube_axis.hpp"

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
