#pragma once
// Shared test helpers over the public API: a world from scenes/NAME.toml, and a world's node
// positions as one flat vector (x, y, z per node) for bit comparisons.
#include <memory>
#include <string>
#include <vector>

#include "haustra/scene.hpp"
#include "haustra/world.hpp"

namespace haustra::test {

// scenes/NAME.toml with `sets` applied, on one thread.
inline SceneDesc scene_desc(const std::string& name, std::vector<std::string> sets = {}) {
  SceneDesc scene = load_scene(std::string(HAUSTRA_SOURCE_DIR) + "/scenes/" + name + ".toml", sets);
  scene.world.threads = 1;
  return scene;
}

inline std::unique_ptr<World> scene_world(const std::string& name, int threads = 1,
                                          std::vector<std::string> sets = {}) {
  SceneDesc scene = load_scene(std::string(HAUSTRA_SOURCE_DIR) + "/scenes/" + name + ".toml", sets);
  scene.world.threads = threads;
  return create_world(scene);
}

inline std::vector<double> positions(const World& w) {
  const auto p = w.node_positions();
  std::vector<double> out;
  out.reserve(3 * w.node_count());
  for (std::size_t k = 0; k < w.node_count(); ++k) out.insert(out.end(), {p.x[k], p.y[k], p.z[k]});
  return out;
}

}  // namespace haustra::test
