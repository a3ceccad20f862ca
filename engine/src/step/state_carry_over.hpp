#pragma once
// Segments added or removed between frames: the model is rebuilt and each kept rod's state moves
// to its place in the new world, so it steps on exactly as if nothing had changed around it.
#include <span>
#include <vector>

#include "model/world_model.hpp"
#include "state/world_state.hpp"

namespace haustra::detail {

inline constexpr std::size_t kRodRemoved = static_cast<std::size_t>(-1);

// Where the parts of a world go in its rebuilt model (kRodRemoved: gone): its rods; its instruments;
// per old rod, the attachments its description lists (by their index there; a rod's grasp slots
// follow their instruments) and its ranges of anchors (by their index in its description). An
// empty map (or an empty entry) is the identity.
struct CarryMap {
  std::vector<std::size_t> rods;
  std::vector<std::size_t> instruments;
  std::vector<std::vector<std::size_t>> attachments;
  std::vector<std::vector<std::size_t>> anchor_ranges;
};

// The identity over a model's rods (and everything else).
CarryMap same_rods(const WorldModel& model);

// `to` is a freshly initialised state of `to_model`. For every old rod r with map.rods[r] !=
// kRodRemoved, copies what a later frame reads (strains, poses, base, attachments, external
// loads, bead motion, which anchors hold) into its new rod; also the clock, the robust mode's rung
// and the kept instruments (a grasp on a removed rod, or on a rod whose beads changed, is let go).
// Parts not mapped to keep their initial state. carry_solver: fast mode's chord state too.
void carry_over_state(const WorldModel& from_model, const WorldState& from, const WorldModel& to_model, WorldState& to,
                      const CarryMap& map, bool carry_solver);

// `to` is a freshly initialised state of `to_model`. For every old rod r with rod_map[r] !=
// kRodRemoved, copies what a later frame reads (strains, poses, base, attachments, external
// loads, bead motion) into new rod rod_map[r]; also the clock, the robust mode's rung and the
// instruments (a grasp on a removed rod is let go). Rods not mapped to keep their initial state.
// carry_solver: fast mode's chord state too (the rods' models are the same: segments added or
// removed beside them, not a reconfiguration).
void carry_over_state(const WorldModel& from_model, const WorldState& from, const WorldModel& to_model, WorldState& to,
                      std::span<const std::size_t> rod_map, bool carry_solver);

}  // namespace haustra::detail
