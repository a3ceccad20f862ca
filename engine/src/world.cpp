#include "haustra/world.hpp"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <fmt/format.h>

#include "checkpoint.hpp"
#include "collision.hpp"
#include "haustra/kernels/rod_forward_sweep.hpp"
#include "instruments.hpp"
#include "mesh_stages.hpp"
#include "newton_stages.hpp"
#include "rod_stages.hpp"
#include "scheduler.hpp"
#include "state_carry_over.hpp"
#include "world_model.hpp"
#include "world_state.hpp"

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

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

}  // namespace

struct World::Impl {
  WorldDesc desc;  // what the model was built from: adding or removing a segment rebuilds it
  detail::WorldModel model;
  detail::WorldState state;
  detail::Scheduler scheduler;
  FrameProfile profile;
  std::vector<Event> events;
  std::vector<GuardResult> guard;
  // A rung of the robust mode's ladder: how a frame is attempted.
  struct Rung {
    int substeps;
    bool newton;
  };
  Rung base{1, false};  // what the scene asked for; the rung it runs now is in the state
  bool any_free_base = false;
  bool any_constraints = false;

  Impl(WorldDesc d, detail::WorldModel m)
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
  void follow_rod() {
    const auto beads = state.collision.bead_position.view();
    for (std::size_t b = 0; b < beads.size(); ++b) beads.set(b, state.now.position.view().get(model.beads.node[b]));
    if (!model.any_mesh) return;
    time_stage(Stage::cage, [&] {
      scheduler.for_each(model.pieces.size(), [&](std::size_t piece) { detail::stage_cage(model, state, piece); });
    });
    // Below ~50,000 vertices a chunk takes a few µs: dispatching it costs more than it saves.
    const bool parallel = model.mesh_vertex_total >= kParallelMeshVertices;
    time_stage(Stage::skin, [&] {
      scheduler.for_each(model.skin_chunks.size(), [&](std::size_t c) { detail::stage_skin(model, state, c); }, parallel);
    });
    if (!model.normal_chunks.empty())
      time_stage(Stage::normals, [&] {
        scheduler.for_each(model.normal_chunks.size(), [&](std::size_t c) { detail::stage_normals(model, state, c); },
                           parallel);
      });
  }

  // A world-wide stage (it spreads its own work over the scheduler).
  template <class F>
  void time_stage(Stage stage, F&& fn) {
    const Clock::time_point t0 = Clock::now();
    fn();
    profile.seconds[static_cast<std::size_t>(stage)] += seconds_since(t0);
    profile.calls[static_cast<std::size_t>(stage)] += 1;
  }

  template <class F>
  void run_stage(Stage stage, F&& fn) {
    const Clock::time_point t0 = Clock::now();
    scheduler.for_each(model.segments.size(), fn);
    profile.seconds[static_cast<std::size_t>(stage)] += seconds_since(t0);
    profile.calls[static_cast<std::size_t>(stage)] += 1;
  }

  // One attempt at a frame with `n` substeps, lagged or Newton. Returns the first segment that
  // failed the guard, or model.segments.size() when all passed.
  std::size_t run_frame(int n, bool newton, bool chord) {
    SubstepParameters p;
    p.dt = model.dt / n;
    p.newton = newton;
    p.chord = chord;
    const std::size_t segs = model.segments.size();
    for (int sub = 0; sub < n; ++sub) {
      run_stage(Stage::snapshot, [&](std::size_t s) {
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
      if (model.beads.size() > 0) time_stage(Stage::collide, [&] { detail::stage_collide(model, state, scheduler); });
      // Fast mode's own rung: one chord iteration a frame, as a haptic loop wants (decision 0037).
      const int iterations = chord ? 1 : model.solver.iterations;
      const int max_iterations = newton ? std::max(iterations, model.solver.max_iterations) : iterations;
      for (int it = 0; it < max_iterations; ++it) {
        auto active = [&](std::size_t s) { return state.segment_converged[s] == 0; };
        // Contact penalties at the current positions: the frame's start for the lagged scheme,
        // each iterate for Newton (which also takes their stiffness).
        if (!state.collision.candidates.empty())
          time_stage(Stage::contacts, [&] { detail::stage_contacts(model, state, scheduler); });
        run_stage(Stage::loads, [&](std::size_t s) {
          if (active(s)) detail::stage_loads(model, state, s, p);
        });
        // Newton moves a free base inside its own system (the medium's drag on every node); the
        // lagged scheme moves it rigidly against the total drag first.
        if (any_free_base && !newton) {
          run_stage(Stage::free_base, [&](std::size_t s) {
            if (active(s)) detail::stage_free_base(model, state, s, p.dt);
          });
        }
        run_stage(Stage::backward_sweep, [&](std::size_t s) {
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
          time_stage(Stage::condense, [&] {
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
          time_stage(Stage::solve, [&] {
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
          time_stage(Stage::line_search, [&] {
            scheduler.for_each(segs, [&](std::size_t s) {
              if (active(s) && state.segment_solvable[s] != 0) detail::stage_newton_search_begin(model, state, s, p);
            });
            for (;;) {
              bool searching = false;
              for (std::size_t s = 0; s < segs; ++s) searching = searching || state.newton[s].search.active;
              if (!searching) break;
              scheduler.for_each(parts, [&](std::size_t i) {
                detail::stage_newton_search_sweep(model, state, model.solve_parts[i]);
              });
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
          run_stage(Stage::solve, [&](std::size_t s) {
            if (active(s)) state.segment_change[s] = detail::stage_solve(model, state, s, p);
          });
          if (any_constraints)
            run_stage(Stage::constraints, [&](std::size_t s) {
              if (active(s)) detail::stage_constraints(model, state, s, p);
            });
        }
        // (Newton's line search leaves the poses of the strains it took.)
        if (!newton)
          run_stage(Stage::forward_sweep, [&](std::size_t s) {
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
    if (model.filter.enabled) run_stage(Stage::filter, [&](std::size_t s) { detail::stage_filter(model, state, s); });
    if (!newton) run_stage(Stage::contraction, [&](std::size_t s) { detail::stage_lagged_contraction(model, state, s, p); });
    run_stage(Stage::guard, [&](std::size_t s) { guard[s] = detail::stage_guard(model, state, s, p); });
    for (std::size_t s = 0; s < segs; ++s)
      if (!guard[s].ok) return s;
    return segs;
  }

  // Writes "frame F: segment 'S' (i), node K: <what failed> after stage 'X' with N substeps" into
  // `out` without allocating; returns the end of what was written.
  // The API's segment (a piece of a chain, or the whole rod) that holds node `node` of rod `rod`,
  // and the node's index in it; a joint node counts as the later piece's base.
  [[nodiscard]] std::pair<std::size_t, std::size_t> piece_of(std::size_t rod, std::size_t node) const {
    const detail::SegmentModel& seg = model.segments[rod];
    std::size_t p = seg.first_piece + seg.piece_count - 1;
    while (p > seg.first_piece && model.pieces[p].first_node > node) --p;
    return {p, node - model.pieces[p].first_node};
  }

  template <class It>
  It describe(It out, std::size_t max, std::size_t s, const GuardResult& g, int n) const {
    const auto [piece, node] = piece_of(s, g.node);
    const auto name = std::string_view(model.pieces[piece].info.name);
    if (g.limit > 0.0)
      return fmt::format_to_n(out, max, "frame {}: segment '{}' ({}), node {}: {} {:.4g} exceeds the limit {:.4g} after stage '{}' with {} substep{}",
                              state.frame, name, piece, node, g.quantity, g.value, g.limit, stage_name(g.stage), n,
                              n == 1 ? "" : "s")
          .out;
    return fmt::format_to_n(out, max, "frame {}: segment '{}' ({}), node {}: {} after stage '{}' with {} substep{}",
                            state.frame, name, piece, node, g.quantity, stage_name(g.stage), n, n == 1 ? "" : "s")
        .out;
  }

  Event make_event(Event::Kind kind, std::size_t s, const GuardResult& g, int n) const {
    Event e;
    e.kind = kind;
    e.frame = state.frame;
    std::tie(e.segment, e.node) = piece_of(s, g.node);
    e.stage = g.stage;
    e.substeps = n;
    return e;
  }

  void record(const Event& e) {
    if (events.size() < kMaxEvents) events.push_back(e);  // capacity reserved at creation
  }

  // The robust mode's ladder: the configured solver, then Newton, then Newton with twice the
  // substeps each time up to solver.max_substeps. A frame that needed it keeps that rung for a
  // while, then steps back down.

  [[nodiscard]] bool can_escalate(const Rung& r) const {
    return model.solver.on_instability == InstabilityPolicy::recover &&
           (!r.newton || r.substeps < model.solver.max_substeps);
  }

  [[nodiscard]] Rung escalate(const Rung& r) const {
    if (!r.newton) return {r.substeps, true};
    return {std::min(2 * r.substeps, model.solver.max_substeps), true};
  }

  void step() {
    const Clock::time_point t0 = Clock::now();
    profile = FrameProfile{};
    if (!model.instruments.empty())
      time_stage(Stage::instruments, [&] { detail::stage_instruments(model, state, state.time + model.dt); });
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
      it = fmt::format_to_n(it, cap - static_cast<std::size_t>(it - e.text.data()), ". {}Lower the time step, raise "
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
                            "; the frame was redone with {}{} substep{}", rung.newton ? "Newton and " : "",
                            rung.substeps, rung.substeps == 1 ? "" : "s")
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
      time_stage(Stage::report, [&] {
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

  // The API's segment `segment` (a piece of the model), or an error naming the range.
  const detail::SegmentPiece& piece(std::size_t segment) const {
    if (segment >= model.pieces.size())
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("segment index {} out of range (the world has {})", segment, model.pieces.size()));
    return model.pieces[segment];
  }

  const detail::SegmentMesh& mesh_of(std::size_t segment) const {
    piece(segment);
    return model.meshes_of[segment];
  }

  // Attachments belong to rods: every piece of a chain addresses its chain's attachments.
  std::size_t attachment_index(std::size_t segment, std::size_t attachment) const {
    const auto& seg = model.segments[piece(segment).rod];
    if (attachment >= seg.attachments.size())
      throw Error(ErrorCode::invalid_argument, fmt::format("segment '{}' has {} attachments, asked for index {}",
                                                           model.pieces[segment].info.name, seg.attachments.size(),
                                                           attachment));
    return seg.attachment_offset + attachment;
  }
};

std::unique_ptr<World> World::create(const WorldDesc& desc) {
  if (desc.jobs.enabled() != (desc.jobs.wait != nullptr))
    throw Error(ErrorCode::invalid_argument, "jobs: a host job system needs both enqueue and wait (or neither)");
  if (desc.jobs.enabled() && (desc.jobs.workers < 1 || desc.jobs.workers > 1024))
    throw Error(ErrorCode::invalid_argument, fmt::format("jobs.workers = {}: expected 1 to 1024", desc.jobs.workers));
  return std::unique_ptr<World>(new World(std::make_unique<Impl>(desc, detail::build_world_model(desc))));
}

// The new model is built first: a description it refuses leaves the world as it was.
void World::rebuild(WorldDesc next, std::span<const std::size_t> rod_map) {
  auto fresh = std::make_unique<Impl>(next, detail::build_world_model(next));
  detail::carry_over_state(impl_->model, impl_->state, fresh->model, fresh->state, rod_map);
  fresh->events = impl_->events;
  fresh->follow_rod();
  fresh->profile = FrameProfile{};
  impl_ = std::move(fresh);
}

std::size_t World::add_segment(const SegmentDesc& segment) {
  WorldDesc next = impl_->desc;
  next.segments.push_back(segment);
  std::vector<std::size_t> rod_map(impl_->model.segments.size());
  for (std::size_t r = 0; r < rod_map.size(); ++r) rod_map[r] = r;
  const std::size_t first = impl_->model.pieces.size();
  rebuild(std::move(next), rod_map);
  return first;
}

void World::remove_segment(std::size_t segment) {
  const detail::SegmentPiece& piece = impl_->piece(segment);
  const detail::SegmentModel& rod = impl_->model.segments[piece.rod];
  if (piece.first_node != 0)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("segment '{}' is a piece of the chain '{}': a chain is removed whole, through its first "
                            "segment '{}'",
                            piece.info.name, rod.info.name, impl_->model.pieces[rod.first_piece].info.name));
  WorldDesc next = impl_->desc;
  next.segments.erase(next.segments.begin() + static_cast<std::ptrdiff_t>(piece.rod));
  std::vector<std::size_t> rod_map(impl_->model.segments.size());
  for (std::size_t r = 0; r < rod_map.size(); ++r)
    rod_map[r] = r < piece.rod ? r : r == piece.rod ? detail::kRodRemoved : r - 1;
  rebuild(std::move(next), rod_map);
}

World::World(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
World::~World() = default;

void World::step() { impl_->step(); }
std::size_t World::segment_count() const { return impl_->model.pieces.size(); }
std::size_t World::node_count() const { return impl_->model.node_total; }
const SegmentInfo& World::segment(std::size_t index) const { return impl_->piece(index).info; }
std::size_t World::chain_of(std::size_t segment) const {
  const detail::SegmentPiece& p = impl_->piece(segment);
  return impl_->model.segments[p.rod].first_piece;
}
double World::dt() const { return impl_->model.dt; }
std::uint64_t World::frame() const { return impl_->state.frame; }
double World::time() const { return impl_->state.time; }
kernels::Vec3View<const double> World::node_positions() const { return impl_->state.now.position.view(); }
kernels::RotationView<const double> World::node_rotations() const { return impl_->state.now.rotation.view(); }
kernels::StrainView<const double> World::strains() const {
  return kernels::StrainView<const double>{impl_->state.now.strain};
}
kernels::StrainView<const double> World::rest_strains() const {
  return kernels::StrainView<const double>{impl_->model.rest_strain};
}
std::span<const double> World::section_lengths() const { return impl_->model.section_length; }
kernels::Pose World::base_pose(std::size_t segment) const {
  const detail::SegmentPiece& p = impl_->piece(segment);
  if (p.first_node == 0) return impl_->state.now.base[p.rod];
  const std::size_t node = p.info.nodes.offset;  // a chained piece's base is its predecessor's tip
  return {impl_->state.now.rotation.view().get(node), impl_->state.now.position.view().get(node)};
}

void World::pose_rod(std::size_t segment, const kernels::Pose& base, std::span<const double> strains) {
  auto& m = impl_->model;
  const detail::SegmentPiece& piece = impl_->piece(segment);
  if (piece.first_node != 0)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("segment '{}' is a later piece of the chain '{}': pose the chain through its first piece",
                            piece.info.name, m.segments[piece.rod].info.name));
  segment = piece.rod;
  const detail::SegmentModel& seg = m.segments[segment];
  if (strains.size() != 4 * seg.node_count)
    throw Error(ErrorCode::invalid_argument, fmt::format("segment '{}' needs {} strains (4 per node), got {}", seg.info.name,
                                                         4 * seg.node_count, strains.size()));
  if (!base.position.allFinite() || !base.rotation.coeffs().allFinite() || !(base.rotation.norm() > 0.0))
    throw Error(ErrorCode::invalid_argument, "pose_rod: the base pose must be finite");
  for (double q : strains)
    if (!std::isfinite(q)) throw Error(ErrorCode::invalid_argument, "pose_rod: strains must be finite");
  auto& st = impl_->state;
  std::copy(strains.begin(), strains.end(), st.now.strain.begin() + static_cast<std::ptrdiff_t>(4 * seg.node_offset));
  st.now.base[segment] = {base.rotation.normalized(), base.position};
  const detail::SegmentViews v = detail::segment_views(m, st, segment);
  kernels::rod_forward_sweep(st.now.base[segment], v.section_length, v.strain, v.poses);
  st.frame_start.copy_from(st.now);
  impl_->follow_rod();
}

void World::set_external_load(std::size_t node, const Eigen::Vector3d& force, const Eigen::Vector3d& moment) {
  if (node >= impl_->model.node_total)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("node index {} out of range (the world has {} nodes)", node, impl_->model.node_total));
  if (!force.allFinite() || !moment.allFinite())
    throw Error(ErrorCode::invalid_argument, "external load: force and moment must be finite");
  impl_->state.external_force.view().set(node, force);
  impl_->state.external_moment.view().set(node, moment);
}

void World::set_attachment_target(std::size_t segment, std::size_t attachment, const Eigen::Vector3d& position) {
  if (!position.allFinite()) throw Error(ErrorCode::invalid_argument, "attachment target must be finite");
  impl_->state.now.attachment[impl_->attachment_index(segment, attachment)].target = position;
}

void World::set_attachment_target_rotation(std::size_t segment, std::size_t attachment,
                                           const Eigen::Quaterniond& rotation) {
  if (!rotation.coeffs().allFinite() || !(rotation.norm() > 0.0))
    throw Error(ErrorCode::invalid_argument, "attachment rotation must be a finite, non-zero quaternion");
  impl_->state.now.attachment[impl_->attachment_index(segment, attachment)].target_rotation = rotation.normalized();
}

void World::set_attachment_active(std::size_t segment, std::size_t attachment, bool active) {
  impl_->state.now.attachment[impl_->attachment_index(segment, attachment)].active = active;
}

Eigen::Vector3d World::attachment_force(std::size_t segment, std::size_t attachment) const {
  return impl_->state.now.attachment[impl_->attachment_index(segment, attachment)].force;
}

Eigen::Vector3d World::attachment_moment(std::size_t segment, std::size_t attachment) const {
  return impl_->state.now.attachment[impl_->attachment_index(segment, attachment)].moment;
}

std::size_t World::bead_count() const { return impl_->model.beads.size(); }
Range World::beads(std::size_t segment) const {
  const detail::SegmentPiece& p = impl_->piece(segment);
  return {p.bead_offset, p.bead_count};
}
std::span<const double> World::bead_radii() const { return impl_->model.beads.radius; }
std::span<const std::uint32_t> World::bead_nodes() const { return impl_->model.beads.node; }
kernels::Vec3View<const double> World::bead_centres() const { return impl_->state.collision.bead_position.view(); }
std::shared_ptr<const void> World::buffers_keeper() const { return impl_; }
bool World::beads_may_collide(std::size_t a, std::size_t b) const {
  const auto& beads = impl_->model.beads;
  if (a >= beads.size() || b >= beads.size() || a == b)
    throw Error(ErrorCode::invalid_argument, fmt::format("bead indices {} and {}: need two different beads below {}", a, b,
                                                         beads.size()));
  if (beads.segment[a] != beads.segment[b]) return true;
  if (!impl_->model.contact.self) return false;
  return !beads.excluded(static_cast<std::uint32_t>(std::min(a, b)), static_cast<std::uint32_t>(std::max(a, b)));
}
const ContactReport& World::contacts() const { return impl_->state.collision.report; }
std::span<const Contact> World::contact_list() const { return impl_->state.collision.candidates; }

std::size_t World::instrument_count() const { return impl_->model.instruments.size(); }

namespace {
void check_instrument(const World::Impl& impl, std::size_t i);
}  // namespace

void World::set_instrument_pose(std::size_t instrument, const Eigen::Vector3d& tip, const Eigen::Vector3d& axis) {
  check_instrument(*impl_, instrument);
  if (!tip.allFinite() || !axis.allFinite() || !(axis.norm() > 0.0))
    throw Error(ErrorCode::invalid_argument, "instrument pose: the tip must be finite and the axis a finite, non-zero direction");
  detail::InstrumentState& s = impl_->state.instruments[instrument];
  s.scripted = false;
  detail::set_instrument_pose(s, tip, axis);
}

void World::set_instrument_grasp(std::size_t instrument, bool closed) {
  check_instrument(*impl_, instrument);
  impl_->state.instruments[instrument].scripted = false;
  impl_->state.instruments[instrument].closed = closed;
}

InstrumentReading World::instrument(std::size_t instrument) const {
  check_instrument(*impl_, instrument);
  const detail::InstrumentState& s = impl_->state.instruments[instrument];
  InstrumentReading r;
  r.tip = s.tip;
  r.axis = s.axis;
  r.closed = s.closed;
  r.grasping = s.grasping;
  if (s.grasping) {
    const detail::AttachmentState& as = impl_->state.now.attachment[s.grasp_attachment];
    std::tie(r.grasped_segment, r.grasped_node) = impl_->piece_of(s.grasp_segment, as.node);
    r.grasp_attachment = s.grasp_attachment - impl_->model.segments[s.grasp_segment].attachment_offset;
    r.grasp_target = as.target;
  }
  r.force = s.force;
  r.torque = s.torque;
  r.filtered_force = s.filtered_force;
  r.filtered_torque = s.filtered_torque;
  return r;
}

namespace {
void check_instrument(const World::Impl& impl, std::size_t i) {
  if (i >= impl.model.instruments.size())
    throw Error(ErrorCode::invalid_argument,
                fmt::format("instrument index {} out of range (the world has {})", i, impl.model.instruments.size()));
}
}  // namespace

const MeshInfo& World::mesh(std::size_t segment) const { return impl_->mesh_of(segment).info; }
std::size_t World::mesh_buffer_size() const { return impl_->model.mesh_vertex_total; }
kernels::Vec3View<const float> World::mesh_positions() const {
  const auto& p = impl_->state.mesh.position;
  return {p.x, p.y, p.z};
}
kernels::Vec3View<const float> World::mesh_normals() const {
  const auto& p = impl_->state.mesh.normal;
  return {p.x, p.y, p.z};
}
std::span<const std::array<std::uint32_t, 3>> World::mesh_triangles() const { return impl_->model.mesh_triangles; }
std::span<const std::array<std::uint32_t, 3>> World::cage_triangles(std::size_t segment) const {
  return impl_->mesh_of(segment).cage.triangles;
}
std::vector<Eigen::Vector3d> World::cage_vertices(std::size_t segment) const {
  const detail::SegmentMesh& m = impl_->mesh_of(segment);
  if (!m.enabled) return {};
  std::vector<Eigen::Vector3d> out(m.cage.offset.size());
  kernels::cage_vertices(std::span(impl_->state.mesh.ring_pose).subspan(m.ring_offset, m.cage.ring_station.size()),
                         m.cage.vertex_ring, m.cage.offset, out);
  return out;
}
std::span<const kernels::RingPose> World::ring_poses(std::size_t segment) const {
  const detail::SegmentMesh& m = impl_->mesh_of(segment);
  return std::span<const kernels::RingPose>(impl_->state.mesh.ring_pose).subspan(m.ring_offset, m.cage.ring_station.size());
}

Energy World::energy() const {
  Energy e;
  for (std::size_t s = 0; s < impl_->model.segments.size(); ++s) {
    const Energy es =
        detail::segment_energy(impl_->model, impl_->state.now.strain, impl_->state.now.position.view(), s);
    e.elastic += es.elastic;
    e.gravity += es.gravity;
  }
  return e;
}

std::vector<std::byte> World::save_checkpoint() const { return detail::save_checkpoint(impl_->model, impl_->state); }

void World::restore_checkpoint(std::span<const std::byte> bytes, const std::string& source) {
  detail::restore_checkpoint(impl_->model, impl_->state, bytes, source);
  impl_->state.frame_start.copy_from(impl_->state.now);
  impl_->profile = FrameProfile{};
  impl_->follow_rod();
}

void World::save_checkpoint_file(const std::string& path) const {
  const std::vector<std::byte> bytes = save_checkpoint();
  const std::filesystem::path target(path);
  std::filesystem::path temp = target;
  temp += ".partial";
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    if (!out) throw Error(ErrorCode::io, fmt::format("checkpoint '{}': cannot open '{}' for writing", path, temp.string()));
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out) {
      std::error_code ignored;
      std::filesystem::remove(temp, ignored);
      throw Error(ErrorCode::io, fmt::format("checkpoint '{}': writing {} bytes failed (disk full?)", path, bytes.size()));
    }
  }
  std::error_code ec;
  std::filesystem::rename(temp, target, ec);
  if (ec) throw Error(ErrorCode::io, fmt::format("checkpoint '{}': cannot rename '{}' over it: {}", path, temp.string(), ec.message()));
}

void World::restore_checkpoint_file(const std::string& path) {
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) throw Error(ErrorCode::io, fmt::format("checkpoint '{}': cannot read it: {}", path, ec.message()));
  // A checkpoint holds a few hundred bytes per node and bead: 1 GiB is far beyond any world.
  constexpr std::uintmax_t kMaxBytes = std::uintmax_t{1} << 30;
  if (size > kMaxBytes) throw Error(ErrorCode::parse, fmt::format("checkpoint '{}': {} bytes is not a checkpoint of this engine", path, size));
  std::vector<std::byte> bytes(size);
  std::ifstream in(path, std::ios::binary);
  in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(size));
  if (!in) throw Error(ErrorCode::io, fmt::format("checkpoint '{}': reading {} bytes failed", path, size));
  restore_checkpoint(bytes, path);
}

std::span<const std::uint32_t> World::cage_vertex_rings(std::size_t segment) const {
  return impl_->mesh_of(segment).cage.vertex_ring;
}

const FrameProfile& World::last_profile() const { return impl_->profile; }
std::span<const Event> World::events() const { return impl_->events; }
int World::threads() const { return impl_->scheduler.threads(); }

}  // namespace haustra
