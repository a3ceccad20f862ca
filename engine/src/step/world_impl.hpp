#pragma once
// World::Impl: a world's model, state, scheduler, profile and events — what the API's accessors
// (world.cpp), the frame pipeline (frame.cpp), checkpoints and rebuilding share.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <exception>
#include <memory>
#include <source_location>
#include <string_view>
#include <utility>
#include <vector>

#include "haustra/error.hpp"
#include "haustra/world.hpp"
#include "model/world_model.hpp"
#include "sched/scheduler.hpp"
#include "state/world_state.hpp"
#include "step/anchors.hpp"
#include "step/mesh_stages.hpp"
#include "step/rod_stages.hpp"
#include "step/sleep.hpp"

namespace haustra {

namespace detail {
// The robust mode's first calm spell, in frames: a rung climbed after a long calm is kept this
// long, then halved; each rung needed again soon doubles it up to solver.calm_frames (decision 0109).
constexpr int kFirstCalmSpell = 8;
inline int first_calm_spell(int calm_frames) { return std::min(kFirstCalmSpell, calm_frames); }
}  // namespace detail

// The API call a range check ran for, as a host wrote it ("World::segment"): the checks below take
// their caller's source location by default, so every accessor's error names it.
std::string_view api_call_name(const std::source_location& where);

struct World::Impl {
  WorldDesc desc;  // what the model was built from: adding or removing a segment rebuilds it
  detail::WorldModel model;
  detail::WorldState state;
  detail::Scheduler scheduler;
  FrameProfile profile;
  std::vector<Event> events;             // waiting to be taken (World::take_events), at most kMaxEvents
  std::uint64_t events_dropped = 0;      // lost since the last take: the queue was full
  std::vector<std::size_t> slipped;      // instruments whose grasp slipped this frame (capacity: all of them)
  std::vector<detail::TornAnchor> torn;  // anchors torn or cut this frame (capacity: all of them)
  std::vector<detail::GuardResult> guard;
  // A rung of the robust mode's ladder: how a frame is attempted.
  struct Rung {
    int substeps;
    bool newton;
  };
  Rung base{1, false};  // what the scene asked for; the rung it runs now is in the state
  bool any_free_base = false;
  bool any_constraints = false;
  bool any_proxy = false;  // an instrument is a proxy (decision 0096)
  // The last frame's dt while frame_start still holds that frame's start (World::node_velocities); 0
  // before the first frame and after a pose or a restore.
  double motion_dt = 0.0;

  Impl(WorldDesc d, detail::WorldModel m);

  // Wakes every sleeping rod when the host's change it guards succeeds (decision 0119); a refused
  // change leaves the world as it was. Holds the World's pointer: a change may rebuild the Impl.
  class WakeOnChange {
   public:
    explicit WakeOnChange(const std::shared_ptr<Impl>& impl) : impl_(impl), exceptions_(std::uncaught_exceptions()) {}
    WakeOnChange(const WakeOnChange&) = delete;
    WakeOnChange& operator=(const WakeOnChange&) = delete;
    ~WakeOnChange() {
      if (std::uncaught_exceptions() == exceptions_) detail::wake_all(impl_->state);
    }

   private:
    const std::shared_ptr<Impl>& impl_;
    int exceptions_;
  };
  friend class World;  // World::step (frame.cpp) climbs the ladder with the frame's private verbs
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;

  // frame.cpp: one attempt at a frame (World::step climbs the robust mode's ladder with it), the
  // meshes after it.
  std::size_t run_frame(int n, bool newton, bool chord);
  void follow_rod();
  // The world's own mesh (or its rings alone) at the current frame when a reader asks (decision 0060).
  void bring_mesh_up_to_date(bool rings_only = false);
  // A reader's mesh from published ring poses; reads only the model (any thread, while stepping).
  void mesh_from_rings(const detail::MeshTarget& target) const;
  bool rings_stale = false, mesh_stale = false;
  // The binding as a host's GPU reads it (World::gpu_skin_binding), made on first ask: a new model
  // (a rebuild, a restore) comes with a new Impl, so it is never stale.
  mutable std::unique_ptr<GpuSkinBinding> gpu_skin;
  [[nodiscard]] GpuSkinBinding make_gpu_skin() const;
  std::uint64_t late_frames =
      0;  // frames over the model's frame_budget since the world was created  // the world's own mesh is behind its rod

  // The API's segment (a piece of a chain, or the whole rod) that holds node `node` of rod `rod`,
  // and the node's index in it; a joint node counts as the later piece's base.
  [[nodiscard]] std::pair<std::size_t, std::size_t> piece_of(std::size_t rod, std::size_t node) const;

  // The API's segment `segment` (a piece of the model), or an error naming the range.
  [[nodiscard]] const detail::SegmentPiece& piece(
      std::size_t segment, const std::source_location& where = std::source_location::current()) const {
    if (segment >= model.pieces.size())
      throw Error(ErrorCode::invalid_argument, fmt::format("{}: segment index {} out of range (the world has {})",
                                                           api_call_name(where), segment, model.pieces.size()));
    return model.pieces[segment];
  }

  [[nodiscard]] const detail::SegmentMesh& mesh_of(
      std::size_t segment, const std::source_location& where = std::source_location::current()) const {
    (void)piece(segment, where);  // the range check
    return model.meshes_of[segment];
  }

  void check_instrument(std::size_t i, const std::source_location& where = std::source_location::current()) const {
    if (i >= model.instruments.size())
      throw Error(ErrorCode::invalid_argument, fmt::format("{}: instrument index {} out of range (the world has {})",
                                                           api_call_name(where), i, model.instruments.size()));
  }

  void check_node(std::size_t node, const std::source_location& where = std::source_location::current()) const {
    if (node >= model.node_total)
      throw Error(ErrorCode::invalid_argument, fmt::format("{}: node index {} out of range (the world has {} nodes)",
                                                           api_call_name(where), node, model.node_total));
  }

  // Attachments belong to rods: every piece of a chain addresses its chain's attachments.
  [[nodiscard]] std::size_t attachment_index(
      std::size_t segment, std::size_t attachment,
      const std::source_location& where = std::source_location::current()) const {
    const auto& seg = model.segments[piece(segment, where).rod];
    if (attachment >= seg.attachments.size())
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("{}: segment '{}' has {} attachments, asked for index {}", api_call_name(where),
                              model.pieces[segment].info.name, seg.attachments.size(), attachment));
    return seg.attachment_offset + attachment;
  }

 private:
  using Clock = std::chrono::steady_clock;
  // The first failure of a frame the robust mode redid: where, what, on which rung.
  struct Failure {
    std::size_t segment;
    detail::GuardResult guard;
    Rung rung;
    [[nodiscard]] bool happened(const detail::WorldModel& m) const { return segment < m.segments.size(); }
  };

  // frame.cpp: the frame's verbs, in pipeline order.
  void keep_rung(const Failure& first, const Rung& rung);
  void lagged_iteration(const detail::SubstepParameters& p);
  void move_instruments();
  void snapshot(bool newton);
  double proxies(const detail::SubstepParameters& p);
  void collide();
  void contacts();
  void loads(const detail::SubstepParameters& p);
  void backward_sweep();
  [[nodiscard]] bool all_converged(bool past_fixed_count);
  void filter();
  void contraction(const detail::SubstepParameters& p);
  [[nodiscard]] std::size_t guard_segments(const detail::SubstepParameters& p);
  void report();
  void finish_frame(const Rung& kept, Clock::time_point t0);
  void collect_newton_counts();
  [[noreturn]] void stop_unstable(std::size_t failed, const Rung& rung, Clock::time_point t0);
  [[nodiscard]] bool can_escalate(const Rung& r) const;
  [[nodiscard]] Rung escalate(const Rung& r) const;
  // A stage's own time and calls, added to the profile when the clock stops or leaves scope
  // (decision 0044). A scope, not a wrapper: the path from the C API to the sweep has no call of its own.
  class StageClock {
   public:
    StageClock(FrameProfile& profile, Stage stage) : profile_(profile), stage_(stage), t0_(Clock::now()) {}
    StageClock(const StageClock&) = delete;
    StageClock& operator=(const StageClock&) = delete;
    ~StageClock() { stop(); }
    // This stage ends and `next` starts now.
    void next(Stage next) {
      stop();
      stage_ = next;
      running_ = true;
      t0_ = Clock::now();
    }
    void stop() {
      if (!running_) return;
      const auto i = static_cast<std::size_t>(stage_);
      profile_.seconds[i] += std::chrono::duration<double>(Clock::now() - t0_).count();
      profile_.calls[i] += 1;
      running_ = false;
    }

   private:
    FrameProfile& profile_;
    Stage stage_;
    Clock::time_point t0_;
    bool running_ = true;
  };
  // A stage per segment over the scheduler, or per segment still iterating in this substep.
  template <class F>
  void per_segment(Stage stage, F&& fn);
  template <class F>
  void per_active_segment(Stage stage, F&& fn);

  // frame_events.cpp: the events a frame records and their text.
  char* describe(Event& e, char* it, std::size_t s, const detail::GuardResult& g, int n) const;
  [[nodiscard]] Event make_event(Event::Kind kind, std::size_t s, const detail::GuardResult& g, int n) const;
  [[nodiscard]] Event unstable_event(std::size_t failed, const detail::GuardResult& g, const Rung& rung) const;
  [[nodiscard]] Event recovered_event(const Failure& first, const Rung& rung) const;
  [[nodiscard]] Event slipped_event(std::size_t instrument) const;
  [[nodiscard]] Event anchors_event(Event::Kind kind, std::size_t first, std::size_t count, double largest) const;

 public:
  // Torn or cut anchors (in anchor order) as events, one per range.
  void record_anchors(Event::Kind kind, std::span<const detail::TornAnchor> anchors);
  // Cuts the anchors whose tissue passes within `radius` of `centre`, with events; how many.
  std::size_t cut_tissue(const Eigen::Vector3d& centre, double radius);

 private:
  void record(const Event& e);
  void reserve_events();
};

}  // namespace haustra
