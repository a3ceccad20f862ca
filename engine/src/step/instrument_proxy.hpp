#pragma once
// Instruments as proxies (decision 0096, haptic rendering's god-object): an instrument's capsule is
// not where the host commands it but where a capped spring–damper from the commanded tip balances
// what the capsule meets — the beads, and at its tip the floor, walls, obstacles — so a command
// that goes through the organ or the floor gives a bounded force and a capsule that stays outside.
// The grasp keeps its own coupling to the commanded pose, with what the capsule's push leaves of the
// force limit, so the two together never exceed it. Solved with the beads where they are at each
// iteration of the frame (block Gauss–Seidel with the rod's solve), and once more at its end for
// the force reported.
#include <cstddef>

#include "model/world_model.hpp"
#include "state/world_state.hpp"

namespace haustra::detail {

// Every proxy instrument's tip for the beads where they are now (dt: the substep's, frame_dt the
// frame's), and what its push leaves its grasp. Returns the farthest a tip moved (m), for the
// frame's convergence.
double stage_instrument_proxies(const WorldModel& model, WorldState& state, double dt, double frame_dt);

// What the instrument's grasp may pull with: its force limit, less what its proxy's capsule pushes with.
double grasp_limit(const InstrumentModel& d, const InstrumentState& s);

// At a substep's start: where the proxies' dampers measure from.
void snapshot_instrument_proxies(WorldState& state);

}  // namespace haustra::detail
