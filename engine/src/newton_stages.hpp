#pragma once
// The Newton stages of a frame, one segment at a time (newton_stages.cpp): each reads the constant
// model and writes only its own segment's slice of the state, so segments run in parallel.
#include "rod_stages.hpp"

namespace haustra::detail {

// Linearizes the implicit law at the current iterate and condenses the system from the tip to the
// base (kernels/rod_condensed), falling back to the banded LU where the sweep's pivots are unsafe.
// Returns false when neither can solve this iteration (a singular pivot on a rod too long for the
// banded fallback).
bool stage_newton_jacobian(const WorldModel& model, WorldState& state, std::size_t segment, const SubstepParameters& p);
// The coupled unknowns (attachment rows, coupled contact pairs) and the Newton step at every node.
void stage_newton_solve(const WorldModel& model, WorldState& state, std::size_t segment, const SubstepParameters& p);
// Takes the step: the trust region's fraction of it, halved until the frame's incremental
// potential (the attachments' exact-penalty merit included) decreases enough and no contact
// deepens too far. Leaves the poses of the strains taken, the strain change in segment_change,
// and the attachment forces updated.
void stage_newton_line_search(const WorldModel& model, WorldState& state, std::size_t segment,
                              const SubstepParameters& p);

}  // namespace haustra::detail
