#pragma once
// Instruments: kinematic capsules that push tissue by contact and grasp it. At a frame's start
// their poses follow the script (unless the host has taken over), closing jaws grasp the nearest
// bead in reach through the segment's grasp attachment slot, opening releases it, and a grasp's
// target follows the instrument. At the frame's end, the force and torque the tissue exerts on
// each instrument are summed from its contacts and its grasp.
#include "model/world_model.hpp"
#include "step/world_state.hpp"

namespace haustra::detail {

void init_instruments(const WorldModel& model, WorldState& state);
void set_instrument_pose(InstrumentState& s, const Eigen::Vector3d& tip, const Eigen::Vector3d& axis);
// time: the end of the frame about to be stepped.
void stage_instruments(const WorldModel& model, WorldState& state, double time);
// From the contact forces and grasp forces the solve just used; then the low-pass filter.
void instrument_forces(const WorldModel& model, WorldState& state, double dt);

}  // namespace haustra::detail
