#pragma once
// Scripted input for `haustra view --script FILE`: what a person would do (press on the organ,
// drag, release, toggle overlays, turn knobs, take screenshots), timed in simulation frames.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace haustra::view {

// One line of a script. Words (one command per line, '#' starts a comment):
//   wait N                  N simulation frames
//   press X Y               the left button goes down at window point (X, Y): grasps on the organ
//   press bead K            ... at the pixel where bead K's centre is seen (aiming at the organ)
//   move X Y [N]            the pointer moves to (X, Y) over N frames (default 1), dragging if pressed
//   move by DX DY [N]       ... by (DX, DY) pixels from where it is
//   release                 the left button goes up
//   ctrl down|up            hold Ctrl (a drag then moves along the view axis)
//   toggle beads|cage|centreline|contacts
//   colour tissue|strain|penetration
//   knob NAME VALUE         a run-time knob (see knobs.hpp), e.g. knob mode lagged
//   pause | resume | step | reset | save | restore
//   screenshot FILE.png     the window as it is drawn (panels included)
//   key NAME                a key pressed: F1 H P V 0 1 2 3 F G T B I TAB SPACE RIGHT ESC CTRL+R CTRL+O
//   open FILE               File > Open: a scene, or a surface imported first
//   record FILE.mp4         a video from the next frame on (at the physics' own time); record stop
//   zoom STEPS              the mouse wheel: > 0 closer
//   select KIND I           the inspector's selection: organ|anchors|instrument|plane|sphere|capsule|mesh I,
//                           or select none
//   edit KIND I FIELD VALUE an inspector's edit: organ I youngs_modulus|relaxation_time V,
//                           instrument I stiffness|damping|force_limit V, contact 0 coefficient V
//   quit
struct ScriptLine {
  int line = 0;
  std::string command;
  std::vector<std::string> words;  // the arguments
  double x = 0, y = 0;             // press, move
  bool at_bead = false;            // press bead K: x holds K
  bool relative = false;           // move by DX DY
  int frames = 0;                  // wait, move
};

// Reads and checks a whole script up front: a bad line fails before the window opens, naming the
// file, the line and what was expected (haustra::Error{parse}).
std::vector<ScriptLine> read_script(const std::filesystem::path& file);

}  // namespace haustra::view
