#pragma once
// PyWorld: one engine World behind a lock, with what Python needs beside it — where it came from
// (for pickling) and a step loop that honours Ctrl-C and records frames.
#include <pybind11/pybind11.h>

#include <exception>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "haustra/scene.hpp"
#include "haustra/world.hpp"

namespace haustra::python {

class Recorder;

// What a world was built from, enough to build it again elsewhere: the scene's text, the file its
// relative paths resolve against, the overrides. Pickling stores this and a checkpoint.
struct WorldOrigin {
  std::string text;
  std::filesystem::path file;  // a scene file, or base_dir / "World(desc)" for a dict
  std::vector<std::string> overrides;
  bool from_dict = false;
  bool rebuilt = false;  // segments added or removed since: the text no longer describes the world
};

class PyWorld {
 public:
  PyWorld(WorldOrigin origin, const SceneDesc& scene);

  // The world, locked; waits for a running step() without holding the GIL.
  struct Locked {
    std::unique_lock<std::mutex> lock;
    World& world;
    World* operator->() const { return &world; }
  };
  Locked locked();

  // An array over the world's buffers, made under one lock with the keeper of those buffers.
  template <class F>
  auto view(F&& make) {
    Locked world = locked();
    return make(world.world, world->buffers_keeper());
  }

  // n frames without the GIL; between frames, at most every 20 ms, Python's signal handlers run
  // (Ctrl-C: the Python error is set, the world at its last whole frame). A recorder, if any,
  // captures each frame after it is stepped. An engine error ends the loop and is handed back.
  struct StepOutcome {
    long frames_done = 0;
    bool interrupted = false;  // a signal handler raised: the Python error is set
    std::exception_ptr error;  // the engine's error of the frame after frames_done
  };
  StepOutcome step(long frames, Recorder* recorder);

  // For haustra.Batch (decision 0103): the world's lock, taken with the GIL released (as step() takes it),
  // the world behind it, and what step() does once its frames are done (held mesh views brought up to date).
  std::unique_lock<std::mutex> lock_for_batch();
  World& engine() { return *world_; }
  void frames_stepped(long frames) {
    if (mesh_viewed_ && frames > 0) (void)world_->mesh_positions();
  }
  [[nodiscard]] const std::string& name() const { return name_; }
  [[nodiscard]] int scene_frames() const { return scene_frames_; }
  [[nodiscard]] const WorldOrigin& origin() const { return origin_; }
  // A mesh view was handed out: step() then brings the mesh up to date when it ends (the engine
  // makes it only when read, decision 0060), so a held view stays live as the others are. A loop
  // that never takes a mesh view never pays for skinning.
  void mesh_viewed() { mesh_viewed_ = true; }
  void mark_rebuilt() { origin_.rebuilt = true; }

 private:
  std::mutex mutex_;
  std::unique_ptr<World> world_;
  std::string name_;
  int scene_frames_ = 0;
  WorldOrigin origin_;
  bool mesh_viewed_ = false;
};

// A world built from an origin's text; a dict's errors name the key path (segment[0].mesh.file)
// without the line of a TOML text the caller never wrote.
PyWorld* build_world(WorldOrigin origin);
// Inside a catch block: the engine's error again, a dict's line prefix (FILE:L:C:) replaced by
// "World(desc):".
[[noreturn]] void rethrow_without_lines(const std::filesystem::path& file);

}  // namespace haustra::python
