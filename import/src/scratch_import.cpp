// A surface imported into a temporary folder of its own, removed with the object.
#include "haustra/import/scratch_import.hpp"

#include <fmt/format.h>
#include <stdlib.h>  // mkdtemp

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>

#include "haustra/error.hpp"
#include "haustra/mesh_io.hpp"

namespace haustra::import {

namespace fs = std::filesystem;

bool is_surface(const fs::path& file) {
  std::string ext = file.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return std::find(kMeshFormats.begin(), kMeshFormats.end(), ext) != kMeshFormats.end();
}

ScratchImport::ScratchImport(const fs::path& surface, std::function<void(std::string_view)> progress) {
  std::string name =
      (fs::temp_directory_path() / fmt::format("haustra-import-{}-XXXXXX", surface.stem().string())).string();
  if (mkdtemp(name.data()) == nullptr)
    throw Error(ErrorCode::io,
                fmt::format("{}: cannot make a temporary folder to import into ({})", name, std::strerror(errno)));
  folder_ = name;
  ImportOptions o;
  o.mesh = surface;
  o.out = folder_ / "scene.toml";
  o.progress = std::move(progress);
  try {
    report_ = import_surface(o);
  } catch (...) {
    std::error_code ignored;
    fs::remove_all(folder_, ignored);
    throw;
  }
}

ScratchImport::~ScratchImport() {
  std::error_code ignored;  // a folder already gone, or a file still open elsewhere: nothing to do
  fs::remove_all(folder_, ignored);
}

}  // namespace haustra::import
