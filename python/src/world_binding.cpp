// haustra.World: a world built from a scene file or a dict in the scene format, stepped with the
// GIL released, read through zero-copy views, driven through loads, attachments and instruments.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>  // a str or any os.PathLike for a path

#include <fmt/format.h>

#include <mutex>

#include "bindings.hpp"
#include "descriptions.hpp"
#include "haustra/error.hpp"
#include "haustra/scene.hpp"
#include "haustra/world.hpp"
#include "views.hpp"
#include "world_reading.hpp"

namespace py = pybind11;

namespace haustra::python {
namespace {

// One world and the lock that keeps a second Python thread from calling into it while step()
// runs without the GIL. Views are read without the lock (between steps, as documented).
class PyWorld {
 public:
  PyWorld(const SceneDesc& scene) : world_(create_world(scene)), name_(scene.name), scene_frames_(scene.frames) {}

  // The world, locked; waits for a running step() without holding the GIL.
  struct Locked {
    std::unique_lock<std::mutex> lock;
    World& world;
    World* operator->() const { return &world; }
  };
  Locked locked() {
    std::unique_lock<std::mutex> lock(mutex_, std::try_to_lock);
    if (!lock.owns_lock()) {
      py::gil_scoped_release release;
      lock.lock();
    }
    return {std::move(lock), *world_};
  }
  // An array over the world's buffers, made under one lock with the keeper of those buffers.
  template <class F>
  py::array view(F&& make) {
    Locked world = locked();
    return make(world.world, world->buffers_keeper());
  }
  [[nodiscard]] const std::string& name() const { return name_; }
  [[nodiscard]] int scene_frames() const { return scene_frames_; }

  void step(long frames) {
    if (frames < 0) throw Error(ErrorCode::invalid_argument, fmt::format("step(n): expected n >= 0, got {}", frames));
    py::gil_scoped_release release;
    const std::lock_guard<std::mutex> lock(mutex_);
    for (long f = 0; f < frames; ++f) world_->step();
  }

 private:
  std::mutex mutex_;
  std::unique_ptr<World> world_;
  std::string name_;
  int scene_frames_ = 0;
};

SceneDesc scene_of_dict(const py::dict& description, const py::dict& overrides) {
  const std::vector<std::string> o = override_strings(overrides);
  return parse_scene(toml_text(description), "World(desc)", o);
}

SegmentDesc segment_of_dict(const py::dict& segment) {
  py::dict description;
  py::list segments;
  segments.append(segment);
  description["segment"] = segments;
  return parse_scene(toml_text(description), "add_segment(desc)").world.segments.at(0);
}

void bind_views(py::class_<PyWorld>& c) {
  c.def_property_readonly(
      "node_positions",
      [](PyWorld& w) {
        return w.view([](const World& x, const Keeper& k) { return vec3_array(x.node_positions(), k); });
      },
      "(N, 3) float64, m: every node, segments one after another. A live view (see the module doc).");
  c.def_property_readonly(
      "strains",
      [](PyWorld& w) {
        return w.view([](const World& x, const Keeper& k) { return rows_array(x.strains().data, 4, k); });
      },
      "(N, 4) float64: κ1, κ2 (1/m), τ (1/m), ε per node. A live view.");
  c.def_property_readonly(
      "rest_strains",
      [](PyWorld& w) {
        return w.view([](const World& x, const Keeper& k) { return rows_array(x.rest_strains().data, 4, k); });
      },
      "(N, 4) float64: the rest shape's strains.");
  c.def_property_readonly(
      "section_lengths",
      [](PyWorld& w) {
        return w.view([](const World& x, const Keeper& k) { return rows_array(x.section_lengths(), 0, k); });
      },
      "(N,) float64, m: section k at node k.");
  c.def_property_readonly(
      "bead_centres",
      [](PyWorld& w) {
        return w.view([](const World& x, const Keeper& k) { return vec3_array(x.bead_centres(), k); });
      },
      "(B, 3) float64, m: bead centres after the last step. A live view.");
  c.def_property_readonly(
      "bead_radii",
      [](PyWorld& w) {
        return w.view([](const World& x, const Keeper& k) { return rows_array(x.bead_radii(), 0, k); });
      },
      "(B,) float64, m.");
  c.def_property_readonly(
      "bead_nodes",
      [](PyWorld& w) {
        return w.view([](const World& x, const Keeper& k) { return rows_array(x.bead_nodes(), 0, k); });
      },
      "(B,) uint32: each bead's node (an index into node_positions).");
  c.def_property_readonly(
      "mesh_positions",
      [](PyWorld& w) {
        return w.view([](const World& x, const Keeper& k) { return vec3_array(x.mesh_positions(), k); });
      },
      "(V, 3) float32, m: every segment's organ mesh vertices. A live view.");
  c.def_property_readonly(
      "mesh_normals",
      [](PyWorld& w) {
        return w.view([](const World& x, const Keeper& k) { return vec3_array(x.mesh_normals(), k); });
      },
      "(V, 3) float32: unit vertex normals. A live view.");
  c.def_property_readonly(
      "mesh_triangles",
      [](PyWorld& w) {
        return w.view([](const World& x, const Keeper& k) { return triangles_array(x.mesh_triangles(), k); });
      },
      "(T, 3) uint32: indices into mesh_positions.");
}

void bind_driving(py::class_<PyWorld>& c) {
  c.def(
      "set_external_load",
      [](PyWorld& w, std::int64_t node, const py::object& force, const py::object& moment) {
        auto world = w.locked();
        // Negative counts from the end, as in Python and in the scene format (node = -1: the last).
        const auto count = static_cast<std::int64_t>(world->node_count());
        if (node < -count || node >= count)
          throw Error(ErrorCode::invalid_argument,
                      fmt::format("set_external_load: node {} out of range: the world has {} nodes", node, count));
        world->set_external_load(static_cast<std::size_t>(node < 0 ? node + count : node), vector3(force, "force"),
                                 vector3(moment, "moment"));
      },
      py::arg("node"), py::arg("force"), py::arg("moment") = py::make_tuple(0.0, 0.0, 0.0),
      "Force (N) and moment (N·m) on one node (an index into node_positions, negative from the end), world frame, "
      "held until changed.");
  c.def(
      "set_attachment_target",
      [](PyWorld& w, std::size_t segment, std::size_t attachment, const py::object& position) {
        w.locked()->set_attachment_target(segment, attachment, vector3(position, "position"));
      },
      py::arg("segment"), py::arg("attachment"), py::arg("position"));
  c.def(
      "set_attachment_active",
      [](PyWorld& w, std::size_t segment, std::size_t attachment, bool active) {
        w.locked()->set_attachment_active(segment, attachment, active);
      },
      py::arg("segment"), py::arg("attachment"), py::arg("active"));
  c.def(
      "attachment_force",
      [](PyWorld& w, std::size_t segment, std::size_t attachment) {
        return array3(w.locked()->attachment_force(segment, attachment));
      },
      py::arg("segment"), py::arg("attachment"), "N, on the rod, in the last frame.");
  c.def(
      "set_instrument_pose",
      [](PyWorld& w, std::size_t instrument, const py::object& tip, const py::object& axis) {
        w.locked()->set_instrument_pose(instrument, vector3(tip, "tip"), vector3(axis, "axis"));
      },
      py::arg("instrument"), py::arg("tip"), py::arg("axis"),
      "Moves an instrument (m; the axis is normalized). Hands it from its script to the caller for good.");
  c.def(
      "grasp", [](PyWorld& w, std::size_t instrument) { w.locked()->set_instrument_grasp(instrument, true); },
      py::arg("instrument") = 0, "Closes the instrument's jaws: it grasps the nearest bead in reach at the next step.");
  c.def(
      "release", [](PyWorld& w, std::size_t instrument) { w.locked()->set_instrument_grasp(instrument, false); },
      py::arg("instrument") = 0, "Opens the jaws: the grasped node is let go at the next step.");
  c.def(
      "instrument", [](PyWorld& w, std::size_t i) { return instrument_dict(w.locked()->instrument(i)); },
      py::arg("instrument") = 0,
      "The instrument after the last frame: pose, grasp (and whether it slipped), force on it (raw and filtered).");
}

void bind_reading(py::class_<PyWorld>& c) {
  c.def_property_readonly("name", &PyWorld::name);
  c.def_property_readonly("scene_frames", &PyWorld::scene_frames,
                          "The scene's length (scene.frames): what `haustra run` runs.");
  c.def_property_readonly("frame", [](PyWorld& w) { return w.locked()->frame(); });
  c.def_property_readonly(
      "time", [](PyWorld& w) { return w.locked()->time(); }, "s");
  c.def_property_readonly(
      "dt", [](PyWorld& w) { return w.locked()->dt(); }, "s");
  c.def_property_readonly("threads", [](PyWorld& w) { return w.locked()->threads(); });
  c.def_property_readonly("node_count", [](PyWorld& w) { return w.locked()->node_count(); });
  c.def_property_readonly("segment_count", [](PyWorld& w) { return w.locked()->segment_count(); });
  c.def_property_readonly("bead_count", [](PyWorld& w) { return w.locked()->bead_count(); });
  c.def_property_readonly("instrument_count", [](PyWorld& w) { return w.locked()->instrument_count(); });
  c.def_property_readonly(
      "segments", [](PyWorld& w) { return segments_list(w.locked().world); },
      "One dict per segment: name, node range, rest length, stiffnesses, mesh ranges.");
  c.def_property_readonly(
      "profile", [](PyWorld& w) { return profile_dict(w.locked()->last_profile()); },
      "The last frame's per-stage profile: seconds and calls per stage, iterations, substeps, ...");
  c.def_property_readonly(
      "events", [](PyWorld& w) { return events_list(w.locked()->events()); },
      "Robust-mode recoveries and instabilities so far, oldest first.");
  c.def_property_readonly(
      "energy",
      [](PyWorld& w) {
        const Energy e = w.locked()->energy();
        return py::dict(py::arg("elastic") = e.elastic, py::arg("gravity") = e.gravity, py::arg("total") = e.total());
      },
      "J");
  c.def_property_readonly("contacts", [](PyWorld& w) { return contacts_dict(w.locked()->contacts()); });
}

void bind_lifecycle(py::class_<PyWorld>& c) {
  c.def(py::init([](const py::dict& desc, const py::dict& overrides) {
          return new PyWorld(scene_of_dict(desc, overrides));
        }),
        py::arg("desc"), py::arg("overrides") = py::dict(),
        "A world from a dict with the keys of a scene file (docs/scene-format.md), e.g.\n"
        "World({'world': {'dt': 0.01}, 'segment': [{'nodes': 50}]}). Errors name the field.");
  c.def_static(
      "from_scene",
      [](const std::filesystem::path& path, const py::dict& overrides) {
        return new PyWorld(load_scene(path, override_strings(overrides)));
      },
      py::arg("path"), py::arg("overrides") = py::dict(),
      "A world from a scene file; overrides as `haustra run --set`: {'segment.nodes': 333}.");
  c.def("step", &PyWorld::step, py::arg("n") = 1,
        "Runs n frames of dt with the GIL released. On an instability the world stays at its last good frame and "
        "haustra.UnstableError names segment, node and stage.");
  c.def(
      "save_checkpoint",
      [](PyWorld& w) {
        const std::vector<std::byte> bytes = w.locked()->save_checkpoint();
        return py::bytes(reinterpret_cast<const char*>(bytes.data()), bytes.size());
      },
      "Everything a later frame depends on, as bytes.");
  c.def(
      "restore_checkpoint",
      [](PyWorld& w, const py::bytes& data) {
        const std::string_view bytes(data);
        w.locked()->restore_checkpoint(std::span(reinterpret_cast<const std::byte*>(bytes.data()), bytes.size()),
                                       "bytes");
      },
      py::arg("data"), "Back to a checkpoint of a world built from the same scene; stepping on gives the same bits.");
  c.def(
      "add_segment",
      [](PyWorld& w, const py::dict& segment) { return w.locked()->add_segment(segment_of_dict(segment)); },
      py::arg("segment"),
      "Adds a segment (a dict like one [[segment]] of a scene); returns its index. "
      "Views taken before keep the old buffers (valid memory, no longer updated).");
  c.def(
      "remove_segment", [](PyWorld& w, std::size_t segment) { w.locked()->remove_segment(segment); },
      py::arg("segment"), "Removes a segment (a chain whole). Views taken before keep the old buffers.");
  c.def("__repr__", [](PyWorld& w) {
    auto world = w.locked();
    return fmt::format("<haustra.World '{}': {} segments, {} nodes, {} beads, frame {}>", w.name(),
                       world->segment_count(), world->node_count(), world->bead_count(), world->frame());
  });
}

}  // namespace

void bind_world(py::module_& m) {
  py::class_<PyWorld> c(m, "World", "A simulated world: rods, beads, meshes, environment and instruments.");
  bind_lifecycle(c);
  bind_views(c);
  bind_driving(c);
  bind_reading(c);
}

}  // namespace haustra::python
