#pragma once
// The viewer's physics thread: owns the world, steps it at the scene's dt in real time, applies the
// window's commands between frames and publishes every frame through the engine's FramePublisher,
// so the window draws the latest completed frame and never makes a step wait. A scripted run steps
// in lockstep instead: one frame per window frame, when the window asks, so the same script gives
// the same frames however loaded the machine is.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "haustra/frame_publisher.hpp"
#include "haustra/scene.hpp"
#include "haustra/world.hpp"

namespace haustra::view {

// What one model looks like, constant until the next rebuild (reset, a knob, the rate toggle).
struct ModelInfo {
  std::uint64_t generation = 0;
  std::string scene_name, scene_path;  // the scene open (its file: what Reload reads again)
  double scene_dt = 1.0 / 60.0;
  int scene_frames = 60;
  WorldDesc desc;  // what the model was built from (the knobs start here)
  std::size_t node_count = 0;
  std::vector<Range> segment_nodes;
  std::vector<MeshInfo> meshes;                                           // per segment
  std::vector<std::array<std::uint32_t, 3>> triangles;                    // all meshes, global vertex indices
  std::vector<std::uint32_t> vertex_node;                                 // per mesh vertex: its nearest node at build
  std::vector<std::vector<std::array<std::uint32_t, 3>>> cage_triangles;  // per segment
  std::vector<std::uint32_t> bead_nodes;
  std::vector<double> bead_radii;
  std::vector<std::uint32_t> anchor_nodes;      // connective tissue: the node each anchor holds ...
  std::vector<Eigen::Vector3d> anchor_targets;  // ... and where
  std::size_t mouse = 0;                        // the instrument the mouse drives (the viewer adds it to the scene)
  // The organs as the scene names them (a chain is one organ of several pieces), for the inspector.
  struct Organ {
    std::string name;
    std::vector<std::size_t> pieces;  // segments, the first one the chain's
    SegmentDesc desc;                 // its description in force (material, damping, drag)
    std::size_t anchors = 0;          // of connective tissue
  };
  std::vector<Organ> organs;
  std::vector<std::size_t> organ_of_segment;
  // The binding as the GPU skins from it (decision 0110), copied once per model; null without a mesh.
  std::shared_ptr<const GpuSkinBinding> gpu_skin;
  double skin_reach = 0.0;  // m: the farthest a mesh vertex lies from its nearest node, at build
};

struct GraspAt {
  Eigen::Vector3d tip, axis;
};
struct MoveTip {
  Eigen::Vector3d tip;
};
struct Release {};
// The inspector's edits. An organ's stiffness and damping (its relaxation time) rebuild its rods
// only, the meshes kept; an instrument's coupling and force limit take effect at the next step.
struct EditMaterial {
  std::size_t organ;
  double youngs_modulus, relaxation_time;
};
struct EditCoupling {
  std::size_t instrument;
  double stiffness, damping, force_limit;
};
// Open another scene, or a surface to import first (its file's path; the viewer's --set apply).
struct Open {
  std::string path;
};
// The dissection tool: cut the connective tissue within `radius` of `centre` (decision 0095).
struct CutAt {
  Eigen::Vector3d centre;
  double radius;
};
struct SetPaused {
  bool paused;
};
struct StepOnce {};
struct Reset {};
struct SaveCheckpoint {};
struct RestoreCheckpoint {};
// A knob (knobs.hpp), applied to the description the world has when the command is taken, so
// several knobs turned between two frames all hold.
struct Reconfigure {
  std::string knob, value;
};
using Command = std::variant<GraspAt, MoveTip, Release, CutAt, Open, SetPaused, StepOnce, Reset, SaveCheckpoint,
                             RestoreCheckpoint, Reconfigure, EditMaterial, EditCoupling>;

// What the window shows on screen beside the log: a stop, a recovery, a grasp that let go,
// tissue torn or cut, a scene that would not open.
struct Notice {
  enum class Kind { info, warning, error };
  Kind kind = Kind::info;
  std::string text;
};

struct SimulationStats {
  double real_time_factor = 0.0;  // simulated seconds per wall second over the last half second
  double steps_per_second = 0.0;
  bool paused = false;
  bool unstable = false;    // the last step was refused; paused until a reset or restore
  std::string stop_reason;  // why, while unstable
  std::string busy;         // what the physics thread is doing that takes a while ("importing ...")
};

class Simulation {
 public:
  // Builds the world from the scene (plus the mouse's instrument); throws haustra::Error as
  // `haustra run` does. checkpoint: a file for save/restore ("" keeps checkpoints in memory).
  Simulation(const SceneDesc& scene, int threads, std::string checkpoint_file, bool start_paused, bool lockstep = false,
             std::string scene_path = {}, std::vector<std::string> sets = {});
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  void start();
  void post(Command command);
  // Lockstep (a scripted run, or while held): the commands posted so far applied, then `frames`
  // frames stepped (none while paused); returns when the last is published.
  void step_in_lockstep(int frames = 1);
  // Held, a free-running simulation steps only when the window asks (a video at the physics'
  // own time); released, it runs on the clock again.
  void hold(bool on);
  [[nodiscard]] bool held() const { return lockstep_ || held_.load(); }
  FramePublisher& frames() { return *frames_; }
  // The model of the frames acquired from now on: read it after acquire() (a rebuild waits for
  // the window to release its frame, so the two always match).
  [[nodiscard]] std::shared_ptr<const ModelInfo> model() const;
  [[nodiscard]] SimulationStats stats() const;
  std::vector<std::string> take_log();  // messages since the last call: changes, events, errors
  std::vector<Notice> take_notices();   // what deserves the screen, since the last call
  [[nodiscard]] bool went_unstable() const { return went_unstable_.load(); }

 private:
  void run();
  void run_in_lockstep();
  bool lockstep_tick(std::vector<Command>& pending);  // false: quit
  void open(const std::string& path);
  void apply(Command& command);
  void step_once();
  void rebuild(WorldDesc next, const std::string& what, bool keep_state);
  // A change to the world made between frames (an edit), with the model published again after it.
  template <typename Change>
  void edit(const std::string& what, Change&& change);
  void publish_model();
  void log(std::string message);
  void notify(Notice::Kind kind, std::string text);
  void set_busy(std::string what);

  SceneDesc scene_;
  std::string scene_path_;
  std::vector<std::string> sets_;
  std::shared_ptr<void> imported_;  // a surface opened: its scratch import, removed when replaced
  int threads_ = 0;
  std::string checkpoint_file_;
  std::vector<std::byte> checkpoint_;
  std::unique_ptr<World> world_;
  std::unique_ptr<FramePublisher> frames_;
  std::shared_ptr<const ModelInfo> model_;
  mutable std::mutex model_mutex_;
  std::uint64_t generation_ = 0;

  std::mutex command_mutex_;
  std::condition_variable command_ready_;
  std::vector<Command> commands_;
  bool quit_ = false;
  bool lockstep_ = false;
  std::uint64_t ticks_asked_ = 0, ticks_done_ = 0;  // lockstep: ticks the window asked for, and taken
  int frames_per_tick_ = 1;
  std::atomic<bool> held_{false};
  std::condition_variable tick_done_;

  mutable std::mutex log_mutex_;
  std::vector<std::string> log_;
  std::vector<Notice> notices_;
  SimulationStats stats_;
  std::size_t events_logged_ = 0;
  bool paused_ = false, unstable_ = false, park_after_step_ = false;
  std::string stop_reason_;  // the physics thread's; copied into stats_ under the lock
  std::atomic<bool> went_unstable_{false};
  Eigen::Vector3d mouse_axis_ = Eigen::Vector3d::UnitZ();
  std::thread thread_;
};

// The mouse's instrument, added to every scene the viewer opens: a thin grasper parked far above
// the scene until a press puts it on a bead.
InstrumentDesc mouse_instrument();
inline const Eigen::Vector3d kParked(0.0, 0.0, 1.0e3);

}  // namespace haustra::view
