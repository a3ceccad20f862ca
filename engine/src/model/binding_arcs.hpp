#pragma once
// Each mesh vertex's place along a centreline (arc length from its first point), for binding the
// mesh to a cage without folds where the organ's loops touch or bend tightly (decision 0049): per
// connected piece of the mesh, u from a harmonic function between its two ends, its sections placed
// on the centreline by their closest points (each searched near the one before), every vertex
// placed by its u; where u is all but constant, a vertex is placed from its neighbours.
#include <Eigen/Core>
#include <span>
#include <vector>

#include "haustra/mesh_io.hpp"
#include "haustra/rod_curve.hpp"

namespace haustra::detail {

struct BindingArcs {
  std::vector<double> arc;         // per mesh vertex, m
  std::size_t pieces = 0;          // connected pieces of the mesh
  std::size_t closest_pieces = 0;  // pieces placed by each vertex's closest point (no two ends, or all astray)
  std::size_t followed = 0;        // vertices the harmonic function passed by, placed from their neighbours
};
// Points evenly spaced along a rod's rest centreline (one per half millimetre, 64 at least), the
// first at arc 0, the last at its length: what the places below are measured on.
std::vector<Eigen::Vector3d> centreline_samples(const RodCurve& curve);

// `samples`: points evenly spaced along the centreline, the first at arc 0, the last at `length`.
BindingArcs harmonic_binding_arcs(const TriangleMesh& mesh, std::span<const Eigen::Vector3d> samples, double length);

// The arc length of the point of a sampled centreline (as above) closest to x.
double closest_arc(std::span<const Eigen::Vector3d> samples, double length, const Eigen::Vector3d& x);
// The same among the points whose arc length lies in [lo, hi].
double closest_arc_within(std::span<const Eigen::Vector3d> samples, double length, const Eigen::Vector3d& x, double lo,
                          double hi);

}  // namespace haustra::detail
