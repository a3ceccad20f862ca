// haustra-view: the interactive viewer (`haustra view SCENE`). A tool over the engine: the
// engine library and the C API link nothing of GLFW, OpenGL or ImGui.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <optional>

#include "haustra/error.hpp"
#include "haustra/import/scratch_import.hpp"
#include "viewer_app.hpp"

int main(int argc, char** argv) {
  haustra::view::ViewerOptions o;
  CLI::App app{"haustra view: grasp the organ with the mouse and watch every stage"};
  app.add_option("scene", o.scene, "scene file (TOML), or a surface to import first with the defaults")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--set", o.sets, "override a scene value, e.g. --set segment.nodes=333")->take_all();
  app.add_option("--threads", o.threads, "physics worker threads (0: all)");
  app.add_option("--script", o.script, "scripted input (press, move, release, toggle, knob, screenshot, ...)")
      ->check(CLI::ExistingFile);
  app.add_option("--screenshot", o.screenshot,
                 "PNG of the window at exit (without --script: after the scene's frames, then exit)");
  app.add_option("--record", o.record, "JSON of the frames seen, presses, releases and the force plot (for tests)");
  app.add_option("--checkpoint", o.checkpoint, "file for Save / Restore (default: in memory)");
  app.add_option("--width", o.width, "window width, pixels")->check(CLI::Range(320, 8192));
  app.add_option("--height", o.height, "window height, pixels")->check(CLI::Range(240, 8192));
  app.add_flag("--paused", o.paused, "open paused (Space runs)");
  app.add_option("--samples", o.samples, "multisampling (default: 4 on a GPU, none on a software renderer)")
      ->check(CLI::Range(0, 16));
  app.add_option("--triangles", o.triangle_budget,
                 "the organ's drawn triangles at most: far parts coarsened to fit (default 100000)")
      ->check(CLI::Range(std::size_t{1000}, std::size_t{100'000'000}));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help is a success; a missing scene or a bad value is bad input, exit 2 as `haustra run`.
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }
  try {
    // A surface is imported first, into a temporary folder removed when the viewer closes.
    std::optional<haustra::import::ScratchImport> imported;
    if (haustra::import::is_surface(o.scene)) {
      imported.emplace(o.scene, [](std::string_view line) { fmt::print(stderr, "import: {}\n", line); });
      fmt::print(stderr, "import: {} is now the scene {} (removed at exit, `haustra import` keeps one)\n", o.scene,
                 imported->scene().string());
      o.source = o.scene;
      o.scene = imported->scene().string();
    }
    return haustra::view::run_viewer(o);
  } catch (const haustra::Error& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return e.code() == haustra::ErrorCode::unstable ? 3 : 2;
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return 2;
  }
}
