#pragma once
// The Newton stages of a frame (newton_stages.cpp, line_search.cpp): three world-wide stages that
// dispatch their steps over the scheduler; each step reads the constant model and writes only its
// own rod's or solve part's slice of the state, so they run in parallel.
#include "step/rod_stages.hpp"

namespace haustra::detail {

class Scheduler;

// The three Newton stages over the whole world, as the frame runs them in each iteration: each spreads
// its per-rod and per-part steps (below) over the scheduler, for the rods still iterating.
void stage_condense(const WorldModel& model, WorldState& state, Scheduler& scheduler, const SubstepParameters& p);
void stage_newton_solve(const WorldModel& model, WorldState& state, Scheduler& scheduler, const SubstepParameters& p);
void stage_line_search(const WorldModel& model, WorldState& state, Scheduler& scheduler, const SubstepParameters& p);
// Rods that neither the condensed sweep nor the banded LU could solve end their iterations here:
// the guard reports them.
void end_unsolvable(const WorldModel& model, WorldState& state);
// Before the filter moves a rod's positions: its poses kept where a line search left them as the
// sweep of its strains, for the next line search's start to take instead of sweeping them again.
void keep_swept_poses(const WorldModel& model, WorldState& state, std::size_t rod);

// The condense stage. Per rod: the implicit law linearized at the current iterate, the coupled
// unknowns' unit loads (and a split rod's parts' share of them). Per solve part: the system
// condensed from the tip (kernels/rod_condensed). Per rod: a split rod's parts joined, or the
// banded LU where a sweep's pivots were unsafe; false when neither can solve this iteration (a
// singular pivot on a rod too long for the banded fallback).
void stage_newton_linearize(const WorldModel& model, WorldState& state, std::size_t rod, const SubstepParameters& p);
// The condense stage's tasks for this iteration (rods being solved: `solving`): one per solve
// part, but whole rods with the residual column alone go four at a time, of one node count, in
// SIMD lanes (kernels/rod_condense_lanes: the same bits as one by one). Then per part, in
// newton_stages.cpp, condense_part (kernels/rod_condensed: the condensed sweep), and per rod the
// join. The solve stage, per half of a rod's columns: the responses at the coupled unknowns'
// nodes; per rod: the coupled unknowns (attachment rows, coupled contact pairs); per part: the
// Newton step at its nodes.
void plan_newton_condense(const WorldModel& model, WorldState& state, std::span<const std::uint8_t> solving);
// The line search stage (line_search.cpp): Newton's step taken as the fraction of it that lowers
// the frame's incremental potential (the attachments' exact-penalty merit included) enough and
// deepens no contact too far. Per rod, begin: the step's slope (the law stiffened and the system
// solved again while the step is not a descent direction) and the first trial. Then, while any
// rod's search is active, per part: the trial's poses (a split rod's tip part relative to the
// joint), per part: composed and weighed, per rod: accepted, halved or stiffened. A finished search
// leaves the poses of the strains taken, the strain change in segment_change and the attachment
// forces updated.
void stage_newton_search_begin(const WorldModel& model, WorldState& state, std::size_t rod, const SubstepParameters& p);
void stage_newton_search_sweep(const WorldModel& model, WorldState& state, const SolvePart& part);
void stage_newton_search_measure(const WorldModel& model, WorldState& state, const SolvePart& part,
                                 const SubstepParameters& p);
void stage_newton_search_decide(const WorldModel& model, WorldState& state, std::size_t rod,
                                const SubstepParameters& p);

}  // namespace haustra::detail
