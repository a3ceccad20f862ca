// The frame pipeline: where a frame goes, verb by verb (like MuJoCo's engine_forward.c). World::step() is
// one frame with the robust mode's ladder; run_frame() one attempt at it; the stages themselves
// live in their own files (rod_stages, newton_stages, line_search, collision, instruments, mesh_stages).
#include <chrono>

#include "step/collision.hpp"
#include "step/instrument_proxy.hpp"
#include "step/instruments.hpp"
#include "step/mesh_stages.hpp"
#include "step/newton_stages.hpp"
#include "step/rod_stages.hpp"
#include "step/sleep.hpp"
#include "step/world_impl.hpp"

namespace haustra {

using detail::SubstepParameters;

namespace {

using Clock = std::chrono::steady_clock;

constexpr std::size_t kParallelMeshVertices = 50'000;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

}  // namespace

// Per segment over the scheduler.
template <class F>
void World::Impl::per_segment(Stage stage, F&& fn) {
  const StageClock clock(profile, stage);
  scheduler.for_each(model.segments.size(), fn);
}

// Per segment still iterating in this substep.
template <class F>
void World::Impl::per_active_segment(Stage stage, F&& fn) {
  per_segment(stage, [&](std::size_t s) {
    if (state.segment_converged[s] == 0) fn(s);
  });
}

// ---- One frame ------------------------------------------------------------------------------------

// One frame, attempted up the robust mode's ladder until an attempt passes the guard (decision
// 0007); when no rung holds, stop_unstable restores the last good frame and throws Error(unstable).
// While it runs, a call on this world from the stepping thread itself (a job system's callback) is
// refused too (decision 0100).
void World::step() {
  const Use use(*this);
  stepping_ = true;
  const struct Stepped {
    bool& stepping;
    ~Stepped() { stepping = false; }
  } stepped{stepping_};
  Impl& w = *impl_;
  const Clock::time_point t0 = Clock::now();
  w.profile = FrameProfile{};
  w.move_instruments();
  w.state.frame_start.copy_from(w.state.now);
  Impl::Rung rung{w.state.robust_substeps, w.state.robust_newton};
  Impl::Failure first{w.model.segments.size(), {}, rung};
  for (;;) {
    // Fast mode reuses factorizations on its own rung only: a redone frame factors afresh.
    const bool chord = w.model.solver.mode == SolverMode::fast && rung.substeps == w.base.substeps && rung.newton &&
                       !first.happened(w.model);
    const std::size_t failed = w.run_frame(rung.substeps, rung.newton, chord);
    if (failed == w.model.segments.size()) break;
    w.state.now.copy_from(w.state.frame_start);
    if (!first.happened(w.model)) first = {failed, w.guard[failed], rung};
    if (!w.can_escalate(rung) || w.profile.retries >= w.model.solver.max_retries) w.stop_unstable(failed, rung, t0);
    rung = w.escalate(rung);
    w.profile.retries += 1;
  }
  w.keep_rung(first, rung);
  w.report();
  w.follow_rod();
  w.finish_frame(rung, t0);
}

// The rung a frame held on is kept for the next ones; after a calm spell extra substeps are shed.
// The spell starts short (one failure, as a pile's first touch, costs a few slow frames, not
// calm_frames of them) and doubles, up to calm_frames, while rungs are needed again within
// calm_frames calm frames (decision 0109).
void World::Impl::keep_rung(const Failure& first, const Rung& rung) {
  const int longest = model.solver.calm_frames;
  if (first.happened(model)) {
    record(recovered_event(first, rung));
    state.robust_calm_spell = state.robust_good_frames >= longest ? detail::first_calm_spell(longest)
                                                                  : std::min(2 * state.robust_calm_spell, longest);
    state.robust_substeps = rung.substeps;
    state.robust_newton = rung.newton;
    state.robust_good_frames = 0;
    return;
  }
  state.robust_good_frames = std::min(state.robust_good_frames + 1, longest);
  if (state.robust_substeps > base.substeps && state.robust_good_frames >= std::min(state.robust_calm_spell, longest)) {
    // Extra substeps are shed again after a calm spell. Newton, once engaged, stays: the scheme
    // that diverged here would diverge again from the same kind of state.
    state.robust_substeps = std::max(base.substeps, state.robust_substeps / 2);
    state.robust_good_frames = 0;
  }
}

// One attempt at a frame with `n` substeps, lagged or Newton. Returns the first segment that
// failed the guard, or model.segments.size() when all passed.
std::size_t World::Impl::run_frame(int n, bool newton, bool chord) {
  SubstepParameters p;
  p.dt = model.dt / n;
  p.newton = newton;
  p.chord = chord;
  // Fast mode's own rung: one chord iteration a frame, as a haptic loop wants (decision 0037).
  const int iterations = chord ? 1 : model.solver.iterations;
  const int max_iterations = newton ? std::max(iterations, model.solver.max_iterations) : iterations;
  for (int sub = 0; sub < n; ++sub) {
    snapshot(newton);
    collide();
    detail::wake_touched(model, state, p.dt);  // a sleeping rod something moving came near (decision 0119)
    for (int it = 0; it < max_iterations; ++it) {
      p.iteration = it;
      const double proxy_moved = proxies(p);
      contacts();
      loads(p);
      if (newton) {
        // Newton (decision 0036): condense the linearized system tip → base, solve for the
        // coupled unknowns and the step, take the fraction of it that lowers the incremental
        // potential (decision 0039); the line search leaves the poses of the strains it took.
        backward_sweep();
        StageClock clock(profile, Stage::condense);
        detail::stage_condense(model, state, scheduler, p);
        clock.next(Stage::solve);
        detail::stage_newton_solve(model, state, scheduler, p);
        clock.next(Stage::line_search);
        detail::stage_line_search(model, state, scheduler, p);
        clock.stop();
        detail::end_unsolvable(model, state);
      } else {
        lagged_iteration(p);
      }
      profile.iterations += 1;
      // The rods and the instruments' proxies converge together (a proxy that still moves asks
      // for another iteration, up to the most there may be).
      if (all_converged(it + 1 >= iterations) && proxy_moved <= detail::kAttachmentTolerance) break;
    }
    if (model.beads.size() > 0) detail::record_bead_motion(model, state);
  }
  filter();
  if (!newton) contraction(p);
  return guard_segments(p);
}

// The paper's lagged scheme: a free base moved rigidly against the total drag first, then the
// strains from the prefactored M, the attachments through their Schur complement, the poses.
void World::Impl::lagged_iteration(const SubstepParameters& p) {
  if (any_free_base)
    per_active_segment(Stage::free_base, [&](std::size_t s) { detail::stage_free_base(model, state, s, p.dt); });
  backward_sweep();
  per_active_segment(Stage::solve,
                     [&](std::size_t s) { state.segment_change[s] = detail::stage_solve(model, state, s, p); });
  if (any_constraints)
    per_active_segment(Stage::constraints, [&](std::size_t s) { detail::stage_constraints(model, state, s, p); });
  per_active_segment(Stage::forward_sweep, [&](std::size_t s) { detail::stage_forward_sweep(model, state, s); });
}

// The beads follow the rod at once; the organ meshes every frame (world.mesh_update =
// "every_frame") or when a reader next asks for them (decision 0060).
void World::Impl::follow_rod() {
  const auto beads = state.collision.bead_position.view();
  for (std::size_t b = 0; b < beads.size(); ++b) beads.set(b, state.now.position.view().get(model.beads.node[b]));
  rings_stale = mesh_stale = model.any_mesh;
  if (model.mesh_update == MeshUpdate::every_frame) bring_mesh_up_to_date();
}

// The world's own mesh at the current frame, if it is not already: rings, skinning, normals.
// Only scheduled when a segment has a mesh; skinning splits into fixed chunks so any thread count
// gives the same bits. rings_only: the cage alone (what cage_vertices and ring_poses read).
void World::Impl::bring_mesh_up_to_date(bool rings_only) {
  const detail::MeshTarget target = detail::own_mesh(state);
  if (rings_stale) {
    const StageClock clock(profile, Stage::cage);
    scheduler.for_each(model.pieces.size(), [&](std::size_t piece) {
      detail::stage_rings(model, state, state.mesh.ring_pose, piece);
      detail::stage_ring_deltas(model, target, piece);
    });
    rings_stale = false;
  }
  if (rings_only || !mesh_stale) return;
  // Below ~50,000 vertices a chunk takes a few µs: dispatching it costs more than it saves.
  const bool parallel = model.mesh_vertex_total >= kParallelMeshVertices;
  StageClock clock(profile, Stage::skin);
  scheduler.for_each(
      model.skin_chunks.size(), [&](std::size_t c) { detail::stage_skin(model, target, c); }, parallel);
  detail::stage_weld_seams(model, target);  // a chain's pieces meet where its mesh was cut
  if (!model.normal_chunks.empty()) {
    clock.next(Stage::normals);
    scheduler.for_each(
        model.normal_chunks.size(), [&](std::size_t c) { detail::stage_normals(model, target, c); }, parallel);
  }
  mesh_stale = false;
}

// A reader's copy of the mesh, from the ring poses the stepping thread published: in the
// caller's thread alone, reading only the model, so it may run while the world steps. Each chunk
// writes only its own vertices, so one after another gives the bits bring_mesh_up_to_date gives.
void World::Impl::mesh_from_rings(const detail::MeshTarget& target) const {
  for (std::size_t piece = 0; piece < model.pieces.size(); ++piece) detail::stage_ring_deltas(model, target, piece);
  for (std::size_t c = 0; c < model.skin_chunks.size(); ++c) detail::stage_skin(model, target, c);
  detail::stage_weld_seams(model, target);
  for (std::size_t c = 0; c < model.normal_chunks.size(); ++c) detail::stage_normals(model, target, c);
}

// ---- The stages, one verb each ---------------------------------------------------------------------

// The instruments to this frame's poses (their scripts, or the host's), grasping and releasing;
// an instrument that cuts takes the tissue within its reach first (decision 0095).
void World::Impl::move_instruments() {
  if (model.instruments.empty()) return;
  const StageClock clock(profile, Stage::instruments);
  detail::stage_instruments(model, state, state.time + model.dt);
  if (model.anchors.size() == 0) return;
  for (std::size_t i = 0; i < model.instruments.size(); ++i)
    if (state.instruments[i].cutting) cut_tissue(state.instruments[i].tip, model.instruments[i].cut_radius);
}

void World::Impl::snapshot(bool newton) {
  per_segment(Stage::snapshot, [&](std::size_t s) { detail::stage_snapshot(model, state, s, newton); });
  if (any_proxy) detail::snapshot_instrument_proxies(state);
}

// The instruments' proxies for the beads where they are now (decision 0096); how far they moved.
double World::Impl::proxies(const SubstepParameters& p) {
  if (!any_proxy) return 0.0;
  const StageClock clock(profile, Stage::proxy);
  return detail::stage_instrument_proxies(model, state, p.dt, model.dt);
}

void World::Impl::collide() {
  if (model.beads.size() == 0) return;
  const StageClock clock(profile, Stage::collide);
  detail::stage_collide(model, state, scheduler);
}

// Contact penalties at the current positions: the frame's start for the lagged scheme, each
// iterate for Newton (which also takes their stiffness).
void World::Impl::contacts() {
  if (state.collision.candidates.empty()) return;
  const StageClock clock(profile, Stage::contacts);
  detail::stage_contacts(model, state, scheduler);
}

void World::Impl::loads(const SubstepParameters& p) {
  per_active_segment(Stage::loads, [&](std::size_t s) { detail::stage_loads(model, state, s, p); });
}

void World::Impl::backward_sweep() {
  per_active_segment(Stage::backward_sweep, [&](std::size_t s) { detail::stage_backward_sweep(model, state, s); });
}

bool World::Impl::all_converged(bool past_fixed_count) {
  bool all = true;
  for (std::size_t s = 0; s < model.segments.size(); ++s) {
    if (state.segment_converged[s] != 0) continue;
    if (detail::iteration_converged(model, state, s, past_fixed_count)) state.segment_converged[s] = 1;
    all = all && state.segment_converged[s] != 0;
  }
  return all;
}

// The stages after the iterations pass over sleeping rods: nothing of theirs changed.
void World::Impl::filter() {
  if (!model.filter.enabled) return;
  per_segment(Stage::filter, [&](std::size_t s) {
    if (state.rod_asleep[s] != 0) return;
    detail::keep_swept_poses(model, state, s);
    detail::stage_filter(model, state, s);
  });
}

void World::Impl::contraction(const SubstepParameters& p) {
  per_segment(Stage::contraction, [&](std::size_t s) {
    if (state.rod_asleep[s] == 0) detail::stage_lagged_contraction(model, state, s, p);
  });
}

std::size_t World::Impl::guard_segments(const SubstepParameters& p) {
  per_segment(Stage::guard, [&](std::size_t s) {
    guard[s] = state.rod_asleep[s] == 0 ? detail::stage_guard(model, state, s, p) : detail::GuardResult{};
  });
  for (std::size_t s = 0; s < model.segments.size(); ++s)
    if (!guard[s].ok) return s;
  return model.segments.size();
}

// What the frame did to the instruments and the tissue: forces on the instruments, grasps that
// slipped, anchors torn past their strength (decision 0095), the contact report; and which rods
// sleep from the next frame on (decision 0119).
void World::Impl::report() {
  if (model.beads.size() == 0 && model.instruments.empty() && model.anchors.size() == 0 && !model.sleep.enabled) return;
  const StageClock clock(profile, Stage::report);
  slipped.clear();
  // The proxies once more for where the frame left the beads: the force each reports is its
  // capsule's spring and its grasp's, within what the capsule leaves it.
  if (any_proxy) (void)detail::stage_instrument_proxies(model, state, model.dt / state.robust_substeps, model.dt);
  detail::instrument_forces(model, state, model.dt, slipped);
  for (const std::size_t i : slipped) record(slipped_event(i));
  if (model.anchors.size() > 0) {
    torn.clear();
    detail::tear_anchors(model, state, torn);
    record_anchors(Event::Kind::torn, torn);
  }
  if (model.beads.size() > 0) detail::stage_contact_report(model, state);
  detail::settle_rods(model, state, model.dt);
}

// The Newton workspaces' counts of this frame (every attempt at it) into the profile.
void World::Impl::collect_newton_counts() {
  for (detail::NewtonWorkspace& ws : state.newton) {
    profile.fallbacks += ws.fallbacks;
    profile.backtracks += ws.backtracks;
    profile.stiffenings += ws.stiffenings;
    profile.chords += ws.chords;
    profile.stalls += ws.stalls;
    ws.fallbacks = ws.backtracks = ws.stiffenings = ws.chords = ws.stalls = 0;
  }
}

void World::Impl::finish_frame(const Rung& kept, Clock::time_point t0) {
  collect_newton_counts();
  profile.substeps = kept.substeps;
  profile.newton = kept.newton;
  profile.nodes_asleep = detail::nodes_asleep(model, state);
  state.frame += 1;
  state.time += model.dt;
  motion_dt = model.dt;
  profile.frame_seconds = seconds_since(t0);
  // Deadline mode (decision 0061): the frame is already done; the host learns it came late.
  if (model.frame_budget > 0.0 && profile.frame_seconds > model.frame_budget) {
    profile.late = 1;
    late_frames += 1;
  }
}

// The frame failed on every rung it may take: the event, then the error; the world keeps the
// last good frame (already restored by the caller).
void World::Impl::stop_unstable(std::size_t failed, const Rung& rung, Clock::time_point t0) {
  const Event e = unstable_event(failed, guard[failed], rung);
  record(e);
  collect_newton_counts();  // the failed frame's own: what the host reads after the error
  profile.substeps = rung.substeps;
  profile.newton = rung.newton;
  profile.frame_seconds = seconds_since(t0);
  throw Error(ErrorCode::unstable, std::string(e.message()));
}

// ---- The robust mode's ladder: the configured solver, then Newton, then Newton with twice the
// substeps each time up to solver.max_substeps. A frame that needed it keeps that rung for a
// while, then steps back down.

bool World::Impl::can_escalate(const Rung& r) const {
  return model.solver.on_instability == InstabilityPolicy::recover &&
         (!r.newton || r.substeps < model.solver.max_substeps);
}

World::Impl::Rung World::Impl::escalate(const Rung& r) const {
  if (!r.newton) return {r.substeps, true};
  return {std::min(2 * r.substeps, model.solver.max_substeps), true};
}

}  // namespace haustra
