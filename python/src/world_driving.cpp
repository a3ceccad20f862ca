// Driving a haustra.World between steps: loads on nodes (set or added), attachments, instruments,
// and the run-time parameters that need no rebuild (gravity, dt, a grasp's coupling).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <fmt/format.h>

#include <optional>

#include "haustra/error.hpp"
#include "haustra/world.hpp"
#include "indices.hpp"
#include "typed.hpp"
#include "world_bindings.hpp"
#include "world_reading.hpp"

namespace py = pybind11;

namespace haustra::python {
namespace {

Eigen::Vector3d vector_or_zero(const py::object& value, const char* what) {
  return value.is_none() ? Eigen::Vector3d::Zero() : vector3(value, what);
}

void bind_loads(WorldClass& c) {
  c.def(
      "set_external_load",
      [](PyWorld& w, IndexArg node, const ArrayLike& force, const ArrayLike& moment) {
        auto world = w.locked();
        world->set_external_load(node_index(world.world, node, "set_external_load"), vector3(force, "force"),
                                 vector_or_zero(moment, "moment"));
      },
      py::arg("node"), py::arg("force"), py::arg("moment") = py::none(),
      "Sets the force (N) and moment (N·m, None: zero) on one node (an index into node_positions, negative from "
      "the end), world frame, held until changed. Replaces what the node held, a scene's load included; "
      "add_external_load adds to it.");
  c.def(
      "add_external_load",
      [](PyWorld& w, IndexArg node, const ArrayLike& force, const ArrayLike& moment) {
        auto world = w.locked();
        const std::size_t k = node_index(world.world, node, "add_external_load");
        const auto [f, m] = world->external_load(k);
        world->set_external_load(k, f + vector3(force, "force"), m + vector_or_zero(moment, "moment"));
      },
      py::arg("node"), py::arg("force"), py::arg("moment") = py::none(),
      "Adds a force (N) and moment (N·m) to what the node holds (a scene's load, an earlier call), world frame.");
  c.def(
      "external_load",
      [](PyWorld& w, IndexArg node) {
        auto world = w.locked();
        const auto [f, m] = world->external_load(node_index(world.world, node, "external_load"));
        return std::make_pair(Float64Array(array3(f)), Float64Array(array3(m)));
      },
      py::arg("node"), "The force (N) and moment (N·m) a node holds, world frame: what the scene and calls set.");
}

void bind_attachments(WorldClass& c) {
  c.def(
      "set_attachment_target",
      [](PyWorld& w, IndexArg segment, IndexArg attachment, const ArrayLike& position) {
        auto world = w.locked();
        const std::size_t s = segment_index(world.world, segment, "set_attachment_target");
        world->set_attachment_target(s, attachment_index(world.world, s, attachment, "set_attachment_target"),
                                     vector3(position, "position"));
      },
      py::arg("segment"), py::arg("attachment"), py::arg("position"),
      "Moves an attachment's target (m, world frame); it pulls its node there from the next step.");
  c.def(
      "set_attachment_active",
      [](PyWorld& w, IndexArg segment, IndexArg attachment, bool active) {
        auto world = w.locked();
        const std::size_t s = segment_index(world.world, segment, "set_attachment_active");
        world->set_attachment_active(s, attachment_index(world.world, s, attachment, "set_attachment_active"), active);
      },
      py::arg("segment"), py::arg("attachment"), py::arg("active"), "Switches an attachment on or off.");
  c.def(
      "attachment_force",
      [](PyWorld& w, IndexArg segment, IndexArg attachment) {
        auto world = w.locked();
        const std::size_t s = segment_index(world.world, segment, "attachment_force");
        return Float64Array(
            array3(world->attachment_force(s, attachment_index(world.world, s, attachment, "attachment_force"))));
      },
      py::arg("segment"), py::arg("attachment"), "N, on the rod, in the last frame.");
}

void bind_instruments(WorldClass& c) {
  c.def(
      "set_instrument_pose",
      [](PyWorld& w, IndexArg instrument, const ArrayLike& tip, const ArrayLike& axis) {
        auto world = w.locked();
        world->set_instrument_pose(instrument_index(world.world, instrument, "set_instrument_pose"),
                                   vector3(tip, "tip"), vector3(axis, "axis"));
      },
      py::arg("instrument"), py::arg("tip"), py::arg("axis"),
      "Moves an instrument (m; the axis is normalized). Hands it from its script to the caller for good.");
  c.def(
      "grasp",
      [](PyWorld& w, IndexArg instrument) {
        auto world = w.locked();
        world->set_instrument_grasp(instrument_index(world.world, instrument, "grasp"), true);
      },
      py::arg("instrument") = 0, "Closes the instrument's jaws: it grasps the nearest bead in reach at the next step.");
  c.def(
      "release",
      [](PyWorld& w, IndexArg instrument) {
        auto world = w.locked();
        world->set_instrument_grasp(instrument_index(world.world, instrument, "release"), false);
      },
      py::arg("instrument") = 0, "Opens the jaws: the grasped node is let go at the next step.");
  c.def(
      "set_instrument_coupling",
      [](PyWorld& w, IndexArg instrument, double stiffness, double damping, double force_limit) {
        auto world = w.locked();
        world->set_instrument_coupling(instrument_index(world.world, instrument, "set_instrument_coupling"), stiffness,
                                       damping, force_limit);
      },
      py::arg("instrument"), py::arg("stiffness"), py::arg("damping"), py::arg("force_limit"),
      "Changes a grasp's virtual coupling (N/m, N·s/m, N) from the next step, without a rebuild; a grasp does not "
      "switch between rigid (stiffness 0) and coupled here.");
}

void bind_parameters(WorldClass& c) {
  c.def_property(
      "gravity",
      [](PyWorld& w) {
        py::array a = array3(w.locked()->gravity());
        a.attr("setflags")(py::arg("write") = false);  // a copy: writing into it would change nothing
        return Float64Array(a);
      },
      [](PyWorld& w, const ArrayLike& g) { w.locked()->set_gravity(vector3(g, "gravity")); },
      "m/s², world frame. Settable between steps (no rebuild), checked as the scene's world.gravity.");
  c.def_property(
      "dt", [](PyWorld& w) { return w.locked()->dt(); }, [](PyWorld& w, double dt) { w.locked()->set_dt(dt); },
      "s, a frame's length. Settable between steps (no rebuild), checked as the scene's world.dt.");
  c.def_property(
      "frame_budget", [](PyWorld& w) { return w.locked()->frame_budget(); },
      [](PyWorld& w, double seconds) { w.locked()->set_frame_budget(seconds); },
      "s: a frame that takes longer is counted (profile['late'], late_frames); 0 turns it off (decision 0061).");
  c.def(
      "set_material",
      [](PyWorld& w, IndexArg index, std::optional<double> youngs_modulus, std::optional<double> poisson_ratio,
         std::optional<double> density, std::optional<double> relaxation_time) {
        auto world = w.locked();
        const std::size_t segment = segment_index(world.world, index, "set_material");
        const SegmentDesc& now = world->segment_desc(segment);
        MaterialDesc m = now.material;
        m.youngs_modulus = youngs_modulus.value_or(m.youngs_modulus);
        m.poisson_ratio = poisson_ratio.value_or(m.poisson_ratio);
        m.density = density.value_or(m.density);
        world->set_material(segment, m, relaxation_time.value_or(now.relaxation_time));
      },
      py::arg("segment"), py::arg("youngs_modulus") = py::none(), py::arg("poisson_ratio") = py::none(),
      py::arg("density") = py::none(), py::arg("relaxation_time") = py::none(),
      "Changes a segment's (a chain's, through its first piece) material (Pa, -, kg/m³) and relaxation time (s; None "
      "keeps a value). The rods are rebuilt and their state carried over, but the organ mesh's cage and binding "
      "are kept: a fraction of a rebuild's cost.");
}

}  // namespace

void bind_world_driving(WorldClass& c) {
  bind_loads(c);
  bind_attachments(c);
  bind_instruments(c);
  bind_parameters(c);
}

}  // namespace haustra::python
