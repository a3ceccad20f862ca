// Repairs of a segmented surface by CGAL's Polygon Mesh Processing, counted as they are made.
#include "surface_repair.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/connected_components.h>
#include <CGAL/Polygon_mesh_processing/manifoldness.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair_degeneracies.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>
#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <numeric>

#include "haustra/error.hpp"

namespace haustra::import {
namespace {

// Exact predicates: with plain doubles, coplanar neighbours sharing an edge test as crossing (a clean
// cylinder read 681 crossings) and near-collinear triangles as degenerate or not by rounding.
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;
namespace PMP = CGAL::Polygon_mesh_processing;

struct OrientationCounter : PMP::Default_orientation_visitor {
  std::size_t* edges;
  std::size_t* vertices;
  std::size_t* reversed;
  void non_manifold_edge(std::size_t, std::size_t, std::size_t) { ++*edges; }
  void non_manifold_vertex(std::size_t, std::size_t) { ++*vertices; }
  void polygon_orientation_reversed(std::size_t) { ++*reversed; }
};

TriangleMesh to_triangles(const Mesh& mesh) {
  TriangleMesh out;
  std::vector<std::uint32_t> index(mesh.number_of_vertices() + mesh.number_of_removed_vertices(), 0);
  for (Mesh::Vertex_index v : mesh.vertices()) {
    index[v.idx()] = static_cast<std::uint32_t>(out.vertices.size());
    const Point& p = mesh.point(v);
    out.vertices.emplace_back(p.x(), p.y(), p.z());
  }
  for (Mesh::Face_index f : mesh.faces()) {
    std::array<std::uint32_t, 3> t{};
    std::size_t i = 0;
    for (Mesh::Vertex_index v : CGAL::vertices_around_face(mesh.halfedge(f), mesh))
      if (i < 3) t[i++] = index[v.idx()];
    if (i == 3) out.triangles.push_back(t);
  }
  return out;
}

}  // namespace

std::string RepairReport::text() const {
  std::vector<std::string> parts;
  if (merged_points > 0) parts.push_back(fmt::format("{} duplicate points joined", merged_points));
  if (dropped_triangles > 0)
    parts.push_back(fmt::format("{} degenerate or duplicate triangles removed", dropped_triangles));
  if (non_manifold_edges > 0)
    parts.push_back(fmt::format("{} edges of three or more triangles split", non_manifold_edges));
  if (non_manifold_vertices > 0) parts.push_back(fmt::format("{} pinched vertices split", non_manifold_vertices));
  if (reversed_triangles > 0)
    parts.push_back(fmt::format("{} triangles turned to face the way their neighbours do", reversed_triangles));
  if (small_pieces > 0)
    parts.push_back(fmt::format("{} small floating piece{} removed ({} triangles)", small_pieces,
                                small_pieces == 1 ? "" : "s", small_piece_triangles));
  std::string t = parts.empty() ? "nothing to repair" : fmt::format("{}", fmt::join(parts, ", "));
  if (self_intersections > 0)
    t += fmt::format("; {} pairs of triangles cross each other (left as they are)", self_intersections);
  if (degenerate_left > 0)
    t += fmt::format("; {} triangles with no area could not be collapsed (left as they are)", degenerate_left);
  return t;
}

RepairedSurface repair_surface(const TriangleMesh& raw, const std::string& where) {
  RepairedSurface out;
  RepairReport& r = out.report;
  std::vector<Point> points;
  points.reserve(raw.vertices.size());
  for (const auto& v : raw.vertices) points.emplace_back(v.x(), v.y(), v.z());
  std::vector<std::vector<std::size_t>> faces;
  faces.reserve(raw.triangles.size());
  for (const auto& t : raw.triangles) faces.push_back({t[0], t[1], t[2]});

  // The soup: duplicate points joined, triangles that repeat a point or another triangle dropped.
  const std::size_t points_before = points.size(), faces_before = faces.size();
  PMP::merge_duplicate_points_in_polygon_soup(points, faces);
  r.merged_points = points_before - points.size();
  PMP::repair_polygon_soup(points, faces);
  r.dropped_triangles = faces_before - faces.size();
  // One winding per piece; what cannot be wound consistently (an edge of three triangles, a
  // pinched vertex) is split apart by duplicating its points.
  OrientationCounter counter;
  counter.edges = &r.non_manifold_edges;
  counter.vertices = &r.non_manifold_vertices;
  counter.reversed = &r.reversed_triangles;
  PMP::orient_polygon_soup(points, faces, CGAL::parameters::visitor(counter));
  Mesh mesh;
  PMP::polygon_soup_to_polygon_mesh(points, faces, mesh);
  // Triangles with no area (three points on a line): collapsed into their neighbours.
  const std::size_t with_degenerate = mesh.number_of_faces();
  const bool all_degenerate_removed = PMP::remove_degenerate_faces(mesh);
  r.non_manifold_vertices += PMP::duplicate_non_manifold_vertices(mesh);
  mesh.collect_garbage();
  r.dropped_triangles += with_degenerate - mesh.number_of_faces();
  if (!all_degenerate_removed)
    for (Mesh::Face_index f : mesh.faces()) r.degenerate_left += PMP::is_degenerate_triangle_face(f, mesh) ? 1 : 0;
  if (mesh.number_of_faces() == 0)
    throw Error(ErrorCode::invalid_geometry,
                fmt::format("{}: no triangle with an area is left after repairing the surface", where));

  // Pieces by area; those under 2 % of the largest are floating debris of the segmentation.
  auto component = mesh.add_property_map<Mesh::Face_index, std::size_t>("f:component", 0).first;
  const std::size_t count = PMP::connected_components(mesh, component);
  std::vector<double> area(count, 0.0);
  std::vector<std::size_t> triangles(count, 0);
  for (Mesh::Face_index f : mesh.faces()) {
    area[component[f]] += PMP::face_area(f, mesh);
    ++triangles[component[f]];
  }
  const double largest = *std::max_element(area.begin(), area.end());
  std::vector<std::size_t> keep;
  for (std::size_t c = 0; c < count; ++c) {
    if (area[c] >= 0.02 * largest) {
      keep.push_back(c);
    } else {
      ++r.small_pieces;
      r.small_piece_triangles += triangles[c];
    }
  }
  std::vector<std::pair<Mesh::Face_index, Mesh::Face_index>> crossing;
  PMP::keep_connected_components(mesh, keep, component);
  mesh.collect_garbage();
  PMP::self_intersections(mesh, std::back_inserter(crossing));
  r.self_intersections = crossing.size();

  // Pieces, largest area first (ties: in CGAL's component order).
  std::vector<Mesh> split;
  PMP::split_connected_components(mesh, split);
  std::vector<TriangleMesh> pieces;
  for (const Mesh& m : split) pieces.push_back(to_triangles(m));
  std::vector<double> piece_area(pieces.size(), 0.0);
  for (std::size_t p = 0; p < pieces.size(); ++p)
    for (const auto& t : pieces[p].triangles)
      piece_area[p] += 0.5 * (pieces[p].vertices[t[1]] - pieces[p].vertices[t[0]])
                                 .cross(pieces[p].vertices[t[2]] - pieces[p].vertices[t[0]])
                                 .norm();
  std::vector<std::size_t> order(pieces.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return piece_area[a] > piece_area[b]; });
  for (std::size_t p : order) out.pieces.push_back(std::move(pieces[p]));
  return out;
}

}  // namespace haustra::import
