// Rods at rest and untouched sleep, and wake on contact, a grasp, a tear or a host's change
// (decision 0119). A sleeping rod keeps its state as it is: its nodes are a fixed body for the others.
#include "step/sleep.hpp"

#include <algorithm>

namespace haustra::detail {

void wake_rod(const WorldModel& model, WorldState& state, std::size_t rod) {
  state.rod_asleep[rod] = 0;
  state.rod_calm[rod] = 0.0;
  state.segment_converged[rod] = 0;
  state.range_first[rod] = state.range_last[rod] = 0;
  const SegmentModel& seg = model.segments[rod];
  std::fill_n(state.node_calm.begin() + static_cast<std::ptrdiff_t>(seg.node_offset), seg.node_count, 0.0);
}

void wake_all(WorldState& state) {
  for (std::size_t rod = 0; rod < state.rod_asleep.size(); ++rod) {
    state.rod_asleep[rod] = 0;
    state.rod_calm[rod] = 0.0;
    state.segment_converged[rod] = 0;
    state.range_first[rod] = state.range_last[rod] = 0;
  }
  std::fill(state.node_calm.begin(), state.node_calm.end(), 0.0);
}

// Decision 0127: the range [first, last] the rod's nodes may sleep over, within the calm run
// [from, to) (nodes calm for sleep.time): kRangeBand nodes short of each end where something moves
// beyond it, at least kMinSleepingRange nodes long, never the whole rod. Empty: {0, 0}.
HeldRange sleepable(std::size_t from, std::size_t to, std::size_t nodes) {
  const std::size_t first = from == 0 ? 0 : from + kRangeBand;
  const std::size_t end = to == nodes ? nodes : (to > kRangeBand ? to - kRangeBand : 0);
  if (end < first + kMinSleepingRange || (first == 0 && end == nodes)) return {};
  return {first, end - 1};
}

void set_range(const WorldModel& model, WorldState& state, std::size_t rod, HeldRange r) {
  const HeldRange was = state.held_range(rod);
  state.range_first[rod] = static_cast<std::uint32_t>(r.first);
  state.range_last[rod] = static_cast<std::uint32_t>(r.last);
  // The base side's end starts where the range's first node stands (its own strains put it there).
  if (r.base_side() && (r.first != was.first || !was.any())) {
    const std::size_t g = model.segments[rod].node_offset + r.first;
    state.now.range_end[rod] = {state.now.rotation.view().get(g), state.now.position.view().get(g)};
  }
}

void wake_nodes(const WorldModel& model, WorldState& state, std::size_t rod, std::size_t node) {
  const SegmentModel& seg = model.segments[rod];
  const std::size_t local = node - seg.node_offset;
  const std::size_t from = local > kRangeBand ? local - kRangeBand : 0;
  const std::size_t to = std::min(seg.node_count, local + kRangeBand + 1);
  std::fill(state.node_calm.begin() + static_cast<std::ptrdiff_t>(seg.node_offset + from),
            state.node_calm.begin() + static_cast<std::ptrdiff_t>(seg.node_offset + to), 0.0);
  const HeldRange r = state.held_range(rod);
  if (!r.any() || to + kRangeBand <= r.first || from > r.last + kRangeBand) return;
  // The range keeps the longer of its two sides beyond the woken nodes, if it is long enough.
  const std::size_t n = seg.node_count;
  const std::size_t run_from = r.first == 0 ? 0 : r.first - kRangeBand;  // the calm run the range was cut from
  const std::size_t run_to = r.last + 1 == n ? n : r.last + 1 + kRangeBand;
  const HeldRange before = sleepable(run_from, std::min(from, run_to), n);
  const HeldRange after = sleepable(std::max(to, run_from), run_to, n);
  const std::size_t before_nodes = before.any() ? before.last - before.first + 1 : 0;
  const std::size_t after_nodes = after.any() ? after.last - after.first + 1 : 0;
  set_range(model, state, rod, before_nodes >= after_nodes ? before : after);
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

namespace {

// Whether the bead lies in its rod's sleeping range or the calm band beside it (decision 0127).
bool in_sleeping_range(const WorldModel& model, const WorldState& state, std::size_t rod, std::size_t node) {
  const HeldRange r = state.held_range(rod);
  const std::size_t local = node - model.segments[rod].node_offset;
  return r.any() && local + kRangeBand >= r.first && local <= r.last + kRangeBand;
}

bool any_range_asleep(const WorldState& state) {
  return std::any_of(state.range_last.begin(), state.range_last.end(), [](std::uint32_t a) { return a != 0; });
}

}  // namespace

void wake_touched(const WorldModel& model, WorldState& state, double substep) {
  if (!model.sleep.enabled || (!any_asleep(state) && !any_range_asleep(state))) return;
  // A bead asleep (its rod, or its rod's range) is woken by an instrument or a moving bead near it.
  auto touch = [&](std::uint32_t bead, bool by_mover) {
    const std::size_t rod = model.beads.segment[bead];
    if (!by_mover) return;
    if (state.rod_asleep[rod] != 0)
      wake_rod(model, state, rod);
    else if (in_sleeping_range(model, state, rod, model.beads.node[bead]))
      wake_nodes(model, state, rod, model.beads.node[bead]);
  };
  for (const ContactCandidate& c : state.collision.candidates) {
    if (c.kind == ContactKind::instrument) {
      touch(c.bead, true);
    } else if (c.kind == ContactKind::bead) {
      touch(c.bead, moving(model, state, c.other, substep));
      touch(c.other, moving(model, state, c.bead, substep));
    }
  }
  for (const InstrumentState& in : state.instruments) {
    if (!in.grasping) continue;
    const std::size_t rod = in.grasp_segment;
    if (state.rod_asleep[rod] != 0)
      wake_rod(model, state, rod);
    else if (in_sleeping_range(model, state, rod, in.grasp_node))
      wake_nodes(model, state, rod, in.grasp_node);
  }
}

void wake_torn(const WorldModel& model, WorldState& state, std::span<const TornAnchor> torn) {
  if (!model.sleep.enabled) return;
  for (const TornAnchor& t : torn) {
    const std::uint32_t node = model.anchors.node[t.anchor];
    for (std::size_t rod = 0; rod < model.segments.size(); ++rod) {
      const SegmentModel& seg = model.segments[rod];
      if (node < seg.node_offset || node >= seg.node_offset + seg.node_count) continue;
      if (state.rod_asleep[rod] != 0)
        wake_rod(model, state, rod);
      else
        wake_nodes(model, state, rod, node);  // its range, if the anchor was in or beside it
    }
  }
}

namespace {

// Decision 0127: each node's calm spell; the rod's longest run of nodes calm for sleep.time (a
// grasped node is never calm) sleeps, short of its moving neighbours by kRangeBand nodes. The range
// follows the calm as it spreads and as motion comes near.
void settle_range(const WorldModel& model, WorldState& state, std::size_t rod, double still, double dt) {
  const SegmentModel& seg = model.segments[rod];
  const auto now = state.now.position.view();
  const auto start = state.frame_start.position.view();
  for (std::size_t k = seg.node_offset; k < seg.node_offset + seg.node_count; ++k)
    state.node_calm[k] = (now.get(k) - start.get(k)).squaredNorm() <= still * still ? state.node_calm[k] + dt : 0.0;
  for (const InstrumentState& in : state.instruments)
    if (in.grasping && in.grasp_segment == rod) state.node_calm[in.grasp_node] = 0.0;
  std::size_t best_from = 0, best_to = 0;
  for (std::size_t k = 0; k < seg.node_count;) {
    if (state.node_calm[seg.node_offset + k] < model.sleep.time) {
      ++k;
      continue;
    }
    const std::size_t from = k;
    while (k < seg.node_count && state.node_calm[seg.node_offset + k] >= model.sleep.time) ++k;
    if (k - from > best_to - best_from) best_from = from, best_to = k;
  }
  const HeldRange best = best_to > best_from ? sleepable(best_from, best_to, seg.node_count) : HeldRange{};
  // The range in force stays while it and its bands are calm, unless the calm has spread a band's
  // length beyond it: each change refactors fast mode's tip side (decision 0037), so the range
  // moves in steps, not node by node.
  const HeldRange held = state.held_range(rod);
  if (held.any()) {
    const std::size_t from = held.first == 0 ? 0 : held.first - kRangeBand;
    const std::size_t to = std::min(seg.node_count, held.last + 1 + kRangeBand);
    bool calm = true;
    for (std::size_t k = from; k < to && calm; ++k) calm = state.node_calm[seg.node_offset + k] >= model.sleep.time;
    const bool grows = best.any() && best.first <= held.first && best.last >= held.last &&
                       (held.first - best.first >= kRangeBand || best.last - held.last >= kRangeBand);
    if (calm && !grows) return;
  }
  set_range(model, state, rod, best);
}

}  // namespace

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
    if (model.sleep.ranges && seg.split_node == 0) settle_range(model, state, rod, still, dt);
  }
}

int nodes_asleep(const WorldModel& model, const WorldState& state) {
  std::size_t n = 0;
  for (std::size_t rod = 0; rod < model.segments.size(); ++rod)
    n += state.rod_asleep[rod] != 0    ? model.segments[rod].node_count
         : state.held_range(rod).any() ? state.range_last[rod] - state.range_first[rod] + 1
                                       : 0;
  return static_cast<int>(n);
}

}  // namespace haustra::detail
