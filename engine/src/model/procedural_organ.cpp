// Procedural organ meshes: a tube with haustra and taeniae around a rod's rest curve.
#include "haustra/procedural_organ.hpp"
#include "model/field_checks.hpp"

#include <fmt/format.h>

#include <cmath>
#include <numbers>

#include "haustra/error.hpp"

namespace haustra {
namespace {

using detail::fail;

void check_fraction(const std::string& field, double v, double hi) {
  if (!std::isfinite(v) || v < 0.0 || v > hi) fail(field, fmt::format("expected a fraction in [0, {}], got {}", hi, v));
}

// Wall radius factor along the tube: a fold (semilunar) every `spacing`, sharp, bulging between.
double haustra_factor(double s, double spacing, double depth) {
  if (spacing <= 0.0 || depth <= 0.0) return 1.0;
  const double phase = std::cos(std::numbers::pi * s / spacing);  // ±1 at the folds
  return 1.0 - depth * std::pow(phase * phase, 6.0);
}

// Around the tube: three taeniae 120° apart, each a narrow groove.
double taenia_factor(double theta, double depth) {
  if (depth <= 0.0) return 1.0;
  double f = 1.0;
  for (int k = 0; k < 3; ++k) {
    const double d = std::remainder(theta - (2.0 * std::numbers::pi * k) / 3.0 + 0.5, 2.0 * std::numbers::pi);
    f -= depth * std::exp(-(d * d) / (0.18 * 0.18));
  }
  return f;
}

}  // namespace

TriangleMesh procedural_organ(const RodCurve& curve, const ProceduralOrganDesc& d, double default_radius,
                              const std::string& where) {
  if (d.vertices < 1000 || d.vertices > 4'000'000)
    fail(where + ".vertices", fmt::format("expected a vertex count in [1000, 4000000], got {}", d.vertices));
  const double radius = d.radius != 0.0 ? d.radius : default_radius;
  if (!std::isfinite(radius) || radius < 1e-4 || radius > 0.5)
    fail(where + ".radius", fmt::format("expected a radius in [0.0001, 0.5] m, got {}", radius));
  if (!std::isfinite(d.haustra_spacing) || d.haustra_spacing < 0.0 || d.haustra_spacing > 10.0)
    fail(where + ".haustra_spacing", fmt::format("expected a spacing in [0, 10] m, got {}", d.haustra_spacing));
  check_fraction(where + ".haustra_depth", d.haustra_depth, 0.6);
  check_fraction(where + ".taenia_depth", d.taenia_depth, 0.5);
  if (!std::isfinite(d.end_taper) || d.end_taper < 0.05 || d.end_taper > 2.0)
    fail(where + ".end_taper", fmt::format("expected a fraction of the radius in [0.05, 2], got {}", d.end_taper));

  // Rings of `around` vertices, about square quads: around / (2πR) ≈ along / L.
  const double cap = d.end_taper * radius;  // how far each rounded end reaches past the rod
  const double total = curve.length() + 2.0 * cap;
  const int around =
      std::max(8, static_cast<int>(std::lround(std::sqrt(d.vertices * 2.0 * std::numbers::pi * radius / total))));
  const int along = std::max(4, static_cast<int>(std::lround(static_cast<double>(d.vertices - 2) / around)));

  TriangleMesh mesh;
  mesh.vertices.reserve(static_cast<std::size_t>(along * around + 2));
  for (int i = 0; i < along; ++i) {
    // Rings spread over [−cap, L + cap]; inside the caps the radius rounds off like an ellipse.
    const double t = (i + 0.5) / along;
    const double s = -cap + t * total;
    double taper = 1.0;
    if (s < 0.0) taper = std::sqrt(std::max(0.0, 1.0 - (s / cap) * (s / cap)));
    if (s > curve.length())
      taper = std::sqrt(std::max(0.0, 1.0 - ((s - curve.length()) / cap) * ((s - curve.length()) / cap)));
    const kernels::Pose pose = curve.extend(s);
    const Eigen::Matrix3d r = pose.rotation.toRotationMatrix();
    const double ring_radius = radius * taper * haustra_factor(s, d.haustra_spacing, d.haustra_depth);
    for (int j = 0; j < around; ++j) {
      const double theta = 2.0 * std::numbers::pi * j / around;
      const double rr = ring_radius * taenia_factor(theta, d.taenia_depth);
      mesh.vertices.push_back(pose.position + rr * (std::cos(theta) * r.col(0) + std::sin(theta) * r.col(1)));
    }
  }
  const auto pole0 = static_cast<std::uint32_t>(mesh.vertices.size());
  mesh.vertices.push_back(curve.extend(-cap).position);
  mesh.vertices.push_back(curve.extend(curve.length() + cap).position);
  auto id = [&](int i, int j) { return static_cast<std::uint32_t>(i * around + ((j % around) + around) % around); };
  // Outward: with (d1, d2, d3) right-handed, (i, j) → (i, j+1) → (i+1, j) faces away from the axis.
  for (int i = 0; i + 1 < along; ++i)
    for (int j = 0; j < around; ++j) {
      mesh.triangles.push_back({id(i, j), id(i, j + 1), id(i + 1, j)});
      mesh.triangles.push_back({id(i + 1, j), id(i, j + 1), id(i + 1, j + 1)});
    }
  for (int j = 0; j < around; ++j) {
    mesh.triangles.push_back({pole0, id(0, j + 1), id(0, j)});
    mesh.triangles.push_back({pole0 + 1, id(along - 1, j), id(along - 1, j + 1)});
  }
  return mesh;
}

}  // namespace haustra
