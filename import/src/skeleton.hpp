#pragma once
// A surface's curve skeleton by CGAL's mean-curvature-flow skeletonization (the paper's automatic
// centreline, its ref. [5]), after CGAL's hole filling closes the open ends; the longest path
// through the skeleton is the organ's centreline.
#include <Eigen/Core>
#include <vector>

#include "haustra/mesh_io.hpp"

namespace haustra::import {

struct SkeletonResult {
  std::vector<Eigen::Vector3d> path;  // mesh units, from one end to the other
  int holes_filled = 0;
  std::size_t skeleton_vertices = 0, branches = 0;  // branches: skeleton vertices of degree ≥ 3
  double seconds = 0.0;
};

// Throws Error{invalid_geometry} when the surface cannot be made a closed 2-manifold or has no
// skeleton to speak of.
SkeletonResult skeleton_path(const TriangleMesh& mesh, const std::string& where);

}  // namespace haustra::import
