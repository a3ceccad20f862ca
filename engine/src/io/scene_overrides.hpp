#pragma once
// `--set key=value` applied to a scene's TOML (scene_overrides.cpp). Private to io/.
#include <toml++/toml.h>

#include <string>

namespace haustra::scene_io {

// Throws Error{invalid_argument} naming `file`, the assignment and what is wrong with it.
void apply_override(toml::table& root, const std::string& assignment, const std::string& file);

}  // namespace haustra::scene_io
