// The world's buffers as hosts see them: three-component buffers are one block (x, y, z), copies
// own their block, and buffers_keeper() keeps every view's memory past the world and a rebuild.
#include <doctest/doctest.h>

#include <vector>

#include "haustra/scene.hpp"
#include "haustra/world.hpp"
#include "state/world_state.hpp"

using namespace haustra;

TEST_CASE("a three-component buffer is one block, and a copy is its own") {
  detail::Vec3Buffer a;
  a.resize(5);
  CHECK(a.y.data() == a.x.data() + 5);
  CHECK(a.z.data() == a.y.data() + 5);
  a.view().set(2, {1.0, 2.0, 3.0});
  detail::Vec3Buffer b = a;  // copy: spans on b's own block
  CHECK(b.x.data() != a.x.data());
  CHECK(b.y.data() == b.x.data() + 5);
  CHECK(b.view().get(2) == Eigen::Vector3d(1.0, 2.0, 3.0));
  b.view().set(2, {4.0, 5.0, 6.0});
  CHECK(a.view().get(2) == Eigen::Vector3d(1.0, 2.0, 3.0));
  const double* before = a.x.data();
  a = b;  // same size: copied in place
  CHECK(a.x.data() == before);
  CHECK(a.view().get(2) == Eigen::Vector3d(4.0, 5.0, 6.0));
  detail::Vec3Buffer c = std::move(b);
  CHECK(c.z.data() == c.x.data() + 10);
  CHECK(b.x.empty());
}

TEST_CASE("buffers_keeper keeps views valid past the world and past a rebuild") {
  const SceneDesc scene = load_scene(HAUSTRA_SOURCE_DIR "/scenes/two-segments.toml");
  auto world = create_world(scene);
  world->step();
  std::shared_ptr<const void> keeper = world->buffers_keeper();
  const auto view = world->node_positions();
  const auto beads = world->bead_centres();
  CHECK(view.y.data() == view.x.data() + view.size());
  const std::vector<double> z(view.z.begin(), view.z.end());
  for (std::size_t b = 0; b < beads.size(); ++b)
    CHECK(beads.get(b) == view.get(world->bead_nodes()[b]));  // bead centres are their nodes after the step

  world->remove_segment(1);  // the world moves to new buffers; the keeper holds the old ones
  CHECK(world->node_positions().x.data() != view.x.data());
  world->step();
  CHECK(std::equal(z.begin(), z.end(), view.z.begin()));  // read under ASan: still allocated

  std::shared_ptr<const void> second = world->buffers_keeper();
  const auto now = world->node_positions();
  const double last = now.z[now.size() - 1];
  world.reset();  // the world is gone; its last buffers stay with `second`
  CHECK(now.z[now.size() - 1] == last);
}
