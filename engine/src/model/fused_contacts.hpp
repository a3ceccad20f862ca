#pragma once
// Where a segmentation fused two loops of an organ into one wall, the surface cut back into two walls
// (issue 35): each loop keeps its own copies of the vertices on the cut.
#include <cstdint>
#include <span>
#include <vector>

#include "haustra/mesh_io.hpp"

namespace haustra::detail {

struct FusedCut {
  std::size_t vertices_cut = 0;  // vertices that got copies
  std::size_t copies = 0;        // copies added (at the end of the vertex list; a vertex cut three ways has 2)
};

// `place`: each vertex's place along the rod (m; the whole surface's harmonic places). Triangles are
// grouped round each vertex by their place (the median of their corners'); where two groups are more
// than `jump` apart along the rod, and ten times the longest edge round the vertex — a wall that the
// places say belongs to two loops, not a tight bend of one nor a coarse triangle — the vertex gets a
// copy per group beyond its own, placed near that group (the closest point of the centreline
// `samples` within `jump` of it), and the group's triangles take the copy. The copies are appended
// (with their places), so vertex v < the old count is still the file's v.
FusedCut cut_fused_contacts(TriangleMesh& mesh, std::vector<double>& place, double jump,
                            std::span<const Eigen::Vector3d> samples, double length);

}  // namespace haustra::detail
