// Resampling, smoothing, coverage by rays, curvature and touching parts of a centreline.
#include "centreline_fit.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "haustra/render/shapes.hpp"

namespace haustra::import {

double polyline_length(const Polyline& p) {
  double l = 0.0;
  for (std::size_t i = 1; i < p.size(); ++i) l += (p[i] - p[i - 1]).norm();
  return l;
}

Polyline resample(const Polyline& p, double spacing) {
  const double total = polyline_length(p);
  const auto n = static_cast<std::size_t>(std::max(1.0, std::round(total / spacing)));
  const double step = total / static_cast<double>(n);
  Polyline out{p.front()};
  std::size_t i = 1;
  double at = 0.0;  // arc length at p[i - 1]
  for (std::size_t k = 1; k < n; ++k) {
    const double want = step * static_cast<double>(k);
    while (i + 1 < p.size() && at + (p[i] - p[i - 1]).norm() < want) {
      at += (p[i] - p[i - 1]).norm();
      ++i;
    }
    const double len = (p[i] - p[i - 1]).norm();
    const double t = len > 0.0 ? std::clamp((want - at) / len, 0.0, 1.0) : 0.0;
    out.push_back(p[i - 1] + t * (p[i] - p[i - 1]));
  }
  out.push_back(p.back());
  return out;
}

Polyline smooth(const Polyline& p, double spacing, double sigma) {
  const auto reach = static_cast<std::ptrdiff_t>(std::ceil(2.5 * sigma / spacing));
  const auto n = static_cast<std::ptrdiff_t>(p.size());
  Polyline out(p.size());
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    const std::ptrdiff_t w = std::min({reach, i, n - 1 - i});
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double total = 0.0;
    for (std::ptrdiff_t j = -w; j <= w; ++j) {
      const double x = static_cast<double>(j) * spacing / sigma;
      const double g = std::exp(-0.5 * x * x);
      sum += g * p[static_cast<std::size_t>(i + j)];
      total += g;
    }
    out[static_cast<std::size_t>(i)] = sum / total;
  }
  return out;
}

namespace {

constexpr int kRays = 16;

// Where 16 rays from `at`, evenly around `tangent` in its normal plane, first meet the wall within
// `reach`: distances and points of the rays that do.
struct PlaneHits {
  std::vector<double> distance;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();  // of the points hit
};
PlaneHits normal_plane_hits(const EmbreeScene& wall, const Eigen::Vector3d& at, const Eigen::Vector3d& tangent,
                            double reach) {
  const auto [u, v] = render::across(tangent);
  PlaneHits h;
  for (int k = 0; k < kRays; ++k) {
    const double a = 2.0 * std::numbers::pi * k / kRays;
    const Eigen::Vector3d d = std::cos(a) * u + std::sin(a) * v;
    const EmbreeScene::Hit hit = wall.first_hit(at, d, 0.0, reach);
    if (!hit.found) continue;
    h.distance.push_back(hit.distance);
    h.sum += at + hit.distance * d;
  }
  return h;
}

Eigen::Vector3d tangent_at(const Polyline& p, std::size_t i) {
  return (p[std::min(i + 1, p.size() - 1)] - p[i > 0 ? i - 1 : 0]).normalized();
}

}  // namespace

Coverage coverage(const EmbreeScene& wall, const Polyline& p, double reach, int min_hits) {
  Coverage c{std::vector<bool>(p.size(), false), std::vector<double>(p.size(), 0.0)};
  for (std::size_t i = 0; i < p.size(); ++i) {
    PlaneHits h = normal_plane_hits(wall, p[i], tangent_at(p, i), reach);
    if (h.distance.size() < static_cast<std::size_t>(min_hits)) continue;
    std::nth_element(h.distance.begin(), h.distance.begin() + static_cast<std::ptrdiff_t>(h.distance.size() / 2),
                     h.distance.end());
    c.covered[i] = true;
    c.radius[i] = h.distance[h.distance.size() / 2];
  }
  return c;
}

Polyline remove_backtracks(const Polyline& p) {
  Polyline out;
  for (const Eigen::Vector3d& q : p) {
    while (out.size() >= 2 && (q - out.back()).dot(out.back() - out[out.size() - 2]) < 0.0) out.pop_back();
    if (out.empty() || (q - out.back()).norm() > 0.0) out.push_back(q);
  }
  return out;
}

std::vector<double> bend_radii(const Polyline& p, double spacing, double half_window) {
  const auto w = static_cast<std::size_t>(std::max(1.0, std::round(half_window / spacing)));
  std::vector<double> r(p.size(), 1e300);
  for (std::size_t i = w; i + w < p.size(); ++i) {
    const Eigen::Vector3d a = p[i - w], b = p[i], c = p[i + w];
    const double area2 = (b - a).cross(c - a).norm();  // twice the triangle's area
    if (area2 > 0.0) r[i] = (b - a).norm() * (c - b).norm() * (c - a).norm() / (2.0 * area2);
  }
  return r;
}

std::vector<std::pair<double, double>> touching_parts(const Polyline& p, double spacing, double apart, double near) {
  std::vector<std::pair<double, double>> out;
  const auto gap = static_cast<std::size_t>(std::ceil(apart / spacing));
  std::size_t last_i = 0;
  bool any = false;
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t j = i + gap; j < p.size(); ++j) {
      if ((p[i] - p[j]).norm() >= near) continue;
      // One report per stretch: skip pairs within `apart` of the last reported one.
      if (any && i < last_i + gap) break;
      out.emplace_back(static_cast<double>(i) * spacing, static_cast<double>(j) * spacing);
      last_i = i;
      any = true;
      break;
    }
  return out;
}

}  // namespace haustra::import
