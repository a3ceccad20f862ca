#pragma once
// The collision stages: world-wide, over the beads of all segments.
//   stage_collide   — at each substep's start: beads take their nodes' positions; the broad phase
//                     and the narrow phase list every contact candidate, in an order that does not
//                     depend on the thread count. A bead's reach is the margin plus 1.5 times how
//                     far it moved in the last substep (a speculative margin), so a fast bead is
//                     listed before it arrives rather than found deep inside something later.
//   stage_contacts  — at every iteration: the penalty force (and its stiffness) of each candidate
//                     at the current positions, gathered per bead. Up to kMaxCoupledContacts
//                     touching contacts between two beads of one segment are marked `coupled`:
//                     Newton solves them as pairs (they hang on the same rod; node by node they
//                     would not converge in a fold). The others enter its Jacobian node by node.
//   stage_contact_report — at a frame's end: depths at the final positions.
#include "model/world_model.hpp"
#include "sched/scheduler.hpp"
#include "state/world_state.hpp"

namespace haustra::detail {

void init_collision_state(const WorldModel& model, WorldState& state);
void stage_collide(const WorldModel& model, WorldState& state, Scheduler& scheduler);
void stage_contacts(const WorldModel& model, WorldState& state, Scheduler& scheduler);
void stage_contact_report(const WorldModel& model, WorldState& state);
// After a substep: how far each bead moved, for the next substep's speculative margin.
void record_bead_motion(const WorldModel& model, WorldState& state);

// The penalty potential (J) of one segment's contacts at its current node positions — what the
// Newton line search weighs: f = c E d^e is −∂/∂r of c E d^(e+1)/(e+1). Pairs within the segment
// and the environment are measured exactly; a pair with another segment's bead, whose own solve
// moves it at the same time, against where that bead was at the iteration's start (the depth and
// direction the contacts stage measured), moved by this bead's motion since `bead_start` (the
// segment's bead positions at the iteration's start, local index).
// Beads at local nodes [first, end) only: `across` false, their contacts but those with a bead of
// the segment outside the range; true, just those (each counted once, from inside the range).
double segment_contact_potential(const WorldModel& model, const WorldState& state, std::size_t segment,
                                 std::span<const Eigen::Vector3d> bead_start, std::size_t first, std::size_t end,
                                 bool across);

// Containers (decision 0093). A contact with one; its depth with the bead where it was at the
// frame's start (against the contact's plane: > the radius, the bead's centre was already out);
// and what one segment's container contacts released in the frame (J: the penalty potential at the
// frame's start less that now, where positive), which the rod may have gained as it was pushed back.
[[nodiscard]] bool held_by_container(const WorldModel& model, const ContactCandidate& c);
[[nodiscard]] double depth_at_frame_start(const WorldModel& model, const WorldState& state, const ContactCandidate& c);
[[nodiscard]] double container_release(const WorldModel& model, const WorldState& state, std::size_t segment);

// Beads a contact candidate list can ignore: an instrument's own grasped bead.
[[nodiscard]] bool instrument_holds(const WorldState& state, std::size_t instrument, std::uint32_t bead);

}  // namespace haustra::detail
