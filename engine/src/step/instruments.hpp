#pragma once
// Instruments: kinematic capsules that push tissue by contact and grasp it. At a frame's start
// their poses follow the script (unless the host has taken over), closing jaws grasp the nearest
// bead in reach through the segment's grasp attachment slot, opening releases it, and a grasp's
// target follows the instrument. At the frame's end, the force and torque the tissue exerts on
// each instrument are summed from its contacts and its grasp. A coupled grasp (decision 0057)
// pulls its node through a capped spring and damper, a load of the frame's solve (stage_loads, the
// Newton linearization and the line search's potential); pulled past its holding force, it slips.
#include <vector>

#include "haustra/kernels/virtual_coupling.hpp"
#include "model/world_model.hpp"
#include "state/world_state.hpp"

namespace haustra::detail {

// Whether an instrument's capsule is a proxy coupled to its commanded pose (decision 0096).
inline bool is_proxy(const InstrumentModel& d) { return d.proxy && d.coupling_stiffness > 0.0; }

void init_instruments(const WorldModel& model, WorldState& state);
void set_instrument_pose(InstrumentState& s, const Eigen::Vector3d& tip, const Eigen::Vector3d& axis);
// time: the end of the frame about to be stepped.
void stage_instruments(const WorldModel& model, WorldState& state, double time);
// From the contact forces and grasp forces the solve just used; then the low-pass filter. Coupled
// grasps pulled past their holding force let go: their instruments are appended to `slipped`.
void instrument_forces(const WorldModel& model, WorldState& state, double dt, std::vector<std::size_t>& slipped);

// The coupling of instrument s on its grasped node at x (x_start: at the substep's start, dt the
// substep's, frame_dt the frame's): spring to the grasp point and damper to its velocity, as one
// capped spring of stiffness k + b/dt towards their weighted target.
kernels::CouplingResponse grasp_coupling(const InstrumentModel& d, const InstrumentState& s, const Eigen::Vector3d& x,
                                         const Eigen::Vector3d& x_start, double dt, double frame_dt);

// Calls f(instrument, global node) for each coupled grasp on `segment`.
template <class F>
void for_each_coupled_grasp(const WorldState& state, std::size_t segment, F&& f) {
  for (std::size_t i = 0; i < state.instruments.size(); ++i) {
    const InstrumentState& s = state.instruments[i];
    if (s.grasping && s.coupled && s.grasp_segment == segment) f(i, static_cast<std::size_t>(s.grasp_node));
  }
}

}  // namespace haustra::detail
