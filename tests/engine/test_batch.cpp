// haustra::Batch (decision 0103): many worlds stepped in one call on a pool of threads, each the same
// bits as stepped alone; a world that fails stops alone. Named "thread" so TSan runs them too.
#include <doctest/doctest.h>

#include <memory>
#include <vector>

#include "haustra/batch.hpp"
#include "haustra/error.hpp"
#include "haustra/world.hpp"
#include "scene_fixtures.hpp"

using namespace haustra;

namespace {

// Worlds of `drop` (beads, the floor) and `grasp-pull` (an instrument on its script) that differ:
// each its own load on its last node.
std::vector<std::unique_ptr<World>> varied_worlds(std::size_t count) {
  std::vector<std::unique_ptr<World>> worlds;
  for (std::size_t i = 0; i < count; ++i) {
    worlds.push_back(test::scene_world(i % 2 == 0 ? "drop" : "grasp-pull", 1));
    worlds.back()->set_external_load(worlds.back()->node_count() - 1, {0.0, 0.05 * static_cast<double>(i), 0.0},
                                     Eigen::Vector3d::Zero());
  }
  return worlds;
}

}  // namespace

TEST_CASE("batch on 2 threads: every world the same bits as stepped alone (thread)") {
  auto alone = varied_worlds(5);
  auto batched = varied_worlds(5);
  for (auto& w : alone)
    for (int f = 0; f < 20; ++f) w->step();
  std::vector<World*> worlds;
  for (auto& w : batched) worlds.push_back(w.get());
  Batch batch(2);
  std::vector<Batch::Outcome> outcomes(worlds.size());
  std::vector<std::uint64_t> recorded(worlds.size(), 0);
  batch.step(worlds, 20, outcomes, [&](std::size_t i, std::uint64_t f) {
    CHECK(f == recorded[i]);  // each world's frames in order
    recorded[i] = f + 1;
  });
  for (std::size_t i = 0; i < worlds.size(); ++i) {
    CHECK(outcomes[i].frames == 20);
    CHECK_FALSE(outcomes[i].error);
    CHECK(test::positions(*alone[i]) == test::positions(*batched[i]));
    const auto a = alone[i]->strains().data, b = batched[i]->strains().data;
    CHECK(std::equal(a.begin(), a.end(), b.begin(), b.end()));
  }
}

TEST_CASE("batch (thread): a failing world stops alone, a world listed twice is refused, a stop stops") {
  auto owned = varied_worlds(3);
  owned[1]->set_external_load(owned[1]->node_count() - 1, {0.0, 0.0, -1e5},
                              Eigen::Vector3d::Zero());  // the most a load may be
  std::vector<World*> worlds{owned[0].get(), owned[1].get(), owned[2].get()};
  Batch batch(2);
  std::vector<Batch::Outcome> outcomes(3);
  batch.step(worlds, 15, outcomes);
  CHECK(outcomes[0].frames == 15);
  CHECK(outcomes[2].frames == 15);
  CHECK(outcomes[1].frames < 15);
  REQUIRE(outcomes[1].error);
  CHECK_THROWS_AS(std::rethrow_exception(outcomes[1].error), Error);
  std::vector<World*> twice{owned[0].get(), owned[0].get()};
  std::vector<Batch::Outcome> two(2);
  CHECK_THROWS_WITH_AS(batch.step(twice, 1, two), doctest::Contains("a world appears twice"), Error);
  int asked = 0;
  std::vector<World*> one{owned[2].get()};
  std::vector<Batch::Outcome> single(1);
  batch.step(one, 100, single, {}, [&] { return ++asked <= 4; });
  CHECK(single[0].frames == 4);
  CHECK(owned[2]->frame() == 19);
}
