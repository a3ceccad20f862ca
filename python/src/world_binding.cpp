// haustra.World's life: built from a scene file or a dict in the scene format, stepped (with the
// GIL released, Ctrl-C and recordings), checkpointed, pickled and copied, segments added and removed.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>  // a str or any os.PathLike for a path

#include <fmt/format.h>

#include <fstream>
#include <optional>
#include <sstream>

#include "bindings.hpp"
#include "descriptions.hpp"
#include "haustra/error.hpp"
#include "haustra/scene.hpp"
#include "haustra/world.hpp"
#include "indices.hpp"
#include "py_world.hpp"
#include "recording.hpp"
#include "typed.hpp"
#include "world_bindings.hpp"

namespace py = pybind11;

namespace haustra::python {
namespace {

std::vector<std::string> overrides_of(const std::optional<py::dict>& overrides) {
  return overrides ? override_strings(*overrides) : std::vector<std::string>{};
}

PyWorld* world_of_dict(const py::dict& desc, const std::optional<py::dict>& overrides,
                       const std::optional<std::filesystem::path>& base_dir) {
  WorldOrigin origin;
  origin.file = (base_dir ? *base_dir : std::filesystem::current_path()) / "World(desc)";
  try {
    origin.text = toml_text(desc);
  } catch (const Error&) {
    rethrow_without_lines(origin.file);
  }
  origin.overrides = overrides_of(overrides);
  origin.from_dict = true;
  return build_world(std::move(origin));
}

PyWorld* world_of_file(const std::filesystem::path& path, const std::optional<py::dict>& overrides) {
  WorldOrigin origin;
  origin.file = std::filesystem::absolute(path);
  origin.overrides = overrides_of(overrides);
  const SceneDesc scene = load_scene(path, origin.overrides);  // refuses folders, empty and unreadable files
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  origin.text = text.str();
  return new PyWorld(std::move(origin), scene);
}

// A segment's dict parsed as a scene of that one segment; its file is where relative paths resolve.
SegmentDesc segment_of_dict(const py::dict& segment, const std::filesystem::path& file) {
  py::dict description;
  py::list segments;
  segments.append(segment);
  description["segment"] = segments;
  try {
    return parse_scene(toml_text(description), file).world.segments.at(0);
  } catch (const Error&) {
    rethrow_without_lines(file);
  }
}

// Sets the Python error for a step that ended early, with what was recorded as its `recording`.
[[noreturn]] void raise_step_error(const PyWorld::StepOutcome& out, const Recorder* recorder) {
  if (!out.interrupted) {
    try {
      std::rethrow_exception(out.error);
    } catch (const Error& e) {
      set_python_error(e);
    } catch (const std::exception& e) {
      PyErr_SetString(PyExc_RuntimeError, e.what());
    }
  }
  py::error_already_set error;  // fetches (and owns) the error set above or by a signal handler
  if (recorder != nullptr) error.value().attr("recording") = recorder->result(out.frames_done);
  throw error;
}

MaybeRecording step(PyWorld& w, long frames, const std::optional<std::vector<std::string>>& record) {
  if (frames < 0) throw Error(ErrorCode::invalid_argument, fmt::format("step(n): expected n >= 0, got {}", frames));
  std::optional<Recorder> recorder;
  if (record) recorder.emplace(w.locked().world, *record, frames);  // refused here, before any frame
  const PyWorld::StepOutcome out = w.step(frames, recorder ? &*recorder : nullptr);
  if (out.interrupted || out.error) raise_step_error(out, recorder ? &*recorder : nullptr);
  return recorder ? MaybeRecording(recorder->result(out.frames_done)) : MaybeRecording(py::none());
}

void bind_checkpoints(py::class_<PyWorld>& c) {
  c.def(
      "save_checkpoint",
      [](PyWorld& w) {
        const std::vector<std::byte> bytes = w.locked()->save_checkpoint();
        return py::bytes(reinterpret_cast<const char*>(bytes.data()), bytes.size());
      },
      "Everything a later frame depends on, as bytes.");
  c.def(
      "restore_checkpoint",
      [](PyWorld& w, const py::buffer& data) {
        const py::buffer_info info = data.request();
        if (info.ndim != 1 || info.itemsize != 1 || (info.strides.size() == 1 && info.strides[0] != 1))
          throw Error(ErrorCode::invalid_argument,
                      "restore_checkpoint: expected bytes-like data (bytes, bytearray, memoryview) of one byte per "
                      "item, contiguous");
        w.locked()->restore_checkpoint(
            std::span(static_cast<const std::byte*>(info.ptr), static_cast<std::size_t>(info.size)), "bytes");
      },
      py::arg("data"),
      "Back to a checkpoint (bytes, bytearray or memoryview) of a world built from the same scene; stepping on "
      "gives the same bits.");
}

void bind_segments(py::class_<PyWorld>& c) {
  c.def(
      "add_segment",
      [](PyWorld& w, const py::dict& segment) {
        const std::filesystem::path file = std::filesystem::current_path() / "World(desc)";
        const SegmentDesc desc = segment_of_dict(segment, file);
        std::size_t index = 0;
        try {
          index = w.locked()->add_segment(desc);
        } catch (const Error&) {
          rethrow_without_lines(file);
        }
        w.mark_rebuilt();
        return index;
      },
      py::arg("segment"),
      "Adds a segment (a dict like one [[segment]] of a scene); returns its index. "
      "Views taken before keep the old buffers (valid memory, no longer updated).");
  c.def(
      "remove_segment",
      [](PyWorld& w, IndexArg segment) {
        auto world = w.locked();
        world->remove_segment(segment_index(world.world, segment, "remove_segment"));
        w.mark_rebuilt();
      },
      py::arg("segment"), "Removes a segment (a chain whole). Views taken before keep the old buffers.");
}

}  // namespace

void bind_lifecycle(py::class_<PyWorld>& c) {
  c.def(py::init(&world_of_dict), py::arg("desc"), py::arg("overrides") = py::none(), py::arg("base_dir") = py::none(),
        "A world from a dict with the keys of a scene file (docs/scene-format.md), e.g.\n"
        "World({'world': {'dt': 0.01}, 'segment': [{'nodes': 50}]}). Relative paths in it (mesh files) resolve "
        "against base_dir (default: the current directory). Errors name the key path, e.g. segment[0].mesh.file.");
  c.def_static("from_scene", &world_of_file, py::arg("path"), py::arg("overrides") = py::none(),
               "A world from a scene file (a str or os.PathLike); overrides as `haustra run --set`: "
               "{'segment.nodes': 333}.");
  c.def("step", &step, py::arg("n") = 1, py::arg("record") = py::none(),
        "Runs n frames of dt with the GIL released. record: names of quantities to capture after every frame "
        "(see haustra.RECORDABLE), returned as a dict of arrays, frames first, with 'frame' and 'time'. Ctrl-C stops "
        "between frames (KeyboardInterrupt, the world at its last whole frame). On an instability the world stays "
        "at its last good frame and haustra.UnstableError names segment, node and stage. Either exception carries "
        "the frames recorded before it as .recording.");
  bind_checkpoints(c);
  bind_segments(c);
  bind_pickling(c);
  c.def("__repr__", [](PyWorld& w) {
    auto world = w.locked();
    return fmt::format("<haustra.World '{}': {} segments, {} nodes, {} beads, frame {}>", w.name(),
                       world->segment_count(), world->node_count(), world->bead_count(), world->frame());
  });
}

void bind_world(py::module_& m) {
  py::class_<PyWorld> c(m, "World", "A simulated world: rods, beads, meshes, environment and instruments.");
  bind_lifecycle(c);
  bind_world_views(c);
  bind_world_state(c);
  bind_world_driving(c);
  bind_world_readings(c);
  bind_world_tissue(c);
  bind_world_writing(c);
  py::list recordable;
  for (const std::string& name : Recorder::known_names()) recordable.append(name);
  m.attr("RECORDABLE") = py::tuple(recordable);
}

}  // namespace haustra::python
