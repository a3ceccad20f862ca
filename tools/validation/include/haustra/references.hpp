#pragma once
// Independent reference solutions for the validation cases. None of these uses the engine: they
// solve the continuum problems directly (closed forms, or ODE shooting with RK4).

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

}  // namespace haustra::reference
