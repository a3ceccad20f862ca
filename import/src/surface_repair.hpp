#pragma once
// What segmentations produce, repaired by CGAL's Polygon Mesh Processing before anything else
// looks at a surface: duplicate points and triangles, degenerate triangles, edges of three or more
// triangles and pinched vertices, triangles facing the wrong way, small floating pieces; and
// self-intersections counted. Each repair is counted for the report.
#include <cstddef>
#include <string>
#include <vector>

#include "haustra/mesh_io.hpp"

namespace haustra::import {

struct RepairReport {
  std::size_t merged_points = 0;          // duplicate points joined
  std::size_t dropped_triangles = 0;      // repeated-vertex, duplicate or zero-area triangles
  std::size_t non_manifold_edges = 0;     // edges of three or more triangles, split apart
  std::size_t non_manifold_vertices = 0;  // pinched vertices, split into one per fan
  std::size_t reversed_triangles = 0;     // turned to face the way their neighbours do
  std::size_t small_pieces = 0;           // floating pieces removed (under 2 % of the largest's area)
  std::size_t small_piece_triangles = 0;
  std::size_t self_intersections = 0;      // pairs of triangles that cross (counted, not changed)
  std::size_t degenerate_left = 0;         // triangles with no area the collapse could not remove
  [[nodiscard]] std::string text() const;  // one line: what was repaired, or "nothing to repair"
};

struct RepairedSurface {
  std::vector<TriangleMesh> pieces;  // the connected pieces, each wound consistently, largest area first
  RepairReport report;
};

// Throws Error{invalid_geometry} when nothing is left (no triangle with an area).
RepairedSurface repair_surface(const TriangleMesh& raw, const std::string& where);

}  // namespace haustra::import
