#pragma once
// Segments added or removed between frames: the model is rebuilt and each kept rod's state moves
// to its place in the new world, so it steps on exactly as if nothing had changed around it.
#include <span>

#include "model/world_model.hpp"
#include "step/world_state.hpp"

namespace haustra::detail {

inline constexpr std::size_t kRodRemoved = static_cast<std::size_t>(-1);

// `to` is a freshly initialised state of `to_model`. For every old rod r with rod_map[r] !=
// kRodRemoved, copies what a later frame reads (strains, poses, base, attachments, external
// loads, bead motion) into new rod rod_map[r]; also the clock, the robust mode's rung and the
// instruments (a grasp on a removed rod is let go). Rods not mapped to keep their initial state.
// carry_solver: fast mode's chord state too (the rods' models are the same: segments added or
// removed beside them, not a reconfiguration).
void carry_over_state(const WorldModel& from_model, const WorldState& from, const WorldModel& to_model, WorldState& to,
                      std::span<const std::size_t> rod_map, bool carry_solver);

}  // namespace haustra::detail
