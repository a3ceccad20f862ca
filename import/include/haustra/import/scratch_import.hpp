#pragma once
// A surface given where a scene is expected (`haustra run SURFACE`, `haustra view SURFACE`):
// imported with the defaults into a folder of its own under the system's temporary folder, which
// goes when the object does, so runs side by side never share one and none is left behind.
#include <filesystem>

#include "haustra/import/import.hpp"

namespace haustra::import {

// A mesh file by its extension (the engine's formats: OBJ, STL, OFF, glTF).
bool is_surface(const std::filesystem::path& file);

class ScratchImport {
 public:
  // Throws haustra::Error as import_surface does; `progress` as ImportOptions::progress.
  ScratchImport(const std::filesystem::path& surface, std::function<void(std::string_view)> progress);
  ~ScratchImport();
  ScratchImport(const ScratchImport&) = delete;
  ScratchImport& operator=(const ScratchImport&) = delete;

  [[nodiscard]] const ImportReport& report() const { return report_; }
  [[nodiscard]] const std::filesystem::path& scene() const { return report_.scene; }

 private:
  std::filesystem::path folder_;
  ImportReport report_;
};

}  // namespace haustra::import
