#pragma once
// Scene files: human-written TOML describing a world and how long to run it. The format is
// documented in docs/scene-format.md; scenes/*.toml are examples. Every value is checked: an
// unknown key, a wrong type, a missing or out-of-range value fails with the file, line, field and
// what was expected.
#include <filesystem>
#include <memory>
#include <span>
#include <string>

#include "haustra/world.hpp"
#include "haustra/world_desc.hpp"

namespace haustra {

struct SceneSource;  // the parsed document, kept to point errors at lines

struct SceneDesc {
  std::string name;
  std::string description;
  std::filesystem::path file;
  int frames = 60;  // default length of `haustra run`
  WorldDesc world;
  std::shared_ptr<const SceneSource> source;
};

// overrides: "key=value" with a dotted key, e.g. "segment.nodes=333" (every segment) or
// "segment[1].nodes=333" (one), "solver.mode=lagged". The value is TOML (a bare word is a string).
SceneDesc load_scene(const std::filesystem::path& file, std::span<const std::string> overrides = {});
SceneDesc parse_scene(const std::string& text, const std::filesystem::path& file,
                      std::span<const std::string> overrides = {});

// World::create, with model-building errors pointed at the scene line that set the field.
std::unique_ptr<World> create_world(const SceneDesc& scene);

}  // namespace haustra
