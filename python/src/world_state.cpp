// haustra.World's derived state, computed when read (fresh arrays, not views): material frames as
// matrices, velocities by finite differences, section stresses, one record per contact.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstring>
#include <vector>

#include "haustra/world.hpp"
#include "recording.hpp"
#include "typed.hpp"
#include "world_bindings.hpp"

namespace py = pybind11;

namespace haustra::python {
namespace {

// (N, 3) float64 filled by one of the World's derived readings (two outputs: `first` picks one).
template <class Read>
Float64Array derived(PyWorld& w, Read read, bool first) {
  auto world = w.locked();
  const auto n = static_cast<py::ssize_t>(world->node_count());
  py::array_t<double> a({n, py::ssize_t{3}}), b({n, py::ssize_t{3}});
  read(world.world, std::span<double>(a.mutable_data(), a.size()), std::span<double>(b.mutable_data(), b.size()));
  return Float64Array(first ? a : b);
}

Float64Array directors(PyWorld& w) {
  auto world = w.locked();
  const auto r = world->node_rotations();
  py::array_t<double> out({static_cast<py::ssize_t>(r.size()), py::ssize_t{3}, py::ssize_t{3}});
  auto m = out.mutable_unchecked<3>();
  for (std::size_t k = 0; k < r.size(); ++k) {
    const Eigen::Matrix3d R = r.get(k).normalized().toRotationMatrix();
    for (Eigen::Index i = 0; i < 3; ++i)
      for (Eigen::Index j = 0; j < 3; ++j) m(static_cast<py::ssize_t>(k), i, j) = R(i, j);
  }
  return Float64Array(out);
}

ContactArray contact_records(PyWorld& w) {
  auto world = w.locked();
  const std::span<const Contact> list = world->contact_list();
  py::array out(contact_dtype(), std::vector<py::ssize_t>{static_cast<py::ssize_t>(list.size())});
  if (!list.empty()) std::memcpy(out.mutable_data(), list.data(), list.size_bytes());
  return ContactArray(out);
}

}  // namespace

void bind_world_state(WorldClass& c) {
  c.def_property_readonly("directors", &directors,
                          "(N, 3, 3) float64: each node's material frame as a rotation matrix whose columns are the "
                          "directors d1, d2 (the cross-section's axes) and d3 (the tangent). A copy.");
  auto velocities = [](const World& x, std::span<double> a, std::span<double> b) { x.node_velocities(a, b); };
  c.def_property_readonly(
      "node_velocities", [velocities](PyWorld& w) { return derived(w, velocities, true); },
      "(N, 3) float64, m/s: each node's velocity over the last frame by finite difference, (r − r₀)/dt (the "
      "model is quasi-static with drag: a free rod falls at its drag-limited speed, not at g·t). Zeros "
      "before the first step and after a pose or a restore. A copy.");
  c.def_property_readonly(
      "angular_velocities", [velocities](PyWorld& w) { return derived(w, velocities, false); },
      "(N, 3) float64, rad/s, world frame: each node frame's rotation over the last frame by finite difference "
      "(the rotation vector of R·R₀ᵀ over dt). Zeros before the first step and after a pose or a restore. A copy.");
  auto stresses = [](const World& x, std::span<double> a, std::span<double> b) { x.section_stresses(a, b); };
  c.def_property_readonly(
      "section_moments", [stresses](PyWorld& w) { return derived(w, stresses, true); },
      "(N, 3) float64, N·m, material frame: the internal moment at each section from the tissue law (bending "
      "about d1, d2; twist about d3): its elastic part at the current strains plus its viscous part at their rate "
      "over the last frame (the paper's viscous bending and torsion have only the latter). A copy.");
  c.def_property_readonly(
      "section_forces", [stresses](PyWorld& w) { return derived(w, stresses, false); },
      "(N, 3) float64, N, material frame: the internal force at each section from the tissue law, elastic and "
      "viscous as section_moments: (0, 0, axial force); the rod is unshearable, so no shear force is "
      "constitutive. A copy.");
  c.def_property_readonly("contact_records", &contact_records,
                          "The last frame's contact candidates (pairs within the margin; depth > 0 where they touch, "
                          "force 0 where they do not), one record each (a structured array): bead, other (a bead, or "
                          "the shape's index), kind (an index into haustra.CONTACT_KINDS), point (nearest point of "
                          "the other surface), normal (a mesh's plane normal; (0, 0, 1) for other kinds), force (N, "
                          "on the bead), direction (the separating direction: use it for every kind), stiffness "
                          "(N/m), depth (m), coupled. A copy.");
}

}  // namespace haustra::python
