#pragma once
// Rods at rest and untouched sleep (decision 0119): when they fall asleep, what wakes them.
#include <cstddef>
#include <span>

#include "model/world_model.hpp"
#include "state/world_state.hpp"
#include "step/anchors.hpp"

namespace haustra::detail {

// The rod is solved again from this substep on, its calm spell restarted (its nodes' too).
void wake_rod(const WorldModel& model, WorldState& state, std::size_t rod);
void wake_all(WorldState& state);

// A sleeping range (decision 0127): the nodes within kRangeBand of `node` (global) restart their
// calm spells, and the rod's range, if it reaches them, keeps its longer side beyond them.
void wake_nodes(const WorldModel& model, WorldState& state, std::size_t rod, std::size_t node);
// The range a run of calm nodes [from, to) may sleep over (empty: none; decision 0127).
[[nodiscard]] HeldRange sleepable(std::size_t from, std::size_t to, std::size_t nodes);
// The rod's sleeping range from now on (its base side's end where the range's first node stands).
void set_range(const WorldModel& model, WorldState& state, std::size_t rod, HeldRange range);

// After the substep's collision candidates are found: a sleeping rod wakes when a bead that moved
// faster than sleep.speed in the last substep (of `substep` seconds), or an instrument, comes
// within the contact margin of one of its beads, or an instrument holds one of its nodes. Reads the
// candidates in their (thread-independent) order.
void wake_touched(const WorldModel& model, WorldState& state, double substep);

// Rods whose anchors tore or were cut this frame.
void wake_torn(const WorldModel& model, WorldState& state, std::span<const TornAnchor> torn);

// At the end of an accepted frame of `dt` seconds: each awake rod's calm spell grows while no node
// moved more than sleep.speed × dt since the frame's start (and nothing holds it), else restarts;
// past sleep.time it sleeps. With sleep.ranges, each node's spell too, and the rod's calm base-side
// range sleeps (decision 0127).
void settle_rods(const WorldModel& model, WorldState& state, double dt);

// Nodes of the sleeping rods and ranges (the profile's count).
[[nodiscard]] int nodes_asleep(const WorldModel& model, const WorldState& state);

}  // namespace haustra::detail
