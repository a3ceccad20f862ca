// The workbench's verbs: open and reload a scene, screenshots and videos, camera views and following.
#include "actions.hpp"

#include <fmt/format.h>

#include <cmath>
#include <numbers>
#include <system_error>

#include "haustra/error.hpp"

namespace haustra::view {
namespace {

constexpr double kReloadCheck = 0.5;  // s between two looks at the scene file's time

std::filesystem::file_time_type written(const std::string& path) {
  std::error_code ec;
  const auto t = std::filesystem::last_write_time(path, ec);
  return ec ? std::filesystem::file_time_type{} : t;
}

std::string stem_of(const ViewerState& v) { return v.scene_name.empty() ? std::string("haustra") : v.scene_name; }

}  // namespace

void open_path(ViewerState& v, const std::string& path) {
  v.note(fmt::format("opening {}", path));
  v.sim.post(Open{path});
  v.watched = {path, written(path)};
  v.camera_fitted = false;  // the new organ framed when it arrives: by the first model after this one
  v.fit_from_generation = v.model ? v.model->generation + 1 : 0;
  v.draw.highlight = {};
}

void reload(ViewerState& v) {
  if (!v.model || v.model->scene_path.empty()) {
    v.note("reload: this scene has no file");
    return;
  }
  open_path(v, v.model->scene_path);
}

bool scene_file_changed(ViewerState& v) {
  const auto now = std::chrono::steady_clock::now();
  if (!v.model || v.model->scene_path.empty() || now - v.reload_checked < std::chrono::duration<double>(kReloadCheck))
    return false;
  v.reload_checked = now;
  // Only the file of the scene shown, against its own time: a scene opened but not yet built (the
  // model still the one before), or one opened by another path, is watched from now on, not reloaded.
  const auto t = written(v.model->scene_path);
  if (v.watched.path != v.model->scene_path) {
    v.watched = {v.model->scene_path, t};
    return false;
  }
  if (t == v.watched.time) return false;
  v.watched.time = t;
  return true;
}

std::string take_screenshot(ViewerState& v, const std::string& path) {
  const std::string file =
      path.empty()
          ? (std::filesystem::path(v.capture_folder) / fmt::format("{}-frame{}.png", stem_of(v), v.frame)).string()
          : path;
  v.screenshot_pending = file;
  return file;
}

std::string toggle_video(ViewerState& v, int width, int height, const std::string& path) {
  if (v.video.recording()) {
    const std::string file = v.video.path();
    try {
      const std::size_t frames = v.video.stop();
      v.sim.hold(false);
      return fmt::format("video {}: {} frames", file, frames);
    } catch (const Error& e) {
      v.sim.hold(false);
      return e.what();
    }
  }
  // A frame of video every k physics frames, about 30 a second of simulated time.
  const double dt = v.model ? v.model->desc.dt : v.scene_dt;
  v.video_frames_per_shot = std::max(1, static_cast<int>(std::lround(1.0 / (30.0 * dt))));
  const double fps = 1.0 / (v.video_frames_per_shot * dt);
  const std::string file =
      path.empty()
          ? (std::filesystem::path(v.capture_folder) / fmt::format("{}-frame{}.mp4", stem_of(v), v.frame)).string()
          : path;
  try {
    v.video.start(file, width, height, fps);
    v.sim.hold(true);
    return fmt::format("recording {} at {:.3g} frames a second of simulated time ({} physics frames each)", file, fps,
                       v.video_frames_per_shot);
  } catch (const Error& e) {
    return e.what();
  }
}

void video_frame(ViewerState& v, int width, int height) {
  if (!v.video.recording()) return;
  if (!v.video.add(width, height)) v.note(toggle_video(v, width, height) + " (the window's size changed)");
}

void set_view(ViewerState& v, View view) {
  switch (view) {
    case View::front: v.camera.azimuth = -0.5 * std::numbers::pi, v.camera.elevation = 0.05; break;
    case View::top: v.camera.azimuth = -0.5 * std::numbers::pi, v.camera.elevation = 1.5; break;
    case View::side: v.camera.azimuth = 0.0, v.camera.elevation = 0.05; break;
    case View::standard: v.camera.azimuth = -1.0, v.camera.elevation = 0.45; break;
  }
  v.camera_fitted = false;
}

void keep_between_panels(ViewerState& v) {
  // Half of what a column takes or gives back: what was in the middle of the view stays there.
  if (v.show_panels != v.panels_were_shown) v.camera.pan(v.show_panels ? 0.5 * kPanelWidth : -0.5 * kPanelWidth, 0.0);
  if (v.inspector_open != v.inspector_was_open)
    v.camera.pan(v.inspector_open ? -0.5 * kInspectorWidth : 0.5 * kInspectorWidth, 0.0);
  v.panels_were_shown = v.show_panels;
  v.inspector_was_open = v.inspector_open;
}

void keep_above_planes(ViewerState& v) {
  if (!v.model) return;
  // Floors only (planes facing up against gravity): a wall may stand between the eye and the organ,
  // drawn from its free side only, so it never hides it.
  const Eigen::Vector3d up = v.model->desc.gravity.norm() > 0.0 ? Eigen::Vector3d(-v.model->desc.gravity.normalized())
                                                                : Eigen::Vector3d::UnitZ();
  for (const PlaneDesc& p : v.model->desc.environment.planes) {
    const Eigen::Vector3d n = p.normal.normalized();
    if (n.dot(up) < 0.7) continue;
    for (int step = 0; step < 300 && (v.camera.eye() - p.point).dot(n) < 1e-3 * v.camera.distance; ++step)
      v.camera.elevation = std::min(1.5, v.camera.elevation + 0.01);
  }
}

void follow(ViewerState& v) {
  if (!v.follow || !v.model) return;
  const auto on = [&](std::size_t segment, std::size_t node) -> std::optional<Eigen::Vector3d> {
    if (segment >= v.model->segment_nodes.size() || v.node_positions.empty()) return std::nullopt;
    const std::size_t k = v.model->segment_nodes[segment].offset + node;
    return k < v.node_positions.size() ? std::optional(v.node_positions[k]) : std::nullopt;
  };
  std::optional<Eigen::Vector3d> target;
  for (const InstrumentReading& r : v.instruments)
    if (r.grasping && !target) target = on(r.grasped_segment, r.grasped_node);
  const Highlight& h = v.draw.highlight;
  if (!target && h.kind == Highlight::Kind::organ && h.index < v.model->organs.size()) {
    const auto& pieces = v.model->organs[h.index].pieces;  // the middle of the organ
    const std::size_t piece = pieces[pieces.size() / 2];
    target = on(piece, v.model->segment_nodes[piece].count / 2);
  }
  if (!target && h.kind == Highlight::Kind::instrument && h.index < v.instruments.size())
    target = v.instruments[h.index].tip;
  if (target) v.camera.target += 0.2 * (*target - v.camera.target);  // eased: no jumps
}

}  // namespace haustra::view
