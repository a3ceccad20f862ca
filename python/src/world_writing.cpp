// Writing a haustra.World's state from arrays (decision 0102): strains, node poses or positions, a
// base pose, many nodes' loads in one call, loads per metre along a segment.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <fmt/format.h>

#include <string>
#include <vector>

#include "haustra/error.hpp"
#include "haustra/world.hpp"
#include "indices.hpp"
#include "typed.hpp"
#include "world_bindings.hpp"
#include "world_reading.hpp"

namespace py = pybind11;

namespace haustra::python {
namespace {

using Doubles = py::array_t<double, py::array::c_style | py::array::forcecast>;

std::string shape_text(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t d = 0; d < a.ndim(); ++d) s += fmt::format("{}{}", d ? ", " : "", a.shape(d));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

// A C-contiguous float64 array of shape (rows, columns) from anything NumPy reads; else
// InvalidArgumentError naming the call, the argument and both shapes. rows < 0: any number of rows.
Doubles rows_of(const py::object& value, py::ssize_t rows, py::ssize_t columns, const char* call, const char* what) {
  Doubles a;
  try {
    a = Doubles::ensure(value);
  } catch (const py::error_already_set&) {
  }
  if (!a) {
    PyErr_Clear();
    throw Error(ErrorCode::invalid_argument, fmt::format("{}: {} must be an array of numbers", call, what));
  }
  if (a.ndim() != 2 || (rows >= 0 && a.shape(0) != rows) || a.shape(1) != columns)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("{}: {} has shape {}; expected ({}, {})", call, what, shape_text(a),
                            rows >= 0 ? std::to_string(rows) : std::string("k"), columns));
  return a;
}

struct Soa3 {
  std::vector<double> x, y, z;
  [[nodiscard]] kernels::Vec3View<const double> view() const { return {x, y, z}; }
};

Soa3 soa3(const Doubles& a) {
  const auto n = static_cast<std::size_t>(a.shape(0));
  Soa3 out{std::vector<double>(n), std::vector<double>(n), std::vector<double>(n)};
  const double* p = a.data();
  for (std::size_t k = 0; k < n; ++k) out.x[k] = p[3 * k], out.y[k] = p[3 * k + 1], out.z[k] = p[3 * k + 2];
  return out;
}

std::span<const double> flat(const Doubles& a) { return {a.data(), static_cast<std::size_t>(a.size())}; }

// Node indices from an int array: negative from the end, each in range, else InvalidIndexError.
std::vector<std::uint32_t> node_indices(const World& world, const py::object& nodes, const char* call) {
  const py::array given = py::array::ensure(nodes);
  if (!given || given.ndim() != 1 || !(given.size() == 0 || given.dtype().kind() == 'i' || given.dtype().kind() == 'u'))
    throw Error(ErrorCode::invalid_argument, fmt::format("{}: nodes must be a one-dimensional sequence of ints", call));
  const auto a = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(given);
  const auto count = static_cast<std::int64_t>(world.node_count());
  std::vector<std::uint32_t> out(static_cast<std::size_t>(a.size()));
  for (py::ssize_t i = 0; i < a.size(); ++i) {
    const std::int64_t k = a.data()[i];
    if (k < -count || k >= count)
      throw IndexOutOfRange(
          fmt::format("{}: nodes[{}] = {} is out of range (the world has {} nodes: 0 to {}, or "
                      "-{} to -1 from the end)",
                      call, i, k, count, count - 1, count));
    out[static_cast<std::size_t>(i)] = static_cast<std::uint32_t>(k < 0 ? k + count : k);
  }
  return out;
}

}  // namespace

void bind_world_writing(WorldClass& c) {
  c.def(
      "set_strains",
      [](PyWorld& w, const ArrayLike& strains) {
        auto world = w.locked();
        const Doubles a = rows_of(strains, static_cast<py::ssize_t>(world->node_count()), 4, "set_strains", "strains");
        world->set_strains(flat(a));
      },
      py::arg("strains"),
      "Writes every node's strains, an (N, 4) array (κ1, κ2 in 1/m, τ in 1/m, ε), as `strains` reads them: each "
      "rod's configuration is its base pose and its strains, so its node positions and frames are rebuilt from them "
      "(and the meshes). Checked first (shape, finite, ε > -1); the velocities then read zero, as after a "
      "checkpoint's restore.");
  c.def(
      "set_node_poses",
      [](PyWorld& w, const ArrayLike& positions, const ArrayLike& rotations, double shear_tolerance) {
        auto world = w.locked();
        const auto n = static_cast<py::ssize_t>(world->node_count());
        const Soa3 p = soa3(rows_of(positions, n, 3, "set_node_poses", "positions"));
        const Doubles r = rows_of(rotations, n, 4, "set_node_poses", "rotations");
        std::vector<double> q(4 * static_cast<std::size_t>(n));
        for (py::ssize_t k = 0; k < n; ++k)
          for (py::ssize_t j = 0; j < 4; ++j) q[static_cast<std::size_t>(j * n + k)] = r.data()[4 * k + j];
        const std::span<const double> qs(q);
        const auto un = static_cast<std::size_t>(n);
        world->set_node_poses(p.view(),
                              {qs.subspan(0, un), qs.subspan(un, un), qs.subspan(2 * un, un), qs.subspan(3 * un, un)},
                              shear_tolerance);
      },
      py::arg("positions"), py::arg("rotations"), py::arg("shear_tolerance") = 1e-6,
      "Writes every node's pose: positions (N, 3), m, and frames (N, 4) unit quaternions w x y z, as node_positions "
      "and node_rotations read them. Node 0 of each rod becomes its base; each section's strain is the logarithm of "
      "its two nodes' relative pose over its rest length. The rod is unshearable: a section whose poses shear it by "
      "more than shear_tolerance of its length is refused, naming it, and nothing is written.");
  c.def(
      "set_node_positions",
      [](PyWorld& w, const ArrayLike& positions) {
        auto world = w.locked();
        const Soa3 p = soa3(
            rows_of(positions, static_cast<py::ssize_t>(world->node_count()), 3, "set_node_positions", "positions"));
        world->set_node_positions(p.view());
      },
      py::arg("positions"),
      "Places every rod through these points, (N, 3), m: node positions are not free in this model (they follow "
      "from the base pose and the strains), so the configuration that passes through them is found — frames that "
      "turn least from point to point (no twist), each section an arc to the next point, its stretch from the "
      "distance. Refused (nothing written) where points coincide or a section would turn by more than 90 degrees.");
  c.def(
      "set_base_pose",
      [](PyWorld& w, IndexArg segment, const ArrayLike& position, const ArrayLike& rotation) {
        auto world = w.locked();
        const std::size_t s = segment_index(world.world, segment, "set_base_pose");
        const Doubles q = Doubles::ensure(rotation);
        if (!q || q.ndim() != 1 || q.shape(0) != 4) {
          PyErr_Clear();
          throw Error(ErrorCode::invalid_argument,
                      "set_base_pose: rotation must be 4 numbers, a unit quaternion (w, x, y, z)");
        }
        const Eigen::Quaterniond rot(q.data()[0], q.data()[1], q.data()[2], q.data()[3]);
        if (!rot.coeffs().allFinite() || std::abs(rot.norm() - 1.0) > 1e-6)
          throw Error(
              ErrorCode::invalid_argument,
              fmt::format("set_base_pose: rotation has norm {}: expected a unit quaternion (w, x, y, z)", rot.norm()));
        world->set_base_pose(s, {rot, vector3(position, "position")});
      },
      py::arg("segment"), py::arg("position"), py::arg("rotation"),
      "Moves a rod's base (a chain's, through any of its pieces) to position (m) and rotation (a unit quaternion w x y "
      "z), its strains kept: the rod moves rigidly.");
  c.def(
      "set_external_loads",
      [](PyWorld& w, const py::object& nodes, const ArrayLike& forces, const ArrayLike& moments, bool add) {
        auto world = w.locked();
        const std::vector<std::uint32_t> k = node_indices(world.world, nodes, "set_external_loads");
        const auto count = static_cast<py::ssize_t>(k.size());
        const Doubles f = rows_of(forces, count, 3, "set_external_loads", "forces");
        Doubles m;
        if (!moments.is_none()) m = rows_of(moments, count, 3, "set_external_loads", "moments");
        world->set_external_loads(k, flat(f), moments.is_none() ? std::span<const double>() : flat(m), add);
      },
      py::arg("nodes"), py::arg("forces"), py::arg("moments") = py::none(), py::arg("add") = false,
      "Loads on many nodes in one call: nodes (k,) ints (negative from the end), forces (k, 3), N, and moments (k, 3), "
      "N·m (None: zero), world frame, held until changed. add=False replaces what the nodes held (a node listed twice "
      "gets the sum of its rows); add=True adds to it.");
  c.def(
      "set_distributed_load",
      [](PyWorld& w, IndexArg segment, const ArrayLike& force, const ArrayLike& moment, bool add) {
        auto world = w.locked();
        const std::size_t s = segment_index(world.world, segment, "set_distributed_load");
        const auto n = static_cast<py::ssize_t>(world->segment(s).nodes.count);
        auto per_node = [n](const py::object& value) {  // (3,) for a uniform load, else (n, 3)
          const py::array a = py::array::ensure(value);
          if (a && a.ndim() == 1 && a.shape(0) == 3)
            return py::object(py::module_::import("numpy").attr("tile")(a, py::make_tuple(n, 1)));
          return value;
        };
        const Doubles f = rows_of(per_node(force), n, 3, "set_distributed_load", "force");
        Doubles m;
        if (!moment.is_none()) m = rows_of(per_node(moment), n, 3, "set_distributed_load", "moment");
        world->set_distributed_load(s, flat(f), moment.is_none() ? std::span<const double>() : flat(m), add);
      },
      py::arg("segment"), py::arg("force"), py::arg("moment") = py::none(), py::arg("add") = false,
      "A load per metre of rest length along a segment: force in N/m and moment in N·m/m (None: zero), world frame, "
      "either (3,) for a uniform load or (n, 3), one row per node of the segment. Lumped onto its nodes by their "
      "share of the rest length (half of each section beside them) and set there as set_external_loads does "
      "(add=False replaces what those nodes held).");
}

}  // namespace haustra::python
