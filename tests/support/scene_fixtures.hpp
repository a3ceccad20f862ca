#pragma once
// Shared test helpers over the public API: a world from scenes/NAME.toml, and a world's node
// positions as one flat vector (x, y, z per node) for bit comparisons.
#include <memory>
#include <string>
#include <vector>

#include "haustra/scene.hpp"
#include "haustra/world.hpp"

namespace haustra::test {

// The one way the tests build a world from a scene file: scenes/NAME.toml (or a path under the
// source tree, "tests/scenes/NAME.toml") with `sets` applied, on `threads` threads (1 unless said).
inline SceneDesc scene_desc(const std::string& name, std::vector<std::string> sets = {}, int threads = 1) {
  const std::string file = name.find('/') != std::string::npos
                               ? std::string(HAUSTRA_SOURCE_DIR) + "/" + name
                               : std::string(HAUSTRA_SOURCE_DIR) + "/scenes/" + name + ".toml";
  SceneDesc scene = load_scene(file, sets);
  scene.world.threads = threads;
  return scene;
}

inline std::unique_ptr<World> scene_world(const std::string& name, int threads = 1,
                                          std::vector<std::string> sets = {}) {
  return create_world(scene_desc(name, std::move(sets), threads));
}

// Two worlds stepped frame by frame together (for bit comparisons of one against the other).
inline void step_both(World& a, World& b, int frames) {
  for (int f = 0; f < frames; ++f) {
    a.step();
    b.step();
  }
}

inline std::vector<double> positions(const World& w) {
  const auto p = w.node_positions();
  std::vector<double> out;
  out.reserve(3 * w.node_count());
  for (std::size_t k = 0; k < w.node_count(); ++k) out.insert(out.end(), {p.x[k], p.y[k], p.z[k]});
  return out;
}

}  // namespace haustra::test
