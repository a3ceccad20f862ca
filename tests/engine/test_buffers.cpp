// The world's buffers as hosts see them: three-component buffers are one block (x, y, z), copies
// own their block, and buffers_keeper() keeps every view's memory past the world and a rebuild; the
// state's lists (decision 0116) size each buffer as the model asks.
#include <doctest/doctest.h>

#include <algorithm>
#include <vector>

#include "haustra/scene.hpp"
#include "haustra/world.hpp"
#include "model/world_model.hpp"
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

namespace {

template <class T>
std::size_t entries(const std::vector<T>& v) {
  return v.size();
}
std::size_t entries(const detail::Vec3Buffer& b) {
  return b.y.size() == b.x.size() && b.z.size() == b.x.size() ? b.x.size() : 0;
}
std::size_t entries(const detail::RotationBuffer& b) {
  return b.x.size() == b.w.size() && b.y.size() == b.w.size() && b.z.size() == b.w.size() ? b.w.size() : 0;
}

}  // namespace

TEST_CASE(
    "the state's lists (decision 0116): each buffer as long as the model asks and from its initial value and bytes per "
    "node as 0038 counted") {
  // A free base, beads, an instrument's grasp slots and an anchor on every node: every rule of the lists.
  SceneDesc scene = load_scene(HAUSTRA_SOURCE_DIR "/scenes/grasp-pull.toml");
  scene.world.segments[0].anchors.push_back(AnchorsDesc{});
  const detail::WorldModel model = detail::build_world_model(scene.world);
  detail::WorldState state;
  detail::init_world_state(model, state);
  const std::size_t n = model.node_total, rods = model.segments.size();
  REQUIRE(model.anchors.size() == n);
  REQUIRE(model.attachment_total > 0);
  // The counts read from the model directly, not through the lists' rule.
  for (const detail::PersistentState* p : {&state.now, &state.frame_start}) {
    CHECK(entries(p->strain) == 4 * n);
    CHECK(entries(p->position) == n);
    CHECK(entries(p->rotation) == n);
    CHECK(entries(p->mid_position) == n);
    CHECK(entries(p->mid_rotation) == n);
    CHECK(entries(p->base) == rods);
    CHECK(entries(p->attachment) == model.attachment_total);
    CHECK(entries(p->anchor_intact) == model.anchors.size());
    CHECK(std::count(p->anchor_intact.begin(), p->anchor_intact.end(), 1) == static_cast<std::ptrdiff_t>(n));
  }
  CHECK(entries(state.strain_substep_start) == 4 * n);
  CHECK(entries(state.external_force) == n);
  CHECK(entries(state.filter_exempt) == n);
  CHECK(entries(state.strain_before_update) == 4 * n);
  CHECK(entries(state.constraint_scratch) == model.constraint_scratch_total);
  CHECK(entries(state.base_resistance) == rods);
  CHECK(state.base_resistance[0] == kernels::Matrix6d::Identity());
  CHECK(state.segment_solvable == std::vector<std::uint8_t>(rods, 1));
  CHECK(state.rotation_substep_start.w[0] == 1.0);  // identities
  const detail::NewtonWorkspace& ws = state.newton.at(0);
  CHECK(entries(ws.step_q) == 4 * model.segments[0].node_count);
  CHECK(entries(ws.force_stiffness) == model.segments[0].node_count);
  CHECK(entries(ws.lower) == model.segments[0].node_count);  // 101 nodes keep the banded fallback
  // The memory estimate's bytes per node, now from the lists, are the literals decision 0038 wrote:
  // 18 doubles a persistent state, 32 doubles (31 before a node's calm spell, decision 0127) and a byte
  // besides; Newton's 41 doubles (59 since its line search keeps its last sweep, decision 0128), and
  // the banded fallback's four 16×16 blocks, 16 bytes of swaps and 10 doubles.
  CHECK(detail::kPersistentBytesPerNode == 18 * sizeof(double));
  CHECK(detail::kFrameBytesPerNode == 32 * sizeof(double) + 1);
  CHECK(detail::kStateBytesPerNode == (2 * 18 + 32) * sizeof(double) + 1);
  CHECK(detail::kNewtonBytesPerNode == (41 + 18) * sizeof(double));
  CHECK(detail::kBandBytesPerNode == 4 * 256 * sizeof(double) + 16 + 10 * sizeof(double));
}
