// Sleeping rods (decision 0119) on `ropes` (six clamped rods: the elastic and Kelvin–Voigt ones come to
// rest, the viscous ones creep on): who sleeps, what it costs in accuracy against every rod awake,
// what wakes them, and the same bits with 1 and 2 threads and through a checkpoint.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "haustra/error.hpp"
#include "haustra/profile.hpp"
#include "haustra/scene.hpp"
#include "haustra/world.hpp"
#include "host_job_pool.hpp"
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

namespace haustra {

namespace {

// scenes/range-pull.toml: a bowel held by its tissue over its base half, its tip lifted and pulled;
// tests/scenes/range-middle.toml: held over its middle, both ends lifted.
const std::string kRangePull = std::string(HAUSTRA_SOURCE_DIR) + "/scenes/range-pull.toml";
const std::string kRangeMiddle = std::string(HAUSTRA_SOURCE_DIR) + "/tests/scenes/range-middle.toml";

std::unique_ptr<World> range_world(const std::string& file, std::vector<std::string> sets = {}, int threads = 1,
                                   HostJobPool* pool = nullptr) {
  SceneDesc scene = load_scene(file, sets);
  scene.world.threads = threads;
  if (pool != nullptr) scene.world.jobs = {&HostJobPool::enqueue, &HostJobPool::wait, pool, threads};
  return create_world(scene);
}
std::unique_ptr<World> range_pull(std::vector<std::string> sets = {}, int threads = 1) {
  return range_world(kRangePull, std::move(sets), threads);
}

// How many of the nodes asleep before a frame (World::node_asleep) moved in it, to the bit.
std::size_t moved_asleep(const std::vector<bool>& asleep, const std::vector<double>& before,
                         const std::vector<double>& after) {
  std::size_t moved = 0;
  for (std::size_t k = 0; k < asleep.size(); ++k)
    moved += asleep[k] && std::memcmp(&before[3 * k], &after[3 * k], 3 * sizeof(double)) != 0 ? 1 : 0;
  return moved;
}

std::vector<bool> asleep_nodes(const World& w) {
  std::vector<bool> asleep(w.node_count());
  for (std::size_t k = 0; k < asleep.size(); ++k) asleep[k] = w.node_asleep(k);
  return asleep;
}

}  // namespace

namespace {

// Steps a world with ranges and one with everything awake to 4.2 s (the grasps on since 0.6 s):
// the nodes asleep before each frame kept their bits through it; the fewest asleep, the range's
// ends, and how far the two worlds are apart at the end.
struct RangeRun {
  std::size_t unheld = 0;
  int fewest = 1 << 30;
  bool middle = false;  // a range asleep with awake nodes on both sides
  double drift = 0.0;
};

RangeRun run_ranges(const std::string& file) {
  auto ranges = range_world(file);
  auto awake = range_world(file, {"sleep.enabled=false", "sleep.ranges=false"});
  RangeRun run;
  std::vector<double> before = test::positions(*ranges);
  for (int f = 0; f < 250; ++f) {
    const std::vector<bool> asleep = asleep_nodes(*ranges);
    ranges->step(), awake->step();
    const std::vector<double> after = test::positions(*ranges);
    if (f >= 40) run.unheld += moved_asleep(asleep, before, after);  // (before 40 a whole rod may wake mid-frame)
    if (f >= 45) run.fewest = std::min(run.fewest, ranges->last_profile().nodes_asleep);
    const std::size_t n = asleep.size();
    run.middle =
        run.middle || (!asleep[0] && !asleep[n - 1] && std::find(asleep.begin(), asleep.end(), true) != asleep.end());
    before = after;
  }
  run.drift = largest_difference(*ranges, *awake);
  return run;
}

}  // namespace

TEST_CASE(
    "sleeping ranges: the tissue-held base side of a pulled bowel sleeps, held to the bit, near everything awake") {
  const RangeRun run = run_ranges(kRangePull);
  CHECK(run.unheld == 0);
  CHECK(run.fewest >= 20);  // measured 30 of 151 nodes asleep at the fewest while the tip moves (no rod can: grasped)
  CHECK(run.drift > 1e-6);
  CHECK(run.drift < 2e-3);  // measured 2.0e-4 m: motion slower than sleep.speed left out
}

TEST_CASE("sleeping ranges: a range between two moving ends sleeps, held to the bit, its sides solved apart") {
  // Both ends lifted by graspers: the middle, held by its tissue, sleeps with awake nodes on both
  // sides; the base side ends on the range's first node (within 6 µm), the tip side starts at its last.
  const RangeRun run = run_ranges(kRangeMiddle);
  CHECK(run.middle);
  CHECK(run.unheld == 0);
  CHECK(run.drift > 1e-6);
  CHECK(run.drift < 8e-3);  // measured 9.8e-4 m: the middle's creep under both pulls left out
}

TEST_CASE("sleeping ranges: a probe touching the sleeping range wakes it, and the touched bowel gives way") {
  auto w = range_pull();
  for (int f = 0; f < 252; ++f) w->step();  // 4.2 s: the probe starts down
  REQUIRE(w->last_profile().nodes_asleep >= 20);
  const Eigen::Vector3d touched = w->node_positions().get(25);
  int woken = -1;
  for (int f = 252; f < 282 && woken < 0; ++f) {
    w->step();
    if (w->last_profile().nodes_asleep == 0) woken = f;
  }
  CHECK(woken > 252);  // when the probe reached the bowel, not before
  for (int f = 0; f < 10; ++f) w->step();
  CHECK((w->node_positions().get(25) - touched).z() < -1e-4);  // pressed into the floor (measured 0.38 mm)
}

TEST_CASE(
    "sleeping ranges: cutting the tissue of a sleeping node wakes the nodes round it, which sleep again once calm") {
  auto w = range_pull();
  for (int f = 0; f < 200; ++f) w->step();
  REQUIRE(w->node_asleep(20));
  const int before = w->last_profile().nodes_asleep;  // measured 51: nodes 0 to 50
  REQUIRE(before >= 40);
  CHECK(w->cut_tissue(w->node_positions().get(20), 0.005) > 0);  // 5 anchors, nodes 18 to 22
  // Nodes 10 to 30 restart their calm: neither side left beside them is 16 nodes long with its band.
  for (const std::size_t k : {0u, 20u, 40u}) CHECK_FALSE(w->node_asleep(k));
  int again = -1;
  for (int f = 0; f < 30 && again < 0; ++f) {
    w->step();
    if (w->node_asleep(20)) again = f;
  }
  CHECK(again >= 5);  // at rest for sleep.time (0.1 s, 6 frames) first: measured 6
}

TEST_CASE("sleeping ranges: the same bits with 1 and 2 threads, a host job system's, and through a checkpoint") {
  for (const std::string& file : {kRangePull, kRangeMiddle}) {
    CAPTURE(file);
    HostJobPool pool(2);
    auto one = range_world(file, {}, 1);
    auto two = range_world(file, {}, 2);
    auto jobs = range_world(file, {}, 2, &pool);
    test::step_both(*one, *two, 70);  // a range asleep (the middle one between its two sides)
    for (int f = 0; f < 70; ++f) jobs->step();
    REQUIRE(one->last_profile().nodes_asleep > 0);
    CHECK(one->last_profile().nodes_asleep == two->last_profile().nodes_asleep);
    CHECK(test::positions(*one) == test::positions(*two));
    CHECK(test::positions(*one) == test::positions(*jobs));
    const std::vector<std::byte> saved = one->save_checkpoint();
    for (int f = 0; f < 60; ++f) one->step();
    auto restored = range_world(file);
    restored->restore_checkpoint(saved);
    for (int f = 0; f < 60; ++f) restored->step();
    CHECK(restored->last_profile().nodes_asleep == one->last_profile().nodes_asleep);
    CHECK(test::positions(*restored) == test::positions(*one));
  }
}

namespace {

// range-pull in fast mode, stepped until its range has slept for 5 frames and a factorization made
// around it serves. (range-middle's middle does not come to rest under fast mode's one chord
// iteration a frame.)
std::unique_ptr<World> fast_range_pull() {
  auto w = range_pull({"solver.mode=fast"});
  int asleep_for = 0;
  for (int f = 0; f < 300 && asleep_for < 5; ++f) {
    w->step();
    asleep_for = w->last_profile().nodes_asleep > 0 ? asleep_for + 1 : 0;
  }
  REQUIRE(asleep_for == 5);
  REQUIRE(w->last_profile().chords > 0);
  REQUIRE(!w->node_asleep(w->node_count() - 1));  // a tip side, awake
  return w;
}

}  // namespace

TEST_CASE("sleeping ranges in fast mode: the same bits through a checkpoint, with a range asleep or just woken") {
  // The range a factorization was made around travels with it (decision 0127): a restored world
  // replays it, or refactors, as the uninterrupted one does. A host's change wakes the range
  // between frames: its factorization must not then serve the whole rod after a restore.
  for (const bool host_change : {false, true}) {
    CAPTURE(host_change);
    auto one = fast_range_pull();
    if (host_change) one->set_external_load(0, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());  // wakes all
    const std::vector<std::byte> saved = one->save_checkpoint();
    auto restored = range_pull({"solver.mode=fast"});
    restored->restore_checkpoint(saved);
    for (int f = 0; f < 40; ++f) one->step(), restored->step();
    CHECK(restored->last_profile().nodes_asleep == one->last_profile().nodes_asleep);
    CHECK(test::positions(*restored) == test::positions(*one));
  }
}

TEST_CASE("sleeping ranges in fast mode: a rebuild wakes the range and factors the whole rod afresh") {
  // A segment added carries each kept rod's factorization over (decision 0037) and wakes every
  // range: one made around a range holds no gains over it, so the next frame factors afresh.
  auto w = fast_range_pull();
  SegmentDesc extra = w->desc().segments[0];
  extra.name = "far";
  extra.anchors.clear();
  extra.base_position += Eigen::Vector3d(0.0, 1.0, 0.0);
  w->add_segment(extra);
  w->step();
  CHECK(w->last_profile().chords == 0);
  // Against a rod that had no range: its factorization serves on after the same rebuild.
  auto plain = range_pull({"solver.mode=fast", "sleep.ranges=false"});
  for (int f = 0; f < 80; ++f) plain->step();
  REQUIRE(plain->last_profile().chords > 0);
  plain->add_segment(extra);
  plain->step();
  CHECK(plain->last_profile().chords > 0);
}

namespace {

// The checkpoint with its rod's range (range_first, range_last: one 32-bit entry each after their
// 64-bit lengths) set to [first, last], its checksum (FNV-1a over the payload after the 76-byte
// header) made good again: a file a tool wrote wrong, not one damaged in transit.
std::vector<std::byte> with_range(std::vector<std::byte> bytes, std::uint32_t first, std::uint32_t last,
                                  std::uint32_t was_first, std::uint32_t was_last) {
  std::byte pattern[24];
  const std::uint64_t one = 1;
  std::memcpy(pattern, &one, 8), std::memcpy(pattern + 8, &was_first, 4);
  std::memcpy(pattern + 12, &one, 8), std::memcpy(pattern + 20, &was_last, 4);
  const auto at = std::search(bytes.begin(), bytes.end(), std::begin(pattern), std::end(pattern));
  REQUIRE(at != bytes.end());
  REQUIRE(std::search(at + 1, bytes.end(), std::begin(pattern), std::end(pattern)) == bytes.end());
  std::memcpy(&*at + 8, &first, 4), std::memcpy(&*at + 20, &last, 4);
  constexpr std::size_t kHeader = 76;
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (std::size_t i = kHeader; i + 8 < bytes.size(); ++i)
    h = (h ^ static_cast<std::uint64_t>(bytes[i])) * 0x100000001b3ull;
  std::memcpy(bytes.data() + bytes.size() - 8, &h, 8);
  return bytes;
}

}  // namespace

TEST_CASE("sleeping ranges: a checkpoint holding a range its rod cannot hold is refused, the world left as it was") {
  auto w = range_pull();
  for (int f = 0; f < 70; ++f) w->step();
  REQUIRE(w->node_asleep(0));  // range-pull's range: from the base
  const std::uint32_t first = 0;
  std::uint32_t last = 0;
  while (w->node_asleep(last + 1)) ++last;
  REQUIRE(first == 0);
  REQUIRE(last >= 15);
  const std::vector<std::byte> good = w->save_checkpoint();
  auto target = range_pull();
  target->restore_checkpoint(with_range(good, first, last, first, last));  // the tool's own bytes: accepted
  CHECK(test::positions(*target) == test::positions(*w));
  const auto n = static_cast<std::uint32_t>(w->node_count());
  for (const auto& [f, l] : std::vector<std::pair<std::uint32_t, std::uint32_t>>{
           {0, n}, {0, n - 1}, {40, 30}, {20, 30}, {5, 0}, {0xFFFFFFF0u, 0xFFFFFFFFu}}) {
    CAPTURE(f);
    CAPTURE(l);
    auto fresh = range_pull();
    const std::vector<double> before = test::positions(*fresh);
    try {
      fresh->restore_checkpoint(with_range(good, f, l, first, last), "bad.ckpt");
      FAIL("restored a range its rod cannot hold");
    } catch (const Error& e) {
      CHECK(e.code() == ErrorCode::parse);
      CHECK(std::string(e.what()).find("asleep") != std::string::npos);
    }
    CHECK(test::positions(*fresh) == before);
    fresh->step();  // and it steps on
  }
  // A world without ranges refuses one that holds a range.
  auto no_ranges = range_pull({"sleep.ranges=false"});
  try {
    no_ranges->restore_checkpoint(good);
    FAIL("a world without ranges restored one");
  } catch (const Error& e) {
    CHECK(std::string(e.what()).find("sleep.ranges is off") != std::string::npos);
  }
}

TEST_CASE("sleeping ranges: a host moves the probe onto a node of the sleeping range and grasps it: awake, it lifts") {
  auto w = range_pull();
  for (int f = 0; f < 100; ++f) w->step();
  const std::size_t node = 20;  // 0.2 m along the bowel, in the range asleep from its base
  REQUIRE(w->node_asleep(node));
  const Eigen::Vector3d at = w->node_positions().get(node);
  const Eigen::Vector3d up(0.0, 0.0, 1.0);
  w->set_instrument_pose(1, at + Eigen::Vector3d(0.0, 0.0, 0.024), up);  // the probe, just above its bead
  for (int f = 0; f < 3; ++f) w->step();
  w->set_instrument_grasp(1, true);
  for (int f = 0; f < 3; ++f) w->step();
  REQUIRE(w->instrument(1).grasping);
  CHECK(w->instrument(1).grasped_node >= node - 2);
  CHECK(w->instrument(1).grasped_node <= node + 2);
  CHECK(!w->node_asleep(node));
  for (int f = 1; f <= 30; ++f) {  // lifted 6 cm over half a second
    w->set_instrument_pose(1, at + Eigen::Vector3d(0.0, 0.0, 0.024 + 0.002 * f), up);
    w->step();
  }
  CHECK(!w->node_asleep(node));
  const double lifted = w->node_positions().get(node).z() - at.z();
  CHECK(lifted > 0.03);  // measured 4.8 cm: the grasped bead (node 21) follows the probe's 6 cm
  CHECK(lifted < 0.065);
}

}  // namespace haustra
