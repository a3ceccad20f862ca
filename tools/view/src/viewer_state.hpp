#pragma once
// What the window knows between its frames: the camera, the display options, what it copied from
// the last published frame, the force plot, the mouse's state and the log.
#include <array>
#include <chrono>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "capture.hpp"
#include "gl_scene.hpp"
#include "orbit_camera.hpp"
#include "simulation.hpp"

namespace haustra::view {

inline constexpr float kPanelWidth = 370.0f;      // the panels' column on the left, pixels
inline constexpr float kInspectorWidth = 330.0f;  // the inspector's column on the right, pixels

// A notice on screen (a stop, a slip, a tear, a scene that would not open) until it ages out.
struct ShownNotice {
  Notice notice;
  std::chrono::steady_clock::time_point since;
};

// File > Open: a folder's scenes and surfaces, and a path typed or picked.
struct OpenDialog {
  bool open = false;
  std::filesystem::path folder;
  std::string path;
  std::vector<std::string> entries;  // names in `folder`: folders (ending in /), scenes, surfaces
};

// The force on one instrument over the last seconds, one sample per frame the window saw.
struct ForcePlot {
  static constexpr std::size_t kSamples = 300;
  std::deque<float> raw, filtered;  // |F|, N
  void push(float r, float f) {
    raw.push_back(r);
    filtered.push_back(f);
    if (raw.size() > kSamples) {
      raw.pop_front();
      filtered.pop_front();
    }
  }
};

struct MouseState {
  enum class Mode { idle, grasping, cutting, orbiting, panning };
  Mode mode = Mode::idle;
  double x = 0, y = 0;  // the pointer, window coordinates
  bool ctrl = false;
  bool shift = false;  // held with the left button: the dissection tool cuts instead of grasping
  Eigen::Vector3d hit = Eigen::Vector3d::Zero();     // where the press met the bead, then where it is dragged
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  // tip − hit
  std::size_t bead = 0;
};

// What a test reads back (--record): the frames seen, the presses and releases, the plot.
struct Sample {
  std::uint64_t frame = 0;
  double time = 0.0;
  bool grasping = false;
  std::size_t node = 0;  // global index of the grasped node
  Eigen::Vector3d node_position = Eigen::Vector3d::Zero(), tip = Eigen::Vector3d::Zero();
  Eigen::Vector3d force = Eigen::Vector3d::Zero(), filtered_force = Eigen::Vector3d::Zero();
  std::size_t anchors_cut = 0;                    // anchors of connective tissue torn or cut so far
  Eigen::Vector3d end = Eigen::Vector3d::Zero();  // the first organ's last node (a cantilever's tip)
};
struct InputEvent {
  std::string kind;  // press, release, script ..., skinning gpu / cpu (the organ's skinning changed)
  std::uint64_t frame = 0;
  double x = 0, y = 0;
  bool on_organ = false;
  std::size_t bead = 0;
  Eigen::Vector3d hit = Eigen::Vector3d::Zero();
  OrbitCamera camera;
  std::array<Eigen::Vector3d, 2> drawn{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};  // the organ's box as drawn
};

struct ViewerState {
  explicit ViewerState(Simulation& s) : sim(s) {}
  Simulation& sim;
  std::string scene_name;
  double scene_dt = 1.0 / 60.0;
  int scene_frames = 60;
  OrbitCamera camera;
  bool camera_fitted = false;
  std::uint64_t fit_from_generation = 0;  // a scene opened: fit to its model, not to the one before
  DrawOptions draw;
  bool show_panels = true;

  // Copied from the last frame the window acquired.
  std::shared_ptr<const ModelInfo> model;
  std::uint64_t frame = 0;
  double time = 0.0;
  FrameProfile profile;
  std::vector<InstrumentReading> instruments;
  std::vector<Eigen::Vector3d> bead_centres;
  std::vector<Eigen::Vector3d> node_positions;
  std::size_t contact_count = 0;

  ForcePlot plot;                // the mouse's grasper
  std::vector<ForcePlot> plots;  // the scene's own instruments, in order
  MouseState mouse;
  std::vector<std::string> log;
  void note(std::string line) { log.push_back(std::move(line)); }

  bool recording = false;
  std::vector<Sample> samples;
  std::vector<InputEvent> events;
  std::vector<std::string> screenshots;
  std::string screenshot_pending;
  bool quit = false;

  // The workbench: help, File > Open, reloading when the scene file changes, captures, cameras,
  // the inspector and the notices on screen.
  bool help_open = false;
  OpenDialog open_dialog;
  bool auto_reload = true;
  struct WatchedFile {
    std::string path;
    std::filesystem::file_time_type time{};
  } watched;  // the open scene's file and its time: reloaded when the time changes
  std::chrono::steady_clock::time_point reload_checked{};
  std::string capture_folder = ".";  // where P's screenshots and V's videos go
  VideoRecorder video;
  int video_frames_per_shot = 1;  // physics frames between two video frames
  std::string video_pending;      // a script's `record FILE` or `record stop`, after the next draw
  bool follow = false;            // the camera keeps the grasped (or selected) part in the middle
  bool organ_on_gpu = false;      // the last frame's organ was skinned by the GPU (decision 0110)
  bool inspector_open = false;    // I, or View > Inspector
  bool panels_were_shown = true, inspector_was_open = false;  // as last drawn: a toggle pans the view
  std::deque<ShownNotice> notices;
  float menu_height = 0.0f;        // the main menu bar's, pixels: the panels start under it
  const GlScene* scene = nullptr;  // what is drawn: a press picks against it
};

}  // namespace haustra::view
