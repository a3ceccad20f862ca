#pragma once
// A surface given where a scene is expected (`haustra run SURFACE`, `haustra view SURFACE`):
// imported with the defaults into a folder of its own under the system's temporary folder, which
// goes when the object does, so runs side by side never share one and none is left behind.
#include <filesystem>

#include "haustra/import/import.hpp"

namespace haustra::import {

// A mesh file by its extension (the engine's formats: OBJ, STL, OFF, glTF).
bool is_surface(const std::filesystem::path& file);

// On SIGINT or SIGTERM, every scratch folder still alive is removed before the signal ends the
// process as it would have (its default action). Call once, first thing in main, before any other
// thread starts: it blocks the two signals in every thread and waits for them on a thread of its own,
// where removing a folder is safe (a signal handler could not).
void remove_scratch_on_signals();

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
  void forget();  // the folder removed, and out of the signal thread's list
  std::filesystem::path folder_;
  ImportReport report_;
};

}  // namespace haustra::import
