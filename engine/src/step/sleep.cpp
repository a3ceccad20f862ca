// Rods at rest and untouched sleep, and wake on contact, a grasp, a tear or a host's change
// (decision 0119). A sleeping rod keeps its state as it is: its nodes are a fixed body for the others.
#include "step/sleep.hpp"

#include <algorithm>

namespace haustra::detail {

void wake_rod(WorldState& state, std::size_t rod) {
  state.rod_asleep[rod] = 0;
  state.rod_calm[rod] = 0.0;
  state.segment_converged[rod] = 0;
}

void wake_all(WorldState& state) {
  for (std::size_t rod = 0; rod < state.rod_asleep.size(); ++rod) wake_rod(state, rod);
}

namespace {

bool any_asleep(const WorldState& state) {
  return std::any_of(state.rod_asleep.begin(), state.rod_asleep.end(), [](std::uint8_t a) { return a != 0; });
}

// A bead of an awake rod that moved faster than sleep.speed in the last substep wakes a sleeping rod
// whose bead it is near; a bead at rest does not, so two resting rods in contact fall asleep one
// after the other, and a rod pulled far away does not wake its neighbour where they touch.
bool moving(const WorldModel& model, const WorldState& state, std::uint32_t bead, double substep) {
  return state.rod_asleep[model.beads.segment[bead]] == 0 &&
         state.collision.bead_motion[bead] > model.sleep.speed * substep;
}

}  // namespace

void wake_touched(const WorldModel& model, WorldState& state, double substep) {
  if (!model.sleep.enabled || !any_asleep(state)) return;
  for (const ContactCandidate& c : state.collision.candidates) {
    const std::size_t rod = model.beads.segment[c.bead];
    if (c.kind == ContactKind::instrument) {
      if (state.rod_asleep[rod] != 0) wake_rod(state, rod);
    } else if (c.kind == ContactKind::bead) {
      const std::size_t other = model.beads.segment[c.other];
      if (state.rod_asleep[rod] != 0 && moving(model, state, c.other, substep)) wake_rod(state, rod);
      if (state.rod_asleep[other] != 0 && moving(model, state, c.bead, substep)) wake_rod(state, other);
    }
  }
  for (const InstrumentState& in : state.instruments)
    if (in.grasping && state.rod_asleep[in.grasp_segment] != 0) wake_rod(state, in.grasp_segment);
}

void wake_torn(const WorldModel& model, WorldState& state, std::span<const TornAnchor> torn) {
  if (!model.sleep.enabled) return;
  for (const TornAnchor& t : torn) {
    const std::uint32_t node = model.anchors.node[t.anchor];
    for (std::size_t rod = 0; rod < model.segments.size(); ++rod) {
      const SegmentModel& seg = model.segments[rod];
      if (node >= seg.node_offset && node < seg.node_offset + seg.node_count) wake_rod(state, rod);
    }
  }
}

void settle_rods(const WorldModel& model, WorldState& state, double dt) {
  if (!model.sleep.enabled) return;
  const double still = model.sleep.speed * dt;
  const auto now = state.now.position.view();
  const auto start = state.frame_start.position.view();
  for (std::size_t rod = 0; rod < model.segments.size(); ++rod) {
    if (state.rod_asleep[rod] != 0) continue;
    const SegmentModel& seg = model.segments[rod];
    double moved = 0.0;
    for (std::size_t k = seg.node_offset; k < seg.node_offset + seg.node_count; ++k)
      moved = std::max(moved, (now.get(k) - start.get(k)).squaredNorm());
    bool held = false;  // a grasp pulls: never asleep while an instrument holds it
    for (const InstrumentState& in : state.instruments) held = held || (in.grasping && in.grasp_segment == rod);
    state.rod_calm[rod] = moved <= still * still && !held ? state.rod_calm[rod] + dt : 0.0;
    if (state.rod_calm[rod] >= model.sleep.time) state.rod_asleep[rod] = 1;
  }
}

int nodes_asleep(const WorldModel& model, const WorldState& state) {
  std::size_t n = 0;
  for (std::size_t rod = 0; rod < model.segments.size(); ++rod)
    if (state.rod_asleep[rod] != 0) n += model.segments[rod].node_count;
  return static_cast<int>(n);
}

}  // namespace haustra::detail
