#pragma once
// Centreline geometry for import: resampling by arc length, Gaussian smoothing, where the mesh
// surrounds it (rays in its normal planes), radii of curvature, and parts whose walls touch.
#include <Eigen/Core>
#include <vector>

#include "haustra/embree_scene.hpp"

namespace haustra::import {

using Polyline = std::vector<Eigen::Vector3d>;

double polyline_length(const Polyline& p);
// Points every `spacing` of arc length from the first to the last (both kept).
Polyline resample(const Polyline& p, double spacing);
// Gaussian of width sigma (arc length) over evenly spaced points; the window shrinks to stay
// symmetric at the ends, so the end points stay where they are.
Polyline smooth(const Polyline& p, double spacing, double sigma);

struct Coverage {
  std::vector<bool> covered;   // at least min_hits of 16 rays in the normal plane meet the mesh
  std::vector<double> radius;  // median distance to the wall where they do (0 where not covered)
};
Coverage coverage(const EmbreeScene& wall, const Polyline& p, double reach, int min_hits = 12);

// Spurs cut: a point that would make the line turn back on itself (its step against the one before)
// removes the points before it until the line runs forward again.
Polyline remove_backtracks(const Polyline& p);

// Radius of curvature at every point, from the circle through the points ±half_window away.
std::vector<double> bend_radii(const Polyline& p, double spacing, double half_window);

// Pairs of places, far apart along the centreline (more than `apart`) but closer than `near` in
// space, one pair per touching stretch: (arc of one, arc of the other), m.
std::vector<std::pair<double, double>> touching_parts(const Polyline& p, double spacing, double apart, double near);

}  // namespace haustra::import
