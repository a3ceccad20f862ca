// The physics thread: real-time pacing, commands between frames, rebuilds that keep the state,
// publishing, and the log of what changed.
#include "simulation.hpp"

#include <fmt/format.h>

#include <chrono>
#include <filesystem>

#include "haustra/error.hpp"
#include "haustra/import/scratch_import.hpp"
#include "haustra/render/render.hpp"
#include "knobs.hpp"

namespace haustra::view {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

}  // namespace

InstrumentDesc mouse_instrument() {
  InstrumentDesc d;
  d.name = "mouse";
  d.radius = 0.002;
  d.length = 0.08;
  d.grasp_reach = 0.01;
  d.force_filter = 0.05;  // s: the haptic loop's usual low-pass
  d.tip = kParked;
  return d;
}

Simulation::Simulation(const SceneDesc& scene, int threads, std::string checkpoint_file, bool start_paused,
                       bool lockstep, std::string scene_path, std::vector<std::string> sets)
    : scene_(scene),
      scene_path_(std::move(scene_path)),
      sets_(std::move(sets)),
      threads_(threads),
      checkpoint_file_(std::move(checkpoint_file)),
      lockstep_(lockstep),
      paused_(start_paused) {
  scene_.world.threads = threads_;
  scene_.world.instruments.push_back(mouse_instrument());
  world_ = create_world(scene_);
  frames_ = std::make_unique<FramePublisher>(*world_, /*details=*/true, /*cages=*/false);
  publish_model();
  stats_.paused = paused_;
}

Simulation::~Simulation() {
  {
    std::lock_guard lock(command_mutex_);
    quit_ = true;
  }
  command_ready_.notify_all();
  tick_done_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void Simulation::start() {
  thread_ = std::thread([this] { lockstep_ ? run_in_lockstep() : run(); });
}

void Simulation::step_in_lockstep(int frames) {
  std::unique_lock lock(command_mutex_);
  frames_per_tick_ = std::max(1, frames);
  const std::uint64_t target = ++ticks_asked_;
  command_ready_.notify_all();
  tick_done_.wait(lock, [&] { return quit_ || ticks_done_ >= target; });
}

void Simulation::hold(bool on) {
  {
    std::lock_guard lock(command_mutex_);
    held_ = on;
    ticks_done_ = ticks_asked_;  // a tick asked before the change is not owed after it
  }
  command_ready_.notify_all();
}

// One tick the window asked for: its commands, then its frames (none while paused).
bool Simulation::lockstep_tick(std::vector<Command>& pending) {
  std::uint64_t asked = 0;
  int frames = 1;
  {
    std::unique_lock lock(command_mutex_);
    command_ready_.wait(lock, [&] { return quit_ || ticks_asked_ > ticks_done_ || !(lockstep_ || held_); });
    if (quit_) return false;
    if (!(lockstep_ || held_)) return true;  // released: back to the clock
    pending.swap(commands_);
    asked = ticks_asked_;
    frames = frames_per_tick_;
  }
  for (Command& c : pending) apply(c);
  pending.clear();
  for (int f = 0; f < frames && !paused_ && !unstable_; ++f) step_once();
  {
    std::lock_guard lock(log_mutex_);
    stats_.paused = paused_;
    stats_.unstable = unstable_;
    stats_.stop_reason = unstable_ ? stop_reason_ : std::string();
    stats_.real_time_factor = 0.0;  // stepped by the window, not the clock
  }
  {
    std::lock_guard lock(command_mutex_);
    ticks_done_ = asked;
  }
  tick_done_.notify_all();
  return true;
}

void Simulation::run_in_lockstep() {
  std::vector<Command> pending;
  while (lockstep_tick(pending)) {
  }
}

void Simulation::post(Command command) {
  {
    std::lock_guard lock(command_mutex_);
    commands_.push_back(std::move(command));
  }
  command_ready_.notify_all();
}

std::shared_ptr<const ModelInfo> Simulation::model() const {
  std::lock_guard lock(model_mutex_);
  return model_;
}

SimulationStats Simulation::stats() const {
  std::lock_guard lock(log_mutex_);
  return stats_;
}

std::vector<std::string> Simulation::take_log() {
  std::lock_guard lock(log_mutex_);
  return std::exchange(log_, {});
}

std::vector<Notice> Simulation::take_notices() {
  std::lock_guard lock(log_mutex_);
  return std::exchange(notices_, {});
}

void Simulation::notify(Notice::Kind kind, std::string text) {
  std::lock_guard lock(log_mutex_);
  notices_.push_back({kind, std::move(text)});
}

void Simulation::set_busy(std::string what) {
  std::lock_guard lock(log_mutex_);
  stats_.busy = std::move(what);
}

void Simulation::log(std::string message) {
  std::lock_guard lock(log_mutex_);
  log_.push_back(fmt::format("[{:.3f} s] {}", world_->time(), message));
}

void Simulation::publish_model() {
  auto info = std::make_shared<ModelInfo>();
  const World& w = *world_;
  info->generation = ++generation_;
  info->scene_name = scene_.name;
  info->scene_path = scene_path_;
  info->scene_dt = scene_.world.dt;
  info->scene_frames = scene_.frames;
  info->desc = w.desc();
  info->node_count = w.node_count();
  for (std::size_t s = 0; s < w.segment_count(); ++s) {
    info->segment_nodes.push_back(w.segment(s).nodes);
    info->meshes.push_back(w.mesh(s));
    const auto cage = w.mesh(s).enabled ? w.cage_triangles(s) : std::span<const std::array<std::uint32_t, 3>>{};
    info->cage_triangles.emplace_back(cage.begin(), cage.end());
  }
  const auto tris = w.mesh_triangles();
  info->triangles.assign(tris.begin(), tris.end());
  info->vertex_node = render::nearest_nodes(w);
  if (w.mesh_buffer_size() > 0) info->gpu_skin = std::make_shared<GpuSkinBinding>(w.gpu_skin_binding());
  const auto skin = w.mesh_positions();
  const auto node_at = w.node_positions();
  for (std::size_t v = 0; v < info->vertex_node.size() && v < skin.size(); ++v)
    info->skin_reach =
        std::max(info->skin_reach,
                 (Eigen::Vector3d(skin.x[v], skin.y[v], skin.z[v]) - node_at.get(info->vertex_node[v])).norm());
  info->bead_nodes.assign(w.bead_nodes().begin(), w.bead_nodes().end());
  info->bead_radii.assign(w.bead_radii().begin(), w.bead_radii().end());
  info->anchor_nodes.assign(w.anchor_nodes().begin(), w.anchor_nodes().end());
  info->anchor_targets.assign(w.anchor_targets().begin(), w.anchor_targets().end());
  info->mouse = w.instrument_count() - 1;
  info->organ_of_segment.assign(w.segment_count(), 0);
  for (std::size_t s = 0; s < w.segment_count(); ++s) {
    if (w.chain_of(s) == s) {
      ModelInfo::Organ organ;
      organ.desc = w.segment_desc(s);
      organ.name = organ.desc.name;
      info->organs.push_back(std::move(organ));
    }
    info->organ_of_segment[s] = info->organs.size() - 1;
    ModelInfo::Organ& organ = info->organs.back();
    organ.pieces.push_back(s);
    const Range nodes = w.segment(s).nodes;
    for (std::uint32_t k : info->anchor_nodes)
      if (k >= nodes.offset + (s == organ.pieces.front() ? 0 : 1) && k < nodes.offset + nodes.count) ++organ.anchors;
  }
  std::lock_guard lock(model_mutex_);
  model_ = std::move(info);
}

template <typename Change>
void Simulation::edit(const std::string& what, Change&& change) {
  const auto t0 = Clock::now();
  set_busy(fmt::format("{}...", what));
  try {
    frames_->resize(
        [&]() -> const World& {
          change(*world_);
          publish_model();
          return *world_;
        },
        /*wait_for_reader=*/true);
    log(fmt::format("{} ({:.1f} ms)", what, 1e3 * seconds_since(t0)));
    notify(Notice::Kind::info, what);
  } catch (const Error& e) {
    log(fmt::format("{}: refused, the world is as it was: {}", what, e.what()));
    notify(Notice::Kind::error, fmt::format("{}: refused: {}", what, e.what()));
  }
  set_busy({});
}

void Simulation::rebuild(WorldDesc next, const std::string& what, bool keep_state) {
  const auto t0 = Clock::now();
  set_busy(fmt::format("{}: rebuilding the model...", what));
  try {
    // The window holds a frame for its upload only: wait for it, then swap the world and the
    // model together, under the publisher's lock.
    frames_->resize(
        [&]() -> const World& {
          if (keep_state) {
            world_->reconfigure(std::move(next));
          } else {
            SceneDesc fresh = scene_;
            fresh.world = std::move(next);
            world_ = create_world(fresh);
          }
          publish_model();
          return *world_;
        },
        /*wait_for_reader=*/true);
    unstable_ = false;
    log(fmt::format("{}: model rebuilt in {:.1f} ms{}", what, 1e3 * seconds_since(t0),
                    keep_state ? " (state kept)" : " (back to frame 0)"));
  } catch (const Error& e) {
    log(fmt::format("{}: refused, the world is as it was: {}", what, e.what()));
    notify(Notice::Kind::error, fmt::format("{}: refused: {}", what, e.what()));
  }
  set_busy({});
}

// Another scene (or a surface, imported first into a folder of its own): a new world, frame 0.
// What fails to load leaves the world as it was, with the reason on screen.
void Simulation::open(const std::string& path) {
  const auto t0 = Clock::now();
  try {
    std::shared_ptr<import::ScratchImport> imported;
    std::string scene_file = path;
    if (import::is_surface(path)) {
      set_busy(fmt::format("importing {}...", std::filesystem::path(path).filename().string()));
      imported = std::make_shared<import::ScratchImport>(path, [](std::string_view) {});
      scene_file = imported->scene().string();
    }
    set_busy(fmt::format("building {}...", std::filesystem::path(path).filename().string()));
    SceneDesc next = load_scene(scene_file, sets_);
    next.world.threads = threads_;
    next.world.instruments.push_back(mouse_instrument());
    frames_->resize(
        [&]() -> const World& {
          world_ = create_world(next);
          scene_ = std::move(next);
          scene_path_ = path;
          imported_ = std::move(imported);
          events_logged_ = 0;
          publish_model();
          return *world_;
        },
        /*wait_for_reader=*/true);
    unstable_ = false;
    log(fmt::format("opened {} in {:.1f} s", path, seconds_since(t0)));
  } catch (const std::exception& e) {
    log(fmt::format("open {}: refused, the scene is as it was: {}", path, e.what()));
    notify(Notice::Kind::error, fmt::format("could not open {}: {}", path, e.what()));
  }
  set_busy({});
}

void Simulation::apply(Command& command) {
  World& w = *world_;
  const std::size_t mouse = w.instrument_count() - 1;
  std::visit(
      [&](auto& c) {
        using T = std::decay_t<decltype(c)>;
        if constexpr (std::is_same_v<T, GraspAt>) {
          mouse_axis_ = c.axis;
          w.set_instrument_pose(mouse, c.tip, c.axis);
          w.set_instrument_grasp(mouse, true);
          park_after_step_ = false;
        } else if constexpr (std::is_same_v<T, MoveTip>) {
          w.set_instrument_pose(mouse, c.tip, mouse_axis_);
        } else if constexpr (std::is_same_v<T, Release>) {
          w.set_instrument_grasp(mouse, false);
          park_after_step_ = true;
        } else if constexpr (std::is_same_v<T, Open>) {
          open(c.path);
        } else if constexpr (std::is_same_v<T, CutAt>) {
          const std::size_t cut = w.cut_tissue(c.centre, c.radius);
          if (cut > 0) log(fmt::format("cut {} anchor{} of connective tissue", cut, cut == 1 ? "" : "s"));
        } else if constexpr (std::is_same_v<T, SetPaused>) {
          if (!c.paused && unstable_) {  // Run after a stop: say why it does not
            log(fmt::format("cannot run: {} (reset, restore a checkpoint or change a knob)", stop_reason_));
          } else {
            paused_ = c.paused;
            log(paused_ ? "paused" : "running");
          }
        } else if constexpr (std::is_same_v<T, StepOnce>) {
          paused_ = true;
          step_once();
        } else if constexpr (std::is_same_v<T, Reset>) {
          rebuild(world_->desc(), "reset", false);
        } else if constexpr (std::is_same_v<T, SaveCheckpoint>) {
          checkpoint_ = w.save_checkpoint();
          if (!checkpoint_file_.empty()) w.save_checkpoint_file(checkpoint_file_);
          log(fmt::format("checkpoint saved at frame {} ({} kB{})", w.frame(), checkpoint_.size() / 1024,
                          checkpoint_file_.empty() ? ", in memory" : ", " + checkpoint_file_));
        } else if constexpr (std::is_same_v<T, RestoreCheckpoint>) {
          try {
            if (!checkpoint_file_.empty())
              w.restore_checkpoint_file(checkpoint_file_);
            else if (checkpoint_.empty())
              throw Error(ErrorCode::invalid_argument, "no checkpoint saved yet");
            else
              w.restore_checkpoint(checkpoint_, "the checkpoint saved in this session");
            unstable_ = false;
            frames_->publish(w);
            log(fmt::format("checkpoint restored: frame {}", w.frame()));
          } catch (const Error& e) {
            log(fmt::format("restore refused, the world is as it was: {}", e.what()));
          }
        } else if constexpr (std::is_same_v<T, EditMaterial>) {
          const auto model = this->model();
          if (c.organ >= model->organs.size()) return;
          const ModelInfo::Organ& organ = model->organs[c.organ];
          MaterialDesc material = organ.desc.material;
          material.youngs_modulus = c.youngs_modulus;
          edit(fmt::format("{}: E {:.4g} -> {:.4g} Pa, relaxation {:.3g} -> {:.3g} s (rods rebuilt, meshes kept)",
                           organ.name, organ.desc.material.youngs_modulus, c.youngs_modulus, organ.desc.relaxation_time,
                           c.relaxation_time),
               [&](World& world) { world.set_material(organ.pieces.front(), material, c.relaxation_time); });
        } else if constexpr (std::is_same_v<T, EditCoupling>) {
          if (c.instrument >= w.instrument_count()) return;
          const InstrumentDesc& was = w.desc().instruments[c.instrument];
          edit(fmt::format("{}: coupling {:.4g} -> {:.4g} N/m, {:.3g} -> {:.3g} N s/m, limit {:.3g} -> {:.3g} N",
                           was.name, was.coupling_stiffness, c.stiffness, was.coupling_damping, c.damping,
                           was.force_limit, c.force_limit),
               [&](World& world) {
                 world.set_instrument_coupling(c.instrument, c.stiffness, c.damping, c.force_limit);
               });
        } else if constexpr (std::is_same_v<T, Reconfigure>) {
          try {
            KnobChange change = set_knob(world_->desc(), c.knob, c.value, scene_.world.dt);
            rebuild(std::move(change.desc), change.what, true);
          } catch (const Error& e) {
            log(e.what());
          }
        }
      },
      command);
}

void Simulation::step_once() {
  World& w = *world_;
  try {
    w.step();
  } catch (const Error& e) {
    if (e.code() != ErrorCode::unstable) throw;
    unstable_ = true;
    paused_ = true;
    went_unstable_ = true;
    stop_reason_ = e.what();
    log(fmt::format("stopped: {} (reset, restore a checkpoint or change a knob)", e.what()));
    notify(Notice::Kind::error, fmt::format("stopped: {}", e.what()));
  }
  if (park_after_step_) {
    w.set_instrument_pose(w.instrument_count() - 1, kParked, Eigen::Vector3d::UnitZ());
    park_after_step_ = false;
  }
  const auto events = w.events();
  for (; events_logged_ < events.size(); ++events_logged_) {
    const Event& e = events[events_logged_];
    log(std::string(e.message()));
    if (e.kind != Event::Kind::unstable)  // a stop has its own notice, with what to do
      notify(e.kind == Event::Kind::recovered ? Notice::Kind::info : Notice::Kind::warning, std::string(e.message()));
  }
  frames_->publish(w);
}

void Simulation::run() {
  auto clock_start = Clock::now();
  double sim_start = world_->time();
  auto window_start = Clock::now();
  double window_sim = world_->time();
  int window_steps = 0;
  std::vector<Command> pending;
  for (;;) {
    if (held_) {  // the window drives the steps (a video at the physics' own time)
      if (!lockstep_tick(pending)) return;
      clock_start = window_start = Clock::now();
      sim_start = window_sim = world_->time();
      continue;
    }
    {
      std::unique_lock lock(command_mutex_);
      if (paused_ || unstable_)
        command_ready_.wait_for(lock, std::chrono::milliseconds(20), [&] { return quit_ || !commands_.empty(); });
      if (quit_) return;
      pending.swap(commands_);
    }
    for (Command& c : pending) apply(c);
    if (!pending.empty() || paused_ || unstable_) {  // the clock and the real-time window restart after any change
      clock_start = window_start = Clock::now();
      sim_start = window_sim = world_->time();
      window_steps = 0;
    }
    pending.clear();
    {
      std::lock_guard lock(log_mutex_);
      stats_.paused = paused_;
      stats_.unstable = unstable_;
      stats_.stop_reason = unstable_ ? stop_reason_ : std::string();
    }
    if (paused_ || unstable_) continue;
    const double ahead = (world_->time() - sim_start) - seconds_since(clock_start);
    if (ahead > 0.0) {  // ahead of the wall clock: wait (commands wake us)
      std::unique_lock lock(command_mutex_);
      command_ready_.wait_for(lock, std::chrono::duration<double>(std::min(ahead, 0.002)),
                              [&] { return quit_ || !commands_.empty(); });
      continue;
    }
    if (ahead < -0.25) {  // cannot keep up: run flat out, the real-time factor says so
      clock_start = Clock::now();
      sim_start = world_->time();
    }
    step_once();
    ++window_steps;
    const double elapsed = seconds_since(window_start);
    if (elapsed >= 0.5) {
      std::lock_guard lock(log_mutex_);
      stats_.real_time_factor = (world_->time() - window_sim) / elapsed;
      stats_.steps_per_second = window_steps / elapsed;
      window_start = Clock::now();
      window_sim = world_->time();
      window_steps = 0;
    }
  }
}

}  // namespace haustra::view
