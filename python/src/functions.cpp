// Module functions: the reference cases, writing a mesh through the engine's writers, the
// memory a scene would take.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>  // a str or any os.PathLike for a path

#include <fmt/format.h>

#include <optional>

#include "bindings.hpp"
#include "descriptions.hpp"
#include "haustra/error.hpp"
#include "haustra/mesh_io.hpp"
#include "haustra/scene.hpp"
#include "haustra/studies/validation.hpp"
#include "haustra/world.hpp"
#include "typed.hpp"

namespace py = pybind11;

namespace haustra::python {
namespace {

ValidationList validate() {
  std::vector<validation::CaseResult> results;
  {
    py::gil_scoped_release release;
    results = validation::run_all(validation::Options{});
  }
  ValidationList out;
  for (const validation::CaseResult& r : results) {
    py::dict d;
    d["name"] = r.name;
    d["quantity"] = r.quantity;
    d["reference"] = r.reference;
    d["value"] = r.value;
    d["error"] = r.error;
    d["tolerance"] = r.tolerance;
    d["absolute"] = r.absolute;
    d["passed"] = r.pass;
    d["note"] = r.note;
    out.append(d);
  }
  return out;
}

// (n, 3) of any float type, as the engine's doubles.
std::vector<Eigen::Vector3d> points_of(const py::object& value, const char* what) {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(value);
  if (!a || a.ndim() != 2 || a.shape(1) != 3)
    throw Error(ErrorCode::invalid_argument, fmt::format("{}: expected an (n, 3) array of numbers", what));
  std::vector<Eigen::Vector3d> out(static_cast<std::size_t>(a.shape(0)));
  for (py::ssize_t i = 0; i < a.shape(0); ++i) out[static_cast<std::size_t>(i)] = {a.at(i, 0), a.at(i, 1), a.at(i, 2)};
  return out;
}

void save_mesh_file(const std::filesystem::path& path, const ArrayLike& vertices, const ArrayLike& triangles,
                    const ArrayLike& normals) {
  TriangleMesh mesh;
  mesh.vertices = points_of(vertices, "vertices");
  const auto t = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(triangles);
  if (!t || t.ndim() != 2 || t.shape(1) != 3)
    throw Error(ErrorCode::invalid_argument, "triangles: expected an (m, 3) array of vertex indices");
  for (py::ssize_t i = 0; i < t.shape(0); ++i) {
    std::array<std::uint32_t, 3> tri{};
    for (py::ssize_t c = 0; c < 3; ++c) {
      const std::int64_t v = t.at(i, c);
      if (v < 0 || static_cast<std::size_t>(v) >= mesh.vertices.size())
        throw Error(ErrorCode::invalid_argument,
                    fmt::format("triangles[{}]: vertex index {} out of range (there are {} vertices)", i, v,
                                mesh.vertices.size()));
      tri[static_cast<std::size_t>(c)] = static_cast<std::uint32_t>(v);
    }
    mesh.triangles.push_back(tri);
  }
  std::vector<Eigen::Vector3d> n;
  if (!normals.is_none()) {
    n = points_of(normals, "normals");
    if (n.size() != mesh.vertices.size())
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("normals: expected one per vertex ({}), got {}", mesh.vertices.size(), n.size()));
  }
  py::gil_scoped_release release;
  save_mesh(path, mesh, n);
}

MemoryDict memory_of(const py::object& scene, const std::optional<py::dict>& overrides) {
  const std::vector<std::string> o = overrides ? override_strings(*overrides) : std::vector<std::string>{};
  const SceneDesc desc = py::isinstance<py::dict>(scene)
                             ? parse_scene(toml_text(scene.cast<py::dict>()), "World(desc)", o)
                             : load_scene(py::str(scene).cast<std::string>(), o);
  const MemoryEstimate e = estimate_memory(desc.world);
  MemoryDict d;
#define HAUSTRA_PUT_FIELD(type, name, initial, meaning) d[#name] = e.name;
  HAUSTRA_MEMORY_FIELDS(HAUSTRA_PUT_FIELD)
#undef HAUSTRA_PUT_FIELD
  d["available"] = available_memory();
  return d;
}

}  // namespace

void bind_functions(py::module_& m) {
  m.def("validate", &validate,
        "Runs the reference cases (`haustra validate`): a list of dicts with name, quantity, reference, value, error, "
        "tolerance, absolute, passed, note.");
  m.def("save_mesh", &save_mesh_file, py::arg("path"), py::arg("vertices"), py::arg("triangles"),
        py::arg("normals") = py::none(),
        "Writes a triangle mesh in the format of the path's extension (.obj, .ply, .stl, .glb) through the engine's "
        "writers (assimp).");
  m.def("estimate_memory", &memory_of, py::arg("scene"), py::arg("overrides") = py::none(),
        "Bytes a scene (a path or a dict) would take, estimated before building, and what the machine has available.");
}

}  // namespace haustra::python
