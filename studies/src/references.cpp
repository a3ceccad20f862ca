// Reference solutions for the validation cases, computed without the engine.
#include "haustra/studies/references.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

namespace haustra::reference {
namespace {

// State (θ, θ', x, z) of the nondimensional elastica along s ∈ [0, 1].
using State = std::array<double, 4>;

State derivative(const State& y, double alpha) {
  return {y[1], -alpha * std::cos(y[0]), std::cos(y[0]), -std::sin(y[0])};
}

State integrate(double slope0, double alpha, int steps) {
  State y{0.0, slope0, 0.0, 0.0};
  const double h = 1.0 / steps;
  auto add = [](const State& a, const State& b, double f) {
    return State{a[0] + f * b[0], a[1] + f * b[1], a[2] + f * b[2], a[3] + f * b[3]};
  };
  for (int i = 0; i < steps; ++i) {
    const State k1 = derivative(y, alpha);
    const State k2 = derivative(add(y, k1, 0.5 * h), alpha);
    const State k3 = derivative(add(y, k2, 0.5 * h), alpha);
    const State k4 = derivative(add(y, k3, h), alpha);
    for (int j = 0; j < 4; ++j)
      y[static_cast<std::size_t>(j)] += h / 6.0 *
                                        (k1[static_cast<std::size_t>(j)] + 2 * k2[static_cast<std::size_t>(j)] +
                                         2 * k3[static_cast<std::size_t>(j)] + k4[static_cast<std::size_t>(j)]);
  }
  return y;
}

}  // namespace

PlanarPoint elastica_cantilever_tip(double alpha, int steps) {
  // θ'(0) is the root moment over B, between 0 and α (the load's moment arm is at most L).
  double lo = 0.0;
  double hi = alpha;
  for (int i = 0; i < 200 && hi - lo > 1e-16 * alpha; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (integrate(mid, alpha, steps)[1] < 0.0)
      lo = mid;
    else
      hi = mid;
  }
  const State y = integrate(0.5 * (lo + hi), alpha, steps);
  return {y[2], y[3]};
}

double cantilever_tip_deflection(double load, double length, double bending_stiffness) {
  return load * length * length * length / (3.0 * bending_stiffness);
}

double clamped_beam_deflection(double x, double span, double q, double bending_stiffness) {
  return q * x * x * (span - x) * (span - x) / (24.0 * bending_stiffness);
}

PlanarPoint catenary_point(double s, double length, double span) {
  if (!(span > 0.0) || !(span < length)) throw std::invalid_argument("catenary: need 0 < span < length");
  // L = 2 a sinh(D / 2a): the left side decreases in a; bisect.
  double lo = 1e-6 * span;
  double hi = 1e6 * span;
  for (int i = 0; i < 400; ++i) {
    const double a = std::sqrt(lo * hi);
    const double arg = span / (2.0 * a);
    const double l = arg > 700.0 ? std::numeric_limits<double>::infinity() : 2.0 * a * std::sinh(arg);
    if (l > length)
      lo = a;
    else
      hi = a;
  }
  const double a = std::sqrt(lo * hi);
  const double x = 0.5 * span + a * std::asinh((s - 0.5 * length) / a);
  const double z = a * std::cosh((x - 0.5 * span) / a) - a * std::cosh(0.5 * span / a);
  return {x, z};
}

}  // namespace haustra::reference

namespace haustra::reference {

std::vector<Eigen::Vector3d> integrate_rod_centreline(const Eigen::Vector3d& base_position,
                                                      const Eigen::Matrix3d& base_rotation,
                                                      std::span<const double> section_length,
                                                      std::span<const double> strain, int steps) {
  // State: position and the frame's three directors, integrated as twelve numbers; the directors
  // drift from orthonormal by O(h⁴) per step, far below what the distances here resolve.
  using Frame = Eigen::Matrix<double, 3, 4>;  // columns d1, d2, d3, x
  Frame g;
  g << base_rotation, base_position;
  std::vector<Eigen::Vector3d> out{base_position};
  for (std::size_t k = 0; k < section_length.size(); ++k) {
    Eigen::Vector4d xi;
    for (int c = 0; c < 4; ++c)
      xi[c] = 0.5 * (strain[4 * k + static_cast<std::size_t>(c)] + strain[4 * k + 4 + static_cast<std::size_t>(c)]);
    // Material-frame curvature u = (κ1, κ2, τ): d_i' = R u × e_i, i.e. R' = R [u]×.
    Eigen::Matrix3d skew;
    skew << 0.0, -xi[2], xi[1], xi[2], 0.0, -xi[0], -xi[1], xi[0], 0.0;
    auto rate = [&](const Frame& y) {
      Frame d;
      d.leftCols<3>() = y.leftCols<3>() * skew;
      d.col(3) = (1.0 + xi[3]) * y.col(2);
      return d;
    };
    const double h = section_length[k] / steps;
    for (int i = 0; i < steps; ++i) {
      const Frame k1 = rate(g), k2 = rate(g + 0.5 * h * k1), k3 = rate(g + 0.5 * h * k2), k4 = rate(g + h * k3);
      g += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
      out.emplace_back(g.col(3));
    }
  }
  return out;
}

double farthest_from_polyline(std::span<const Eigen::Vector3d> points, std::span<const Eigen::Vector3d> vertices) {
  double farthest = 0.0;
  for (const Eigen::Vector3d& p : points) {
    double nearest = (p - vertices.front()).squaredNorm();
    for (std::size_t i = 0; i + 1 < vertices.size(); ++i) {
      const Eigen::Vector3d a = vertices[i], ab = vertices[i + 1] - a;
      const double t = ab.squaredNorm() > 0.0 ? std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0) : 0.0;
      nearest = std::min(nearest, (a + t * ab - p).squaredNorm());
    }
    farthest = std::max(farthest, std::sqrt(nearest));
  }
  return farthest;
}

}  // namespace haustra::reference
