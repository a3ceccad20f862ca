// The frame pipeline, stage by stage: World::Impl's step() and run_frame(). Read this file to
// see where a frame goes (like MuJoCo's engine_forward.c); the stages themselves live in their
// own files (rod_stages, newton_stages, line_search, collision, instruments, mesh_stages).
#include <fmt/format.h>
#include <chrono>
#include <type_traits>

#include "haustra/kernels/rod_forward_sweep.hpp"
#include "step/collision.hpp"
#include "step/instruments.hpp"
#include "step/mesh_stages.hpp"
#include "step/newton_stages.hpp"
#include "step/rod_stages.hpp"
#include "step/world_impl.hpp"

namespace haustra {

using detail::GuardResult;
using detail::SubstepParameters;

std::string_view stage_name(Stage s) noexcept {
  switch (s) {
    case Stage::instruments: return "instruments";
    case Stage::snapshot: return "snapshot";
    case Stage::collide: return "collide";
    case Stage::contacts: return "contacts";
    case Stage::loads: return "loads";
    case Stage::free_base: return "free_base";
    case Stage::backward_sweep: return "backward_sweep";
    case Stage::condense: return "condense";
    case Stage::solve: return "solve";
    case Stage::line_search: return "line_search";
    case Stage::constraints: return "constraints";
    case Stage::forward_sweep: return "forward_sweep";
    case Stage::filter: return "filter";
    case Stage::contraction: return "contraction";
    case Stage::guard: return "guard";
    case Stage::report: return "report";
    case Stage::cage: return "cage";
    case Stage::skin: return "skin";
    case Stage::normals: return "normals";
    case Stage::count: break;
  }
  return "?";
}

namespace {

using Clock = std::chrono::steady_clock;

constexpr std::size_t kMaxEvents = 1024;
constexpr std::size_t kParallelMeshVertices = 50'000;
constexpr int kGoodFramesBeforeRelaxing = 120;  // robust mode: calm frames before halving substeps again

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

}  // namespace

template <class F>
void World::Impl::stage(Stage stage, F&& fn) {
  const Clock::time_point t0 = Clock::now();
  if constexpr (std::is_invocable_v<F&, std::size_t>)
    scheduler.for_each(model.segments.size(), fn);
  else
    fn();
  profile.seconds[static_cast<std::size_t>(stage)] += seconds_since(t0);
  profile.calls[static_cast<std::size_t>(stage)] += 1;
}

World::Impl::Impl(WorldDesc d, detail::WorldModel m)
    : desc(std::move(d)), model(std::move(m)), scheduler(desc.threads, desc.jobs) {
  detail::init_world_state(model, state);
  detail::init_collision_state(model, state);
  detail::init_instruments(model, state);
  guard.resize(model.segments.size());
  events.reserve(kMaxEvents);
  base = {model.solver.substeps, model.solver.mode != SolverMode::lagged};
  state.robust_substeps = base.substeps;
  state.robust_newton = base.newton;
  for (const auto& s : model.segments) {
    any_free_base |= s.base_mode == BaseMode::free;
    any_constraints |= s.constraint_rows > 0;
  }
  follow_rod();  // the meshes at rest, before the first step
}

// The organ meshes follow the rod: rings, skinning, normals. Only scheduled when a segment has
// a mesh; skinning splits into fixed chunks so any thread count gives the same bits.
void World::Impl::follow_rod() {
  const auto beads = state.collision.bead_position.view();
  for (std::size_t b = 0; b < beads.size(); ++b) beads.set(b, state.now.position.view().get(model.beads.node[b]));
  if (!model.any_mesh) return;
  stage(Stage::cage, [&] {
    scheduler.for_each(model.pieces.size(), [&](std::size_t piece) { detail::stage_cage(model, state, piece); });
  });
  // Below ~50,000 vertices a chunk takes a few µs: dispatching it costs more than it saves.
  const bool parallel = model.mesh_vertex_total >= kParallelMeshVertices;
  stage(Stage::skin, [&] {
    scheduler.for_each(
        model.skin_chunks.size(), [&](std::size_t c) { detail::stage_skin(model, state, c); }, parallel);
  });
  if (!model.normal_chunks.empty())
    stage(Stage::normals, [&] {
      scheduler.for_each(
          model.normal_chunks.size(), [&](std::size_t c) { detail::stage_normals(model, state, c); }, parallel);
    });
}

// One attempt at a frame with `n` substeps, lagged or Newton. Returns the first segment that
// failed the guard, or model.segments.size() when all passed.
std::size_t World::Impl::run_frame(int n, bool newton, bool chord) {
  SubstepParameters p;
  p.dt = model.dt / n;
  p.newton = newton;
  p.chord = chord;
  const std::size_t segs = model.segments.size();
  for (int sub = 0; sub < n; ++sub) {
    stage(Stage::snapshot, [&](std::size_t s) {
      const auto& seg = model.segments[s];
      const auto off = static_cast<std::ptrdiff_t>(seg.node_offset);
      const auto cnt = static_cast<std::ptrdiff_t>(seg.node_count);
      std::copy_n(state.now.strain.begin() + 4 * off, 4 * cnt, state.strain_substep_start.begin() + 4 * off);
      if (newton && seg.has_drag) {
        auto copy = [&](std::span<const double> from, std::span<double> to) {
          std::copy_n(from.begin() + off, cnt, to.begin() + off);
        };
        copy(state.now.position.x, state.position_substep_start.x);
        copy(state.now.position.y, state.position_substep_start.y);
        copy(state.now.position.z, state.position_substep_start.z);
        copy(state.now.rotation.w, state.rotation_substep_start.w);
        copy(state.now.rotation.x, state.rotation_substep_start.x);
        copy(state.now.rotation.y, state.rotation_substep_start.y);
        copy(state.now.rotation.z, state.rotation_substep_start.z);
      }
      state.base_substep_start[s] = state.now.base[s];
      state.segment_converged[s] = 0;
      state.segment_solvable[s] = 1;
    });
    if (model.beads.size() > 0) stage(Stage::collide, [&] { detail::stage_collide(model, state, scheduler); });
    // Fast mode's own rung: one chord iteration a frame, as a haptic loop wants (decision 0037).
    const int iterations = chord ? 1 : model.solver.iterations;
    const int max_iterations = newton ? std::max(iterations, model.solver.max_iterations) : iterations;
    for (int it = 0; it < max_iterations; ++it) {
      auto active = [&](std::size_t s) { return state.segment_converged[s] == 0; };
      // Contact penalties at the current positions: the frame's start for the lagged scheme,
      // each iterate for Newton (which also takes their stiffness).
      if (!state.collision.candidates.empty())
        stage(Stage::contacts, [&] { detail::stage_contacts(model, state, scheduler); });
      stage(Stage::loads, [&](std::size_t s) {
        if (active(s)) detail::stage_loads(model, state, s, p);
      });
      // Newton moves a free base inside its own system (the medium's drag on every node); the
      // lagged scheme moves it rigidly against the total drag first.
      if (any_free_base && !newton) {
        stage(Stage::free_base, [&](std::size_t s) {
          if (active(s)) detail::stage_free_base(model, state, s, p.dt);
        });
      }
      stage(Stage::backward_sweep, [&](std::size_t s) {
        if (active(s)) detail::stage_backward_sweep(model, state, s);
      });
      p.iteration = it;
      if (newton) {
        // A long rod's solve runs as two parts (decision 0036): per part where it can, per rod
        // where the parts meet.
        auto part_active = [&](std::size_t i) {
          const std::size_t s = model.solve_parts[i].rod;
          return active(s) && state.segment_solvable[s] != 0;
        };
        const std::size_t parts = model.solve_parts.size();
        stage(Stage::condense, [&] {
          scheduler.for_each(segs, [&](std::size_t s) {
            if (active(s)) detail::stage_newton_linearize(model, state, s, p);
          });
          for (std::size_t s = 0; s < segs; ++s) state.segment_solving[s] = active(s) && state.segment_solvable[s] != 0;
          detail::plan_newton_condense(model, state, state.segment_solving);
          scheduler.for_each(state.condense_tasks.size(), [&](std::size_t i) {
            detail::stage_newton_condense_task(model, state, state.condense_tasks[i], p);
          });
          scheduler.for_each(segs, [&](std::size_t s) {
            if (active(s)) state.segment_solvable[s] = detail::stage_newton_join(model, state, s, p) ? 1 : 0;
          });
        });
        stage(Stage::solve, [&] {
          scheduler.for_each(2 * segs, [&](std::size_t i) {
            const std::size_t s = i / 2;
            if (active(s) && state.segment_solvable[s] != 0)
              detail::stage_newton_responses(model, state, s, static_cast<int>(i % 2), p);
          });
          scheduler.for_each(segs, [&](std::size_t s) {
            if (active(s) && state.segment_solvable[s] != 0) detail::stage_newton_multipliers(model, state, s);
          });
          scheduler.for_each(parts, [&](std::size_t i) {
            if (part_active(i)) detail::stage_newton_step_part(model, state, model.solve_parts[i], p);
          });
        });
        stage(Stage::line_search, [&] {
          scheduler.for_each(segs, [&](std::size_t s) {
            if (active(s) && state.segment_solvable[s] != 0) detail::stage_newton_search_begin(model, state, s, p);
          });
          for (;;) {
            bool searching = false;
            for (std::size_t s = 0; s < segs; ++s) searching = searching || state.newton[s].search.active;
            if (!searching) break;
            scheduler.for_each(
                parts, [&](std::size_t i) { detail::stage_newton_search_sweep(model, state, model.solve_parts[i]); });
            scheduler.for_each(parts, [&](std::size_t i) {
              detail::stage_newton_search_measure(model, state, model.solve_parts[i], p);
            });
            scheduler.for_each(segs, [&](std::size_t s) { detail::stage_newton_search_decide(model, state, s, p); });
          }
        });
        for (std::size_t s = 0; s < segs; ++s)
          if (active(s) && state.segment_solvable[s] == 0) {
            state.segment_change[s].setZero();
            state.segment_converged[s] = 1;  // nothing more to do here: the guard reports it
          }
      } else {
        stage(Stage::solve, [&](std::size_t s) {
          if (active(s)) state.segment_change[s] = detail::stage_solve(model, state, s, p);
        });
        if (any_constraints)
          stage(Stage::constraints, [&](std::size_t s) {
            if (active(s)) detail::stage_constraints(model, state, s, p);
          });
      }
      // (Newton's line search leaves the poses of the strains it took.)
      if (!newton)
        stage(Stage::forward_sweep, [&](std::size_t s) {
          if (active(s)) detail::stage_forward_sweep(model, state, s);
        });
      profile.iterations += 1;
      bool all = true;
      for (std::size_t s = 0; s < segs; ++s) {
        if (!active(s)) continue;
        const Eigen::Vector4d& d = state.segment_change[s];
        const double moved = std::max(d.head<3>().maxCoeff() * model.segments[s].mean_section, d[3]);
        if (moved <= model.solver.tolerance) state.segment_converged[s] = 1;
        // Past the fixed count, Newton goes on only where a contact cut its step short or an
        // attachment is still off target.
        if (it + 1 >= iterations) {
          std::size_t node = 0;
          if (state.segment_step_cut[s] == 0 &&
              detail::attachment_miss(model, state, s, node) <= model.solver.attachment_tolerance)
            state.segment_converged[s] = 1;
        }
        all = all && state.segment_converged[s] != 0;
      }
      if (all) break;
    }
    if (model.beads.size() > 0) detail::record_bead_motion(model, state);
  }
  if (model.filter.enabled) stage(Stage::filter, [&](std::size_t s) { detail::stage_filter(model, state, s); });
  if (!newton) stage(Stage::contraction, [&](std::size_t s) { detail::stage_lagged_contraction(model, state, s, p); });
  stage(Stage::guard, [&](std::size_t s) { guard[s] = detail::stage_guard(model, state, s, p); });
  for (std::size_t s = 0; s < segs; ++s)
    if (!guard[s].ok) return s;
  return segs;
}

// The API's segment (a piece of a chain, or the whole rod) that holds node `node` of rod `rod`,
// and the node's index in it; a joint node counts as the later piece's base.
std::pair<std::size_t, std::size_t> World::Impl::piece_of(std::size_t rod, std::size_t node) const {
  const detail::SegmentModel& seg = model.segments[rod];
  std::size_t p = seg.first_piece + seg.piece_count - 1;
  while (p > seg.first_piece && model.pieces[p].first_node > node) --p;
  return {p, node - model.pieces[p].first_node};
}

// Writes "frame F: segment 'S' (i), node K: <what failed> after stage 'X' with N substeps" into
// `out` without allocating; returns the end of what was written.
template <class It>
It World::Impl::describe(It out, std::size_t max, std::size_t s, const GuardResult& g, int n) const {
  const auto [piece, node] = piece_of(s, g.node);
  const auto name = std::string_view(model.pieces[piece].info.name);
  if (g.limit > 0.0)
    return fmt::format_to_n(out, max,
                            "frame {}: segment '{}' ({}), node {}: {} {:.4g} exceeds the limit {:.4g} after stage '{}' "
                            "with {} substep{}",
                            state.frame, name, piece, node, g.quantity, g.value, g.limit, stage_name(g.stage), n,
                            n == 1 ? "" : "s")
        .out;
  return fmt::format_to_n(out, max, "frame {}: segment '{}' ({}), node {}: {} after stage '{}' with {} substep{}",
                          state.frame, name, piece, node, g.quantity, stage_name(g.stage), n, n == 1 ? "" : "s")
      .out;
}

Event World::Impl::make_event(Event::Kind kind, std::size_t s, const GuardResult& g, int n) const {
  Event e;
  e.kind = kind;
  e.frame = state.frame;
  std::tie(e.segment, e.node) = piece_of(s, g.node);
  e.stage = g.stage;
  e.substeps = n;
  return e;
}

void World::Impl::record(const Event& e) {
  if (events.size() < kMaxEvents) events.push_back(e);  // capacity reserved at creation
}

// The robust mode's ladder: the configured solver, then Newton, then Newton with twice the
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

void World::Impl::step() {
  const Clock::time_point t0 = Clock::now();
  profile = FrameProfile{};
  if (!model.instruments.empty())
    stage(Stage::instruments, [&] { detail::stage_instruments(model, state, state.time + model.dt); });
  state.frame_start.copy_from(state.now);
  Rung rung{state.robust_substeps, state.robust_newton};
  std::size_t first_segment = model.segments.size();
  GuardResult first{};
  Rung first_rung = rung;
  for (;;) {
    // Fast mode reuses factorizations on its own rung only: a redone frame factors afresh.
    const bool chord = model.solver.mode == SolverMode::fast && rung.substeps == base.substeps && rung.newton;
    const std::size_t failed = run_frame(rung.substeps, rung.newton, chord && first_segment == model.segments.size());
    if (failed == model.segments.size()) break;
    state.now.copy_from(state.frame_start);
    if (first_segment == model.segments.size()) {
      first_segment = failed;
      first = guard[failed];
      first_rung = rung;
    }
    if (can_escalate(rung)) {
      rung = escalate(rung);
      profile.retries += 1;
      continue;
    }
    const GuardResult& g = guard[failed];
    Event e = make_event(Event::Kind::unstable, failed, g, rung.substeps);
    const std::size_t cap = e.text.size() - 1;
    char* it = fmt::format_to_n(e.text.data(), cap, "unstable at ").out;
    it = describe(it, cap - static_cast<std::size_t>(it - e.text.data()), failed, g, rung.substeps);
    it = fmt::format_to_n(it, cap - static_cast<std::size_t>(it - e.text.data()),
                          ". {}Lower the time step, raise "
                          "solver.max_substeps or solver.iterations, or soften the loads. The world keeps its last "
                          "good frame.",
                          model.solver.on_instability == InstabilityPolicy::recover
                              ? "Newton with more substeps did not recover either. "
                              : "solver.on_instability is \"stop\". ")
             .out;
    *std::min(it, e.text.data() + cap) = '\0';
    record(e);
    profile.substeps = rung.substeps;
    profile.newton = rung.newton;
    profile.frame_seconds = seconds_since(t0);
    throw Error(ErrorCode::unstable, std::string(e.message()));
  }
  if (first_segment != model.segments.size()) {
    Event e = make_event(Event::Kind::recovered, first_segment, first, rung.substeps);
    const std::size_t cap = e.text.size() - 1;
    char* it = fmt::format_to_n(e.text.data(), cap, "recovered: ").out;
    it = describe(it, cap - static_cast<std::size_t>(it - e.text.data()), first_segment, first, first_rung.substeps);
    it = fmt::format_to_n(it, cap - static_cast<std::size_t>(it - e.text.data()),
                          "; the frame was redone with {}{} substep{}", rung.newton ? "Newton and " : "", rung.substeps,
                          rung.substeps == 1 ? "" : "s")
             .out;
    *std::min(it, e.text.data() + cap) = '\0';
    record(e);
    state.robust_substeps = rung.substeps;
    state.robust_newton = rung.newton;
    state.robust_good_frames = 0;
  } else if (state.robust_substeps > base.substeps && ++state.robust_good_frames >= kGoodFramesBeforeRelaxing) {
    // Extra substeps are shed again after a calm spell. Newton, once engaged, stays: the scheme
    // that diverged here would diverge again from the same kind of state.
    state.robust_substeps = std::max(base.substeps, state.robust_substeps / 2);
    state.robust_good_frames = 0;
  }
  if (model.beads.size() > 0 || !model.instruments.empty())
    stage(Stage::report, [&] {
      detail::instrument_forces(model, state, model.dt);
      if (model.beads.size() > 0) detail::stage_contact_report(model, state);
    });
  follow_rod();
  for (detail::NewtonWorkspace& ws : state.newton) {
    profile.fallbacks += ws.fallbacks;
    profile.backtracks += ws.backtracks;
    profile.stiffenings += ws.stiffenings;
    profile.chords += ws.chords;
    ws.fallbacks = ws.backtracks = ws.stiffenings = ws.chords = 0;
  }
  profile.substeps = rung.substeps;
  profile.newton = rung.newton;
  state.frame += 1;
  state.time += model.dt;
  profile.frame_seconds = seconds_since(t0);
}

std::unique_ptr<World> World::create(const WorldDesc& desc) {
  if (desc.jobs.enabled() != (desc.jobs.wait != nullptr))
    throw Error(ErrorCode::invalid_argument, "jobs: a host job system needs both enqueue and wait (or neither)");
  if (desc.jobs.enabled() && (desc.jobs.workers < 1 || desc.jobs.workers > 1024))
    throw Error(ErrorCode::invalid_argument, fmt::format("jobs.workers = {}: expected 1 to 1024", desc.jobs.workers));
  return std::unique_ptr<World>(new World(std::make_unique<Impl>(desc, detail::build_world_model(desc))));
}

void World::step() { impl_->step(); }

}  // namespace haustra
