#pragma once
// The axis of a tube-shaped surface from a harmonic function on it: u = 0 on one end (an open end's
// rim, or a closed end's tip), 1 on the other, Laplace's equation between. Its level sets are the
// tube's cross-sections, their area centroids the centreline, and u gives every vertex a place
// along the tube that is smooth and never folds, wherever loops touch (docs/decisions/0049).
#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <vector>

#include "haustra/mesh_io.hpp"

namespace haustra {

// The boundary loops of a manifold mesh, each as its vertices in order.
std::vector<std::vector<std::uint32_t>> boundary_loops(const TriangleMesh& mesh);

// One end of a tube: an open end (the vertices of its boundary loops: one, or concentric ones
// where a wall of two shells is cut, its outer rim and its lumen's) or a closed end (its tip vertex).
struct TubeEnd {
  std::vector<std::uint32_t> vertices;
  bool open = false;
  std::vector<int> loops;  // indices into the loops it came from; empty for a tip
  [[nodiscard]] bool has_loop(std::size_t l) const {
    for (int k : loops)
      if (static_cast<std::size_t>(k) == l) return true;
    return false;
  }
};

// A boundary loop's mean point, mean distance of its vertices from it, and length.
struct LoopShape {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radius = 0.0, perimeter = 0.0;
};
LoopShape loop_shape(const TriangleMesh& mesh, const std::vector<std::uint32_t>& loop);

// Boundary loops grouped into ends: loops whose centres lie within half the larger one's radius
// of each other (a walled tube's outer rim and lumen rim) are one end. Per loop, its group's number.
std::vector<int> loop_groups(const TriangleMesh& mesh, const std::vector<std::vector<std::uint32_t>>& loops);

// The open end that loop `loop` belongs to (with its concentric loops).
TubeEnd loop_end(const TriangleMesh& mesh, const std::vector<std::vector<std::uint32_t>>& loops, int loop);

// Geodesic distances over the mesh's edges from a set of vertices (Dijkstra, ties by index).
std::vector<double> edge_distances(const TriangleMesh& mesh, const std::vector<std::uint32_t>& from);

// The two ends farthest apart along the surface: from `start` if given, else from the extremity
// found by sweeping from vertex 0; the far end is the farthest vertex's loop, or that vertex.
std::pair<TubeEnd, TubeEnd> farthest_ends(const TriangleMesh& mesh,
                                          const std::vector<std::vector<std::uint32_t>>& loops,
                                          const std::optional<TubeEnd>& start);

struct CrossSection {
  double u = 0.0;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // area centroid of the level's contour
  double area = 0.0;                                 // enclosed, projected on its best plane
};

struct TubeAxis {
  TubeEnd start, end;
  std::vector<double> u;               // per mesh vertex: 0 at the start, 1 at the end
  std::vector<CrossSection> sections;  // by ascending u, from the start's rim or tip to the end's
  int capped_loops = 0;                // other boundary loops (side openings, holes) capped for the solve
  double geodesic_length = 0.0;        // between the ends, along the surface's edges
};

// Throws Error{invalid_geometry} when the ends coincide or the surface is not connected between them.
// `spacing`: the largest gap wanted between consecutive section centres (levels are refined until met;
// a level at each vertex's u besides, so a loop hanging from a fusion within a sliver of u is crossed).
TubeAxis tube_axis(const TriangleMesh& mesh, const std::vector<std::vector<std::uint32_t>>& loops, const TubeEnd& start,
                   const TubeEnd& end, double spacing);

// One contour per level, the levels by ascending u, each a level's closed contours (one along a
// simple tube, several where loops are fused into handles): the longest line through their centres
// that steps only from a contour to its continuation on the next level (one is the other's nearest,
// within a few `spacing`s or the larger contour's size), so it follows the tube round its loops
// rather than across a fusion, and never zigzags between parallel contours. Only steps within a few
// `spacing`s count: a jump where contours split or merge is allowed but adds nothing.
std::vector<CrossSection> section_path(const std::vector<std::vector<CrossSection>>& levels, double spacing);

// The value of a monotone table (xs ascending) at x, linear between entries, clamped at its ends.
double interpolate(const std::vector<double>& xs, const std::vector<double>& ys, double x);

}  // namespace haustra
