#pragma once
// Plays a script against the window, one step per window frame, timed by the simulation's frames.
#include <vector>

#include "script.hpp"
#include "viewer_state.hpp"

namespace haustra::view {

class ScriptPlayer {
 public:
  explicit ScriptPlayer(std::vector<ScriptLine> lines) : lines_(std::move(lines)) {}
  // Runs what is due at the window's current frame; returns false once the script has ended.
  bool tick(ViewerState& v);

 private:
  std::vector<ScriptLine> lines_;
  std::size_t next_ = 0;
  bool started_ = false;  // the current line has begun (wait, move)
  // Physics frames asked for: a scripted run steps the physics once per window frame (lockstep),
  // or a video's frames per shot while it records, unless paused — a wait while paused still ends.
  std::uint64_t ticks_ = 0, start_tick_ = 0;
  double from_x_ = 0, from_y_ = 0;  // a move's start
};

}  // namespace haustra::view
