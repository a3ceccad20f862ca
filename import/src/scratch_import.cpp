// A surface imported into a temporary folder of its own, removed with the object.
#include "haustra/import/scratch_import.hpp"

#include <fmt/format.h>
#include <pthread.h>
#include <stdlib.h>  // mkdtemp

#include <csignal>
#include <mutex>
#include <set>
#include <thread>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>

#include "haustra/error.hpp"
#include "haustra/mesh_io.hpp"

namespace haustra::import {

namespace fs = std::filesystem;

namespace {

// The scratch folders alive now, for the signal thread to remove.
std::mutex g_live_mutex;
std::set<fs::path>& live_folders() {
  static std::set<fs::path> live;
  return live;
}

void remove_live_folders() {
  const std::lock_guard lock(g_live_mutex);
  for (const fs::path& folder : live_folders()) {
    std::error_code ignored;
    fs::remove_all(folder, ignored);
  }
}

}  // namespace

void remove_scratch_on_signals() {
  static std::once_flag once;
  std::call_once(once, [] {
    sigset_t signals;
    sigemptyset(&signals);
    sigaddset(&signals, SIGINT);
    sigaddset(&signals, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &signals, nullptr);  // threads started later inherit it
    std::thread([signals] {
      int received = 0;
      if (sigwait(&signals, &received) != 0) return;
      remove_live_folders();
      // Then the signal's own end: its default action, delivered to this thread alone.
      std::signal(received, SIG_DFL);
      sigset_t one;
      sigemptyset(&one);
      sigaddset(&one, received);
      pthread_sigmask(SIG_UNBLOCK, &one, nullptr);
      std::raise(received);
    }).detach();
  });
}

bool is_surface(const fs::path& file) {
  std::string ext = file.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return std::find(kMeshFormats.begin(), kMeshFormats.end(), ext) != kMeshFormats.end();
}

ScratchImport::ScratchImport(const fs::path& surface, std::function<void(std::string_view)> progress) {
  std::string name =
      (fs::temp_directory_path() / fmt::format("haustra-import-{}-XXXXXX", surface.stem().string())).string();
  {
    // Made and listed under one lock: a signal between the two would otherwise find the folder made
    // but not listed, and leave it behind (the signal thread waits for the lock instead).
    const std::lock_guard lock(g_live_mutex);
    if (mkdtemp(name.data()) == nullptr)
      throw Error(ErrorCode::io,
                  fmt::format("{}: cannot make a temporary folder to import into ({})", name, std::strerror(errno)));
    folder_ = name;
    live_folders().insert(folder_);
  }
  ImportOptions o;
  o.mesh = surface;
  o.out = folder_ / "scene.toml";
  o.progress = std::move(progress);
  try {
    report_ = import_surface(o);
  } catch (...) {
    forget();
    throw;
  }
}

ScratchImport::~ScratchImport() { forget(); }

void ScratchImport::forget() {
  const std::lock_guard lock(g_live_mutex);
  live_folders().erase(folder_);
  std::error_code ignored;  // a folder already gone, or a file still open elsewhere: nothing to do
  fs::remove_all(folder_, ignored);
}

}  // namespace haustra::import
