#pragma once
// Independent reference solutions for the validation cases. None of these uses the engine: they
// solve the continuum problems directly (closed forms, or ODE shooting with RK4).
#include <Eigen/Core>
#include <span>
#include <vector>

namespace haustra::reference {

struct PlanarPoint {
  double x = 0.0;  // along the undeformed rod
  double z = 0.0;  // transverse, positive up
};

// Tip of an inextensible cantilever of length 1, clamped horizontally at the origin, under a
// vertical dead load at the tip with P L²/B = load_parameter (pointing down). Planar Kirchhoff
// rod B θ'' = −P cos θ, θ(0) = 0, θ'(1) = 0, solved by shooting on θ'(0) (bisection) with RK4.
PlanarPoint elastica_cantilever_tip(double load_parameter, int steps = 20000);

// Small-deflection cantilever tip deflection P L³ / (3 B).
double cantilever_tip_deflection(double load, double length, double bending_stiffness);

// Clamped–clamped beam of span L under uniform load q (N/m, downward): deflection at x,
// w = q x² (L − x)² / (24 B), positive down.
double clamped_beam_deflection(double x, double span, double load_per_length, double bending_stiffness);

// Inextensible catenary of length L hanging between supports at (0, 0) and (D, 0), D < L:
// the point at arc length s from the left support.
PlanarPoint catenary_point(double s, double length, double span);

// A rod's centreline from its base pose and node strains, by integrating the Cosserat kinematics
// x' = (1 + ε) d3, d_i' = u × d_i with RK4 — not the engine's closed-form section maps. Section k
// (length h_k) carries the mean of its end nodes' strains (docs/model.md). base_rotation holds d1,
// d2, d3 as columns. Returns `steps` points per section after the base point.
std::vector<Eigen::Vector3d> integrate_rod_centreline(const Eigen::Vector3d& base_position,
                                                      const Eigen::Matrix3d& base_rotation,
                                                      std::span<const double> section_length,
                                                      std::span<const double> strain, int steps);

// The largest distance of any of `points` from the polyline through `vertices` (brute force over
// its segments).
double farthest_from_polyline(std::span<const Eigen::Vector3d> points, std::span<const Eigen::Vector3d> vertices);

}  // namespace haustra::reference
