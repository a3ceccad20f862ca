// Fast mode's prefactor (decision 0085): the factorization a chord frame will need when its record
// comes of age, made two frames early on another thread, from a copy of that frame's
// linearization, and swapped in when its frame comes. The plan depends on the state alone, so the same frames launch
// and swap on 1 or 2 threads and on a host's jobs, and the sweep's numbers are those of its copy.
#include <algorithm>

#include "haustra/kernels/rod_condensed.hpp"
#include "step/newton_internal.hpp"
#include "step/newton_stages.hpp"
#include "step/scheduler.hpp"
#include "step/segment_law.hpp"

namespace haustra::detail {
namespace {

template <class From, class To>
void copy_into(const From& from, To&& to) {
  std::copy(from.begin(), from.end(), to.begin());
}
void copy_vec3(kernels::Vec3View<const double> from, Vec3Buffer& to) {
  copy_into(from.x, to.x), copy_into(from.y, to.y), copy_into(from.z, to.z);
}
void copy_rotation(kernels::RotationView<const double> from, RotationBuffer& to) {
  copy_into(from.w, to.w), copy_into(from.x, to.x), copy_into(from.y, to.y), copy_into(from.z, to.z);
}

// The background job: the whole sweep of the copied linearization (kernels/rod_condense, as the
// condense stage runs it), then every column's responses at the coupled unknowns' nodes (as the
// solve stage does). Reads and writes the prefactor's own memory only.
void prefactor_sweep(void* data) {
  Prefactor& pf = *static_cast<Prefactor*>(data);
  const std::size_t n = pf.section_length.size() + 1;
  kernels::RodLinearization lin;
  lin.poses = {pf.position.view(), pf.rotation.view(), pf.mid_position.view().subview(0, n - 1),
               pf.mid_rotation.view().subview(0, n - 1)};
  lin.section_length = pf.section_length;
  lin.node_force = pf.force.view();
  lin.node_moment = pf.moment.view();
  lin.law_total = pf.law_total;
  if (pf.exp2) lin.nodal = {kernels::StrainView<const double>{pf.law_tangent}, pf.bend_coupling};
  if (pf.has_stiffness) lin.stiffness = {pf.force_stiffness, pf.drag_moment_rate};
  lin.free_base = pf.free_base;
  const kernels::CondensedSystem sys{pf.gain, pf.scratch, pf.base_solution, pf.columns, pf.record};
  pf.ok = kernels::rod_condense(lin, kernels::StrainView<const double>{pf.residual}, pf.loads, sys).ok;
  if (pf.ok && !pf.response_nodes.empty())
    kernels::rod_condensed_responses_range(lin, sys, 0, pf.response_nodes.back(), sys.base, pf.response_nodes,
                                           pf.responses, {});
}

// Frames between a prefactor's launch and its swap: the sweep has the rest of the launch frame and
// the whole next one on the other core (measured on the small intestine: a sweep with its responses
// takes ~0.5–0.7 ms there beside the stepping thread, longer than what is left of one frame).
constexpr std::uint64_t kLead = 2;

// The rod replays its record this iteration, and the record comes of age kLead frames from now:
// the record for that frame is launched now.
bool launch_due(const WorldModel& model, const WorldState& state, std::size_t rod, const SubstepParameters& p) {
  const NewtonWorkspace& ws = state.newton[rod];
  return model.solver.prefactor && static_cast<std::uint64_t>(model.solver.refactor_frames) > kLead && p.chord &&
         p.iteration == 0 && !ws.record.empty() && !ws.prefactor.pending &&
         state.segment_converged[rod] == 0 && ws.chord && ws.law_scale == 1.0 && !ws.band &&
         state.frame + kLead - ws.chord_frame >= static_cast<std::uint64_t>(model.solver.refactor_frames);
}

void launch(const WorldModel& model, WorldState& state, Scheduler& scheduler, std::size_t rod,
            const SubstepParameters& p) {
  const SegmentModel& seg = model.segments[rod];
  NewtonWorkspace& ws = state.newton[rod];
  Prefactor& pf = ws.prefactor;
  scheduler.settle(pf.job);  // its buffers are about to be written
  const SegmentViews v = segment_views(model, state, rod);
  copy_vec3(v.poses.node_position, pf.position);
  copy_rotation(v.poses.node_rotation, pf.rotation);
  copy_vec3(v.poses.mid_position, pf.mid_position);
  copy_rotation(v.poses.mid_rotation, pf.mid_rotation);
  copy_vec3(v.force, pf.force);
  copy_vec3(v.moment, pf.moment);
  copy_into(v.section_length, pf.section_length);
  copy_into(ws.residual, pf.residual);
  pf.exp2 = seg.exp2;
  if (pf.exp2) copy_into(ws.law_tangent, pf.law_tangent), copy_into(ws.bend_coupling, pf.bend_coupling);
  pf.has_stiffness = seg.has_load_stiffness;
  if (pf.has_stiffness) {
    copy_into(ws.force_stiffness, pf.force_stiffness);
    copy_into(ws.drag_moment_rate, pf.drag_moment_rate);
  }
  pf.loads = ws.loads;  // within the capacity reserved at build
  pf.response_nodes = ws.response_nodes;
  pf.columns = newton::coupled_unknowns(model, state, rod).columns();
  pf.law_total = law_total(seg, p.dt);
  pf.free_base = seg.base_mode == BaseMode::free;
  pf.frame = state.frame;
  pf.replaces = ws.chord_frame;
  pf.dt = p.dt;
  pf.pattern = ws.pattern_now;
  pf.pending = true;
  scheduler.launch(pf.job, &prefactor_sweep, &pf);
}

// At its frame, the prefactor becomes the record — if the record it was made to replace
// still stands (no refactorization came between) and its sweep held its pivots. A prefactor whose
// frame passed without a chord iteration to swap it into is dropped.
void swap_in(WorldState& state, Scheduler& scheduler, std::size_t rod, const SubstepParameters& p) {
  NewtonWorkspace& ws = state.newton[rod];
  Prefactor& pf = ws.prefactor;
  scheduler.join(pf.job);
  pf.pending = false;
  const bool planned = state.frame == pf.frame + kLead && p.chord && p.iteration == 0;
  if (!planned || !pf.ok || !ws.chord_ready || ws.chord_frame != pf.replaces) return;
  std::swap(ws.gain, pf.gain);
  std::swap(ws.base_solution, pf.base_solution);
  std::swap(ws.record, pf.record);
  std::swap(ws.responses, pf.responses);
  ws.chord_frame = pf.frame;
  ws.chord_dt = pf.dt;
  ws.chord_pattern = pf.pattern;
  ++ws.prefactors;
}

}  // namespace

bool prefactor_swap_due(const WorldState& state) {
  for (const NewtonWorkspace& ws : state.newton)
    if (ws.prefactor.pending && state.frame >= ws.prefactor.frame + kLead) return true;
  return false;
}

void stage_prefactor_swap(const WorldModel& model, WorldState& state, Scheduler& scheduler,
                          const SubstepParameters& p) {
  for (std::size_t s = 0; s < model.segments.size() && s < state.newton.size(); ++s) {
    const Prefactor& pf = state.newton[s].prefactor;
    if (pf.pending && state.frame >= pf.frame + kLead) swap_in(state, scheduler, s, p);
  }
}

bool prefactor_launch_due(const WorldModel& model, const WorldState& state, const SubstepParameters& p) {
  for (std::size_t s = 0; s < state.newton.size(); ++s)
    if (launch_due(model, state, s, p)) return true;
  return false;
}

void stage_prefactor_launch(const WorldModel& model, WorldState& state, Scheduler& scheduler,
                            const SubstepParameters& p) {
  for (std::size_t s = 0; s < state.newton.size(); ++s)
    if (launch_due(model, state, s, p)) launch(model, state, scheduler, s, p);
}

void settle_prefactors(WorldState& state, Scheduler& scheduler) {
  for (NewtonWorkspace& ws : state.newton) scheduler.settle(ws.prefactor.job);
}

}  // namespace haustra::detail
