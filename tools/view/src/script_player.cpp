// Script lines turned into the same calls the mouse, the keyboard and the panels make.
#include "script_player.hpp"

#define GLFW_INCLUDE_NONE 1
#include <GLFW/glfw3.h>
#include <fmt/format.h>

#include <algorithm>

#include "actions.hpp"
#include "inspector.hpp"
#include "mouse.hpp"
#include "panels.hpp"
#include "viewer_app.hpp"

namespace haustra::view {
namespace {

// A key by the name a script gives it, pressed as the keyboard would.
void press_named_key(ViewerState& v, const std::string& name) {
  static const std::pair<const char*, std::pair<int, int>> kKeys[] = {{"F1", {GLFW_KEY_F1, 0}},
                                                                      {"H", {GLFW_KEY_H, 0}},
                                                                      {"P", {GLFW_KEY_P, 0}},
                                                                      {"V", {GLFW_KEY_V, 0}},
                                                                      {"0", {GLFW_KEY_0, 0}},
                                                                      {"1", {GLFW_KEY_1, 0}},
                                                                      {"2", {GLFW_KEY_2, 0}},
                                                                      {"3", {GLFW_KEY_3, 0}},
                                                                      {"F", {GLFW_KEY_F, 0}},
                                                                      {"G", {GLFW_KEY_G, 0}},
                                                                      {"T", {GLFW_KEY_T, 0}},
                                                                      {"K", {GLFW_KEY_K, 0}},
                                                                      {"B", {GLFW_KEY_B, 0}},
                                                                      {"TAB", {GLFW_KEY_TAB, 0}},
                                                                      {"I", {GLFW_KEY_I, 0}},
                                                                      {"SPACE", {GLFW_KEY_SPACE, 0}},
                                                                      {"RIGHT", {GLFW_KEY_RIGHT, 0}},
                                                                      {"ESC", {GLFW_KEY_ESCAPE, 0}},
                                                                      {"CTRL+R", {GLFW_KEY_R, GLFW_MOD_CONTROL}},
                                                                      {"CTRL+O", {GLFW_KEY_O, GLFW_MOD_CONTROL}}};
  for (const auto& [n, key] : kKeys)
    if (name == n) press_key(v, key.first, key.second, v.camera.width, v.camera.height);
}

}  // namespace

bool ScriptPlayer::tick(ViewerState& v) {
  ticks_ += v.video.recording() ? static_cast<std::uint64_t>(v.video_frames_per_shot) : 1;  // what was stepped
  while (next_ < lines_.size()) {
    const ScriptLine& l = lines_[next_];
    // A knob rebuilds the open scene: it waits for the scene, which opens on the simulation's thread.
    if (l.command == "knob" && v.model == nullptr) return true;
    if (!started_) {
      started_ = true;
      start_tick_ = ticks_;
      v.events.push_back(
          {"script " + l.command, v.frame, v.mouse.x, v.mouse.y, false, 0, Eigen::Vector3d::Zero(), v.camera});
      if (v.scene != nullptr) v.events.back().drawn = {v.scene->subject_lo(), v.scene->subject_hi()};
      from_x_ = v.mouse.x;
      from_y_ = v.mouse.y;
    }
    const auto elapsed = static_cast<double>(ticks_ - start_tick_);
    if (l.command == "wait") {
      if (elapsed < l.frames) return true;
    } else if (l.command == "move") {
      const double t = std::min(1.0, elapsed / l.frames);
      const double to_x = l.relative ? from_x_ + l.x : l.x, to_y = l.relative ? from_y_ + l.y : l.y;
      mouse_move(v, from_x_ + t * (to_x - from_x_), from_y_ + t * (to_y - from_y_));
      if (t < 1.0) return true;
    } else if (l.command == "press") {
      double x = l.x, y = l.y;
      if (l.at_bead) {
        const auto k = static_cast<std::size_t>(l.x);
        if (k >= v.bead_centres.size()) {
          v.note(fmt::format("script line {}: no bead {} (the scene has {})", l.line, k, v.bead_centres.size()));
          v.quit = true;
          return false;
        }
        const Eigen::Vector2d p = v.camera.project(v.bead_centres[k]);
        x = p.x();
        y = p.y();
      }
      mouse_move(v, x, y);
      mouse_press(v, Button::left, x, y);
    } else if (l.command == "release") {
      mouse_release(v, Button::left);
    } else if (l.command == "ctrl") {
      v.mouse.ctrl = l.words[0] == "down";
    } else if (l.command == "shift") {
      v.mouse.shift = l.words[0] == "down";
    } else if (l.command == "toggle") {
      const std::string& w = l.words[0];
      bool& flag = w == "beads"        ? v.draw.beads
                   : w == "cage"       ? v.draw.cage
                   : w == "centreline" ? v.draw.centreline
                   : w == "tissue"     ? v.draw.anchors
                                       : v.draw.contacts;
      flag = !flag;
      if (w == "cage") v.sim.frames().want_cages(flag);
    } else if (l.command == "colour") {
      const std::string& w = l.words[0];
      v.draw.colour = w == "strain"        ? Colouring::strain
                      : w == "penetration" ? Colouring::penetration
                                           : Colouring::tissue;
    } else if (l.command == "knob") {
      turn_knob(v, l.words[0], l.words[1]);
    } else if (l.command == "pause" || l.command == "resume") {
      v.sim.post(SetPaused{l.command == "pause"});
    } else if (l.command == "step") {
      v.sim.post(StepOnce{});
    } else if (l.command == "reset") {
      v.sim.post(Reset{});
    } else if (l.command == "save") {
      v.sim.post(SaveCheckpoint{});
    } else if (l.command == "restore") {
      v.sim.post(RestoreCheckpoint{});
    } else if (l.command == "key") {
      press_named_key(v, l.words[0]);
    } else if (l.command == "open") {
      open_path(v, l.words[0]);
    } else if (l.command == "record") {
      v.video_pending = l.words[0];  // started, or stopped ("stop"), after this frame is drawn and added
    } else if (l.command == "screenshot") {
      v.screenshot_pending = l.words[0];
      ++next_;
      started_ = false;
      return true;  // taken after this window frame is drawn
    } else if (l.command == "select") {
      v.note(select_part(v, l.words[0], static_cast<std::size_t>(l.x)));
    } else if (l.command == "edit") {
      v.note(edit_value(v, l.words[0], static_cast<std::size_t>(l.x), l.words[2], l.y));
    } else if (l.command == "zoom") {
      mouse_scroll(v, l.x);
    } else if (l.command == "quit") {
      v.quit = true;
    }
    ++next_;
    started_ = false;
  }
  return false;
}

}  // namespace haustra::view
