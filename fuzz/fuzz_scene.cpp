// Fuzz target: scene text → the scene reader → (when the scene is small) the model builder and two
// frames. Anything but haustra::Error escaping, a sanitizer report or a hang is a finding.
#include <cstddef>
#include <cstdint>
#include <string>

#include "haustra/error.hpp"
#include "haustra/scene.hpp"

namespace {

// Keeps each input fast: worlds larger than this are parsed and checked but not built.
bool small_enough(const haustra::SceneDesc& s) {
  long nodes = 0;
  for (const auto& seg : s.world.segments) {
    nodes += seg.nodes;
    if (seg.mesh.enabled && (seg.mesh.source == haustra::MeshSource::file || seg.mesh.procedural.vertices > 3000))
      return false;
  }
  return nodes <= 400 && s.world.segments.size() <= 8 && s.world.solver.substeps <= 4 &&
         s.world.solver.max_substeps <= 8 && s.world.environment.meshes.empty();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const haustra::SceneDesc scene = haustra::parse_scene(text, HAUSTRA_SOURCE_DIR "/scenes/fuzz.toml");
    if (!small_enough(scene)) return 0;
    auto world = haustra::create_world(scene);
    world->step();
    world->step();
  } catch (const haustra::Error&) {
    // A clear refusal is the expected answer to a bad scene.
  }
  return 0;
}
