// haustra.Batch: many worlds stepped in one call on a pool of threads (decision 0103), with the GIL
// released, each world's recording captured on the thread that steps it, Ctrl-C between frames.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "bindings.hpp"
#include "haustra/batch.hpp"
#include "haustra/error.hpp"
#include "py_world.hpp"
#include "recording.hpp"
#include "typed.hpp"

namespace py = pybind11;

namespace haustra::python {
namespace {

class PyBatch {
 public:
  PyBatch(const py::list& worlds, int threads) : batch_(threads) {
    for (const py::handle item : worlds) {
      if (!py::isinstance<PyWorld>(item))
        throw Error(ErrorCode::invalid_argument,
                    fmt::format("Batch: expected a list of haustra.World, got a {}",
                                py::str(item.get_type().attr("__name__")).cast<std::string>()));
      objects_.push_back(py::reinterpret_borrow<py::object>(item));
      worlds_.push_back(&item.cast<PyWorld&>());
    }
    std::vector<PyWorld*> sorted = worlds_;
    std::sort(sorted.begin(), sorted.end());
    if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end())
      throw Error(ErrorCode::invalid_argument,
                  "Batch: a world appears twice in the list (two threads would step it at once): list each world once "
                  "(copy.deepcopy makes an independent one)");
  }

  py::object step(long frames, const std::optional<std::vector<std::string>>& record) {
    if (frames < 0)
      throw Error(ErrorCode::invalid_argument, fmt::format("Batch.step(n): expected n >= 0, got {}", frames));
    // Every world locked, in address order (no deadlock with another batch), without the GIL.
    std::vector<PyWorld*> order = worlds_;
    std::sort(order.begin(), order.end());
    std::vector<std::unique_lock<std::mutex>> locks;
    {
      py::gil_scoped_release release;
      for (PyWorld* w : order) locks.push_back(w->lock_for_batch());
    }
    std::vector<World*> engines;
    for (PyWorld* w : worlds_) engines.push_back(&w->engine());
    std::vector<std::unique_ptr<Recorder>> recorders;
    if (record)  // refused here (an unknown name, too much memory), before any frame
      for (World* e : engines) recorders.push_back(std::make_unique<Recorder>(*e, *record, frames));
    std::vector<Batch::Outcome> outcomes(engines.size());
    bool interrupted = false;
    {
      py::gil_scoped_release release;
      // Ctrl-C: Python runs signal handlers on the main thread only, so the thread that called step()
      // (which steps worlds too) looks every 20 ms; the others see the flag the batch sets.
      using Clock = std::chrono::steady_clock;
      const std::thread::id caller = std::this_thread::get_id();
      auto last_check = Clock::now();
      const Batch::KeepGoing keep_going = [&]() {
        if (std::this_thread::get_id() != caller || Clock::now() - last_check < std::chrono::milliseconds(20))
          return true;
        last_check = Clock::now();
        py::gil_scoped_acquire gil;
        if (PyErr_CheckSignals() == 0) return true;
        interrupted = true;
        return false;
      };
      Batch::AfterFrame after;
      if (record)
        after = [&](std::size_t i, std::uint64_t f) { recorders[i]->capture(*engines[i], static_cast<long>(f)); };
      batch_.step(engines, static_cast<std::uint64_t>(frames), outcomes, after, keep_going);
      for (std::size_t i = 0; i < engines.size(); ++i)
        worlds_[i]->frames_stepped(static_cast<long>(outcomes[i].frames));
    }
    locks.clear();
    py::list recordings, done;
    for (std::size_t i = 0; i < engines.size(); ++i) {
      done.append(outcomes[i].frames);
      if (record) recordings.append(recorders[i]->result(static_cast<long>(outcomes[i].frames)));
    }
    const py::object result = record ? py::object(recordings) : py::object(py::none());
    if (interrupted) {
      py::error_already_set error;  // the KeyboardInterrupt a signal handler set
      error.value().attr("frames") = done;
      error.value().attr("recording") = result;
      throw error;
    }
    for (std::size_t i = 0; i < engines.size(); ++i) {
      if (!outcomes[i].error) continue;
      try {
        std::rethrow_exception(outcomes[i].error);
      } catch (const Error& e) {
        set_python_error(e);
      } catch (const std::exception& e) {
        PyErr_SetString(PyExc_RuntimeError, e.what());
      }
      py::error_already_set error;
      error.value().attr("world") = i;
      error.value().attr("frames") = done;
      error.value().attr("recording") = result;
      throw error;
    }
    return result;
  }

  [[nodiscard]] py::list worlds() const {
    py::list out;
    for (const py::object& o : objects_) out.append(o);
    return out;
  }
  [[nodiscard]] std::size_t size() const { return worlds_.size(); }
  [[nodiscard]] int threads() const { return batch_.threads(); }

 private:
  Batch batch_;
  std::vector<py::object> objects_;  // keeps the worlds alive
  std::vector<PyWorld*> worlds_;
};

}  // namespace

void bind_batch(py::module_& m) {
  py::class_<PyBatch> c(m, "Batch",
                        "Many independent worlds stepped in one call on a pool of threads (decision 0103). Each world "
                        "is stepped through its frames by one thread at a time, so its frames are the same bits as "
                        "stepping it alone, whatever the pool's width. Build the worlds with world.threads = 1: the "
                        "batch's threads are spread over worlds.");
  c.def(py::init<const py::list&, int>(), py::arg("worlds"), py::arg("threads") = 0,
        "A batch of these worlds (a list of haustra.World, each listed once), stepped on `threads` threads (0: every "
        "core). The batch holds the worlds; they stay usable on their own between its steps.");
  c.def("step", &PyBatch::step, py::arg("n") = 1, py::arg("record") = py::none(),
        "Steps every world n frames with the GIL released. record: names as World.step's (haustra.RECORDABLE); then "
        "a list of one recording per world, in the batch's order. A world that fails stops at its last good frame "
        "and the others go on; then its error is raised (the first such world's) with .world (its index), .frames "
        "(frames each world completed) and .recording. Ctrl-C stops every world between frames: KeyboardInterrupt "
        "with .frames and .recording.");
  c.def_property_readonly("worlds", &PyBatch::worlds, "The worlds, in the batch's order (a new list).");
  c.def_property_readonly("threads", &PyBatch::threads, "The pool's width.");
  c.def("__len__", &PyBatch::size, "How many worlds the batch steps.");
}

}  // namespace haustra::python
