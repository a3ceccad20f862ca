// haustra.World's zero-copy arrays: read-only NumPy views over the engine's own buffers, live
// (they show the state after the last completed step; see the module doc).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include "haustra/world.hpp"
#include "typed.hpp"
#include "views.hpp"
#include "world_bindings.hpp"

namespace py = pybind11;

namespace haustra::python {
namespace {

// A read-only property over one buffer: `make` turns the world and its keeper into the array.
template <class Typed, class F>
void view_property(WorldClass& c, const char* name, F make, const char* doc) {
  c.def_property_readonly(
      name, [make](PyWorld& w) { return Typed(w.view(make)); }, doc);
}

// The same over a mesh buffer, which the engine makes when read: stepping keeps it live from then on.
template <class Typed, class F>
void mesh_view_property(WorldClass& c, const char* name, F make, const char* doc) {
  c.def_property_readonly(
      name,
      [make](PyWorld& w) {
        w.mesh_viewed();
        return Typed(w.view(make));
      },
      doc);
}

void bind_rod_views(WorldClass& c) {
  view_property<Float64Array>(
      c, "node_positions", [](const World& x, const Keeper& k) { return vec3_array(x.node_positions(), k); },
      "(N, 3) float64, m: every node, segments one after another. A live view (see the module doc).");
  view_property<Float64Array>(
      c, "node_rotations", [](const World& x, const Keeper& k) { return rotation_array(x.node_rotations(), k); },
      "(N, 4) float64: each node's material frame (directors d1 d2 d3: the columns of its rotation) as a unit "
      "quaternion w, x, y, z, body to world. A live view; `directors` gives the 3 × 3 matrices.");
  view_property<Float64Array>(
      c, "strains", [](const World& x, const Keeper& k) { return rows_array(x.strains().data, 4, k); },
      "(N, 4) float64: κ1, κ2 (1/m), τ (1/m), ε per node. A live view.");
  view_property<Float64Array>(
      c, "rest_strains", [](const World& x, const Keeper& k) { return rows_array(x.rest_strains().data, 4, k); },
      "(N, 4) float64: the rest shape's strains.");
  view_property<Float64Array>(
      c, "section_lengths", [](const World& x, const Keeper& k) { return rows_array(x.section_lengths(), 0, k); },
      "(N,) float64, m: section k at node k.");
}

void bind_bead_views(WorldClass& c) {
  view_property<Float64Array>(
      c, "bead_centres", [](const World& x, const Keeper& k) { return vec3_array(x.bead_centres(), k); },
      "(B, 3) float64, m: bead centres after the last step. A live view.");
  view_property<Float64Array>(
      c, "bead_radii", [](const World& x, const Keeper& k) { return rows_array(x.bead_radii(), 0, k); },
      "(B,) float64, m: each bead's radius.");
  view_property<UInt32Array>(
      c, "bead_nodes", [](const World& x, const Keeper& k) { return rows_array(x.bead_nodes(), 0, k); },
      "(B,) uint32: each bead's node (an index into node_positions).");
}

void bind_mesh_views(WorldClass& c) {
  mesh_view_property<Float32Array>(
      c, "mesh_positions", [](const World& x, const Keeper& k) { return vec3_array(x.mesh_positions(), k); },
      "(V, 3) float32, m: every segment's organ mesh vertices. A live view.");
  mesh_view_property<Float32Array>(
      c, "mesh_normals", [](const World& x, const Keeper& k) { return vec3_array(x.mesh_normals(), k); },
      "(V, 3) float32: unit vertex normals. A live view.");
  view_property<UInt32Array>(
      c, "mesh_triangles", [](const World& x, const Keeper& k) { return triangles_array(x.mesh_triangles(), k); },
      "(T, 3) uint32: indices into mesh_positions.");
}

}  // namespace

void bind_world_views(WorldClass& c) {
  bind_rod_views(c);
  bind_bead_views(c);
  bind_mesh_views(c);
}

}  // namespace haustra::python
