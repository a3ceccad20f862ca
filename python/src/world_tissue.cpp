// haustra.World's connective tissue (decision 0095): its anchors, their tensions, and dissection —
// cutting the tissue in a sphere, or letting an instrument cut as it goes.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include "haustra/world.hpp"
#include "indices.hpp"
#include "typed.hpp"
#include "views.hpp"
#include "world_bindings.hpp"
#include "world_reading.hpp"

namespace py = pybind11;

namespace haustra::python {

void bind_world_tissue(WorldClass& c) {
  c.def_property_readonly(
      "anchor_nodes",
      [](PyWorld& w) {
        return UInt32Array(w.view([](const World& x, const Keeper& k) { return rows_array(x.anchor_nodes(), 0, k); }));
      },
      "(A,) uint32: the node each anchor of connective tissue holds (an index into node_positions).");
  c.def_property_readonly(
      "anchor_targets",
      [](PyWorld& w) {
        return Float64Array(w.view([](const World& x, const Keeper& k) {
          const auto t = x.anchor_targets();
          return rows_array(std::span<const double>(t.empty() ? nullptr : t.front().data(), 3 * t.size()), 3, k);
        }));
      },
      "(A, 3) float64, m: where each anchor holds its node (its rest place, or the nearest point of its root line).");
  c.def_property_readonly(
      "anchors_intact",
      [](PyWorld& w) {
        auto world = w.locked();
        const auto intact = world->anchors_intact();
        py::array_t<bool> out(static_cast<py::ssize_t>(intact.size()));
        for (std::size_t a = 0; a < intact.size(); ++a) out.mutable_at(static_cast<py::ssize_t>(a)) = intact[a] != 0;
        return BoolArray(std::move(out));
      },
      "(A,) bool, a copy: whether each anchor still holds (False once torn or cut).");
  c.def(
      "anchor_tensions",
      [](PyWorld& w) {
        auto world = w.locked();
        py::array_t<double> out(static_cast<py::ssize_t>(world->anchor_count()));
        world->anchor_tensions(std::span<double>(out.mutable_data(), world->anchor_count()));
        return Float64Array(std::move(out));
      },
      "(A,) float64, N: each anchor's pull now (0 once torn or cut).");
  c.def(
      "cut_tissue",
      [](PyWorld& w, const ArrayLike& centre, double radius) {
        return w.locked()->cut_tissue(vector3(centre, "centre"), radius);
      },
      py::arg("centre"), py::arg("radius"),
      "Cuts every anchor whose tissue (from its node to its target) passes within `radius` (m) of `centre`, "
      "records a 'cut' event per range, and returns how many it cut.");
  c.def(
      "set_instrument_cutting",
      [](PyWorld& w, IndexArg instrument, bool cutting) {
        auto world = w.locked();
        world->set_instrument_cutting(instrument_index(world.world, instrument, "set_instrument_cutting"), cutting);
      },
      py::arg("instrument"), py::arg("cutting"),
      "While on, the instrument cuts the connective tissue within its cut radius of its tip every step. Hands it "
      "from its script to the caller for good.");
}

}  // namespace haustra::python
