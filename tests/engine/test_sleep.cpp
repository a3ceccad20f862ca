// Sleeping rods (decision 0119) on `ropes` (six clamped rods: the elastic and Kelvin–Voigt ones come to
// rest, the viscous ones creep on): who sleeps, what it costs in accuracy against every rod awake,
// what wakes them, and the same bits with 1 and 2 threads and through a checkpoint.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "haustra/profile.hpp"
#include "haustra/world.hpp"
#include "scene_fixtures.hpp"

namespace haustra {

namespace {

const std::vector<std::string> kSleep{"sleep.enabled=true"};

double largest_difference(const World& a, const World& b) {
  const std::vector<double> x = test::positions(a), y = test::positions(b);
  double worst = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) worst = std::max(worst, std::abs(x[i] - y[i]));
  return worst;
}

// Node range of `ropes`' rod `rod` (each 81 nodes).
Range rod_nodes(const World& w, std::size_t rod) { return w.segment(rod).nodes; }

}  // namespace

TEST_CASE("sleeping rods: the rods at rest sleep, held to the bit, within speed × time of every rod awake") {
  auto asleep = test::scene_world("ropes", 1, kSleep);
  auto awake = test::scene_world("ropes");
  test::step_both(*asleep, *awake, 120);  // 2 s at 60 Hz
  // The two elastic rods are at rest within 1 s; the viscous ones creep (~5 mm/s) and stay awake.
  CHECK(asleep->last_profile().nodes_asleep == 2 * 81);
  CHECK(awake->last_profile().nodes_asleep == 0);
  CHECK(largest_difference(*asleep, *awake) < 1e-12);  // measured 1.4e-17: asleep where they stopped
  const std::vector<double> before = test::positions(*asleep);
  test::step_both(*asleep, *awake, 480);  // to 10 s
  // Held to the bit while asleep.
  const std::vector<double> after = test::positions(*asleep);
  for (const std::size_t rod : {2u, 3u}) {
    const Range r = rod_nodes(*asleep, rod);
    CHECK(std::memcmp(before.data() + 3 * r.offset, after.data() + 3 * r.offset, 3 * r.count * sizeof(double)) == 0);
  }
  // What sleeping costs: motion slower than sleep.speed (1 mm/s) left out over the 9 s asleep.
  const double drift = largest_difference(*asleep, *awake);
  CHECK(drift > 0.0);
  CHECK(drift < 1e-3 * 9.0);  // measured 1.5e-3 m
  CHECK(asleep->last_profile().nodes_asleep >= 3 * 81);
}

TEST_CASE("sleeping rods: a host's load wakes them, and the loaded rod moves") {
  auto w = test::scene_world("ropes", 1, kSleep);
  for (int f = 0; f < 120; ++f) w->step();
  REQUIRE(w->last_profile().nodes_asleep == 2 * 81);
  const Range r = rod_nodes(*w, 2);
  const Eigen::Vector3d tip = w->node_positions().get(r.offset + r.count - 1);
  w->set_external_load(r.offset + r.count - 1, Eigen::Vector3d(0.0, 0.0, -0.05), Eigen::Vector3d::Zero());
  w->step();
  CHECK(w->last_profile().nodes_asleep == 0);
  CHECK((w->node_positions().get(r.offset + r.count - 1) - tip).z() < -1e-4);  // the tip sags under the load
}

TEST_CASE("sleeping rods: the same bits with 1 and 2 threads, and through a checkpoint") {
  auto one = test::scene_world("ropes", 1, kSleep);
  auto two = test::scene_world("ropes", 2, kSleep);
  test::step_both(*one, *two, 150);
  CHECK(one->last_profile().nodes_asleep == two->last_profile().nodes_asleep);
  CHECK(test::positions(*one) == test::positions(*two));
  const std::vector<std::byte> saved = one->save_checkpoint();
  for (int f = 0; f < 60; ++f) one->step();
  auto restored = test::scene_world("ropes", 1, kSleep);
  restored->restore_checkpoint(saved);
  for (int f = 0; f < 60; ++f) restored->step();
  CHECK(restored->last_profile().nodes_asleep == one->last_profile().nodes_asleep);
  CHECK(test::positions(*restored) == test::positions(*one));
}

}  // namespace haustra
