// Readings to Python values: each a fresh object (a copy), unlike the buffer views.
#include "world_reading.hpp"

#include <fmt/format.h>

#include "haustra/error.hpp"

namespace py = pybind11;

namespace haustra::python {

Eigen::Vector3d vector3(const py::object& value, const char* what) {
  py::array_t<double, py::array::c_style | py::array::forcecast> a;
  try {
    a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(value);
  } catch (const py::error_already_set&) {
    a = {};
  }
  if (!a || a.ndim() != 1 || a.shape(0) != 3)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("{}: expected three numbers, got {}", what, py::repr(value).cast<std::string>()));
  return {a.at(0), a.at(1), a.at(2)};
}

py::array array3(const Eigen::Vector3d& v) {
  py::array_t<double> a(3);
  for (py::ssize_t i = 0; i < 3; ++i) a.mutable_at(i) = v[i];
  return a;
}

InstrumentDict instrument_dict(const InstrumentReading& r) {
  InstrumentDict d;
  d["tip"] = array3(r.tip);
  d["commanded_tip"] = array3(r.commanded_tip);
  d["axis"] = array3(r.axis);
  d["closed"] = r.closed;
  d["cutting"] = r.cutting;
  d["grasping"] = r.grasping;
  d["grasped_segment"] = r.grasping ? py::object(py::int_(r.grasped_segment)) : py::object(py::none());
  d["grasped_node"] = r.grasping ? py::object(py::int_(r.grasped_node)) : py::object(py::none());
  d["slipped"] = r.slipped;
  d["grasp_target"] = array3(r.grasp_target);
  d["force"] = array3(r.force);
  d["torque"] = array3(r.torque);
  d["filtered_force"] = array3(r.filtered_force);
  d["filtered_torque"] = array3(r.filtered_torque);
  return d;
}

SegmentList segments_list(const World& world) {
  SegmentList out;
  for (std::size_t s = 0; s < world.segment_count(); ++s) {
    const SegmentInfo& i = world.segment(s);
    py::dict d;
    d["name"] = i.name;
    d["node_offset"] = i.nodes.offset;
    d["node_count"] = i.nodes.count;
    d["chain"] = world.chain_of(s);
    d["length"] = i.length;
    d["bending_stiffness"] = i.bending_stiffness;
    d["torsion_stiffness"] = i.torsion_stiffness;
    d["axial_stiffness"] = i.axial_stiffness;
    d["linear_density"] = i.linear_density;
    const Range beads = world.beads(s);
    d["bead_offset"] = beads.offset;
    d["bead_count"] = beads.count;
    const MeshInfo& mesh = world.mesh(s);
    d["mesh_vertex_offset"] = mesh.vertices.offset;
    d["mesh_vertex_count"] = mesh.vertices.count;
    d["mesh_triangle_offset"] = mesh.triangles.offset;
    d["mesh_triangle_count"] = mesh.triangles.count;
    out.append(d);
  }
  return out;
}

ProfileDict profile_dict(const FrameProfile& p) {
  py::dict seconds, calls;
  for (std::size_t s = 0; s < kStageCount; ++s) {
    const std::string name(stage_name(static_cast<Stage>(s)));
    seconds[py::str(name)] = p.seconds[s];
    calls[py::str(name)] = p.calls[s];
  }
  ProfileDict d;
  d["seconds"] = seconds;
  d["calls"] = calls;
  d["frame_seconds"] = p.frame_seconds;
#define HAUSTRA_PUT_FIELD(type, name, initial, meaning) d[#name] = p.name;
  HAUSTRA_PROFILE_COUNTERS(HAUSTRA_PUT_FIELD)
#undef HAUSTRA_PUT_FIELD
  d["newton"] = p.newton;
  return d;
}

EventList events_list(std::span<const Event> events) {
  EventList out;
  for (const Event& e : events) {
    py::dict d;
    d["kind"] = std::string(event_kind_name(e.kind));
    d["frame"] = e.frame;
    d["segment"] = e.segment;
    d["node"] = e.node;
    d["stage"] = std::string(stage_name(e.stage));
    d["substeps"] = e.substeps;
    d["message"] = std::string(e.message());
    out.append(d);
  }
  return out;
}

ContactSummaryDict contacts_dict(const ContactReport& r) {
  ContactSummaryDict d;
#define HAUSTRA_PUT_FIELD(type, name, initial, meaning) d[#name] = r.name;
  HAUSTRA_CONTACT_FIELDS(HAUSTRA_PUT_FIELD)
#undef HAUSTRA_PUT_FIELD
  return d;
}

}  // namespace haustra::python
