#pragma once
// `haustra view`: the window's life from opening to exit code.
#include <cstddef>
#include <string>
#include <vector>

namespace haustra::view {

struct ViewerOptions {
  std::string scene;
  std::string source;             // what was given, when `scene` was made from it (a surface imported first)
  std::vector<std::string> sets;  // scene overrides, as `haustra run --set`
  int threads = 0;
  std::string script;      // scripted input (script.hpp)
  std::string screenshot;  // the last frame drawn, at exit
  std::string record;      // JSON of what happened (for tests)
  std::string checkpoint;  // file for Save / Restore ("" : in memory)
  int width = 1280, height = 720;
  int samples = -1;                       // multisampling: -1 picks 4 on a GPU and none on a software renderer
  std::size_t triangle_budget = 100'000;  // the organ's drawn triangles at most (DrawOptions)
  bool paused = false;
};

struct ViewerState;
// A key pressed (GLFW's key codes and modifier bits), by a person or a script; width, height: the
// framebuffer's (for a video started by V).
void press_key(ViewerState& v, int key, int mods, int width, int height);

// Exit codes as `haustra run`: 0 ok, 2 bad input (scene, script, no display), 3 the simulation
// went unstable during a scripted run.
int run_viewer(const ViewerOptions& options);

}  // namespace haustra::view
