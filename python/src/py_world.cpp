// PyWorld's lock, its step loop (Ctrl-C between frames, recordings) and scenes from an origin.
#include "py_world.hpp"

#include <fmt/format.h>

#include <chrono>
#include <string>

#include "haustra/error.hpp"
#include "recording.hpp"

namespace py = pybind11;

namespace haustra::python {

PyWorld::PyWorld(WorldOrigin origin, const SceneDesc& scene)
    : world_(create_world(scene)), name_(scene.name), scene_frames_(scene.frames), origin_(std::move(origin)) {}

PyWorld::Locked PyWorld::locked() {
  std::unique_lock<std::mutex> lock(mutex_, std::try_to_lock);
  if (!lock.owns_lock()) {
    py::gil_scoped_release release;
    lock.lock();
  }
  return {std::move(lock), *world_};
}

std::unique_lock<std::mutex> PyWorld::lock_for_batch() { return std::unique_lock<std::mutex>(mutex_); }

namespace {

// Python's signal handlers, run with the GIL; true when one raised (the error is set).
bool signal_raised() {
  py::gil_scoped_acquire gil;
  return PyErr_CheckSignals() != 0;
}

}  // namespace

PyWorld::StepOutcome PyWorld::step(long frames, Recorder* recorder) {
  using Clock = std::chrono::steady_clock;
  constexpr auto kSignalInterval = std::chrono::milliseconds(20);
  StepOutcome out;
  py::gil_scoped_release release;
  const std::lock_guard<std::mutex> lock(mutex_);
  auto last_check = Clock::now();
  for (; out.frames_done < frames; ++out.frames_done) {
    if (Clock::now() - last_check >= kSignalInterval) {  // a clock read per frame; the GIL every 20 ms
      if (signal_raised()) {
        out.interrupted = true;
        break;
      }
      last_check = Clock::now();
    }
    try {
      world_->step();
    } catch (...) {  // the world stays at its last good frame; the caller raises with what was recorded
      out.error = std::current_exception();
      break;
    }
    if (recorder != nullptr) recorder->capture(*world_, out.frames_done);
  }
  if (mesh_viewed_ && out.frames_done > 0) (void)world_->mesh_positions();  // held mesh views show this frame
  return out;
}

namespace {

// "FILE:L:C: rest" → "rest" (the position in a TOML text made from a dict); other text as it is.
std::string without_position(const std::string& message, const std::string& file) {
  const std::string head = file + ":";
  if (message.rfind(head, 0) != 0) return message;
  std::size_t at = head.size();
  for (int number = 0; number < 2; ++number) {  // L: then C:
    const std::size_t digits = message.find_first_not_of("0123456789", at);
    if (digits == at || digits == std::string::npos || message[digits] != ':') return message;
    at = digits + 1;
  }
  return message.substr(at + (message.compare(at, 1, " ") == 0 ? 1 : 0));
}

}  // namespace

void rethrow_without_lines(const std::filesystem::path& file) {
  const std::string label = "World(desc)";
  try {
    throw;
  } catch (const FieldError& e) {  // the key path, not a line of the TOML text made from the dict
    throw FieldError(e.code(), e.field(), e.detail(), fmt::format("{}: {}: {}", label, e.field(), e.detail()));
  } catch (const Error& e) {
    throw Error(e.code(), fmt::format("{}: {}", label, without_position(e.what(), file.string())));
  }
}

PyWorld* build_world(WorldOrigin origin) {
  try {
    const SceneDesc scene = parse_scene(origin.text, origin.file, origin.overrides);
    return new PyWorld(std::move(origin), scene);
  } catch (const Error&) {
    if (!origin.from_dict) throw;
    rethrow_without_lines(origin.file);
  }
}

}  // namespace haustra::python
