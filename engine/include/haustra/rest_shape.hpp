#pragma once
// Rest shapes: section lengths and node rest strains (κ̂1, κ̂2, τ̂, ε̂) whose forward sweep is the
// rod's unloaded shape.
//
// From a measured centreline, an exact reproduction of every sample is ill-posed for a shear-free
// rod: the tangent at each node is forced by the previous sections, and noise at the voxel scale
// grows into zig-zag curvature. Instead the polyline is resampled at ⌈N/2⌉+1 points with smooth
// tangents, and each interval between two samples is a *biarc*: two circular, torsion-free
// sections meeting with a common tangent (G¹ Hermite interpolation). The rod then passes exactly
// through every sample with the sampled tangent, its frames are rotation-minimizing by
// construction (τ̂ = 0), and its curvature is piecewise constant. See
// docs/decisions/0004-rest-shape-biarcs.md.
#include <span>
#include <string>
#include <vector>

#include "haustra/kernels/pose.hpp"

namespace haustra {

struct RestShape {
  std::vector<double> section_length;  // N values, m
  std::vector<double> strain;          // 4 (N+1) values, interleaved (κ1, κ2, τ, ε)
  kernels::Pose base;                  // pose of node 0
  double length = 0.0;
  double node_deviation = 0.0;      // m, interpolation samples vs reconstructed nodes
  double polyline_deviation = 0.0;  // m, source vertices vs the reconstructed rod curve
};

RestShape rest_shape_constant_strain(int nodes, double length, const Eigen::Vector3d& curvature_torsion,
                                     const kernels::Pose& base);

// points in metres; `source` names them in error messages. normal_hint orients d1 at node 0.
RestShape rest_shape_from_centreline(std::span<const Eigen::Vector3d> points, int nodes,
                                     const Eigen::Vector3d& normal_hint, const std::string& source);

// Nodal strains q with ½(q_k + q_{k+1}) = section_strain_k exactly. The one free constant (the
// alternating null-space component) is chosen to keep q closest, in the least-squares sense, to
// the mean of the adjacent sections. section_strain: 4N values; returns 4(N+1).
std::vector<double> node_strains_from_sections(std::span<const double> section_strain,
                                               std::span<const double> section_length);

// Largest distance from each point to the rod curve given by section lengths, node strains and
// base (the curve sampled finely within each section). Metres.
double max_distance_to_rod(std::span<const Eigen::Vector3d> points, std::span<const double> section_length,
                           std::span<const double> strain, const kernels::Pose& base);

}  // namespace haustra
