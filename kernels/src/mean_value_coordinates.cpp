// Mean value coordinates of points with respect to a closed triangle cage.
#include "haustra/kernels/mean_value_coordinates.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>

namespace haustra::kernels {
namespace {

// A point closer than this (× cage size) to a vertex takes that vertex's coordinates; closer to a
// face (and inside it) takes the face's barycentric coordinates. Both are far below any distance
// a float mesh vertex can resolve, far above double rounding of cage-sized differences.
constexpr double kOnVertex = 1e-12;
constexpr double kOnFace = 1e-12;
// A triangle whose solid angle is below this (steradians) is taken as seen edge-on. Skipping it
// errs by at most about this fraction of the point's total weight; keeping it would divide the
// rounding of m (≈ 1e-16) by det (≈ the solid angle). Both errors meet near 1e-8.
constexpr double kEdgeOn = 1e-8;
// det(u0, u1, u2) below which the on-face test runs (a point on a face has det = 0; one within
// kOnFace of it has det ≤ 1e-3 unless it is also within ~1e-9 of a vertex).
constexpr double kNearPlane = 1e-3;

// Barycentric coordinates of the foot of p on triangle abc; false when the foot is outside.
bool face_coordinates(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                      const Eigen::Vector3d& c, Eigen::Vector3d& bary) {
  const Eigen::Vector3d e0 = b - a, e1 = c - a, ep = p - a;
  const double d00 = e0.dot(e0), d01 = e0.dot(e1), d11 = e1.dot(e1);
  const double d20 = ep.dot(e0), d21 = ep.dot(e1);
  const double den = d00 * d11 - d01 * d01;
  if (!(den > 0.0)) return false;
  const double v = (d11 * d20 - d01 * d21) / den;
  const double w = (d00 * d21 - d01 * d20) / den;
  const double u = 1.0 - v - w;
  constexpr double kSlack = 1e-12;
  if (u < -kSlack || v < -kSlack || w < -kSlack) return false;
  bary = Eigen::Vector3d(std::max(u, 0.0), std::max(v, 0.0), std::max(w, 0.0));
  bary /= bary.sum();
  return true;
}

MvcResult finish(std::span<double> weights, MvcLocation location, double total) {
  MvcResult r;
  r.location = location;
  r.total_weight = total;
  r.min_weight = weights.empty() ? 0.0 : *std::min_element(weights.begin(), weights.end());
  for (double w : weights)
    if (w < 0.0) r.negative_mass -= w;
  return r;
}

}  // namespace

CageFrame cage_frame(std::span<const Eigen::Vector3d> vertices) {
  CageFrame f;
  if (vertices.empty()) return f;
  Eigen::Vector3d lo = vertices[0], hi = vertices[0], sum = Eigen::Vector3d::Zero();
  for (const auto& v : vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
    sum += v;
  }
  f.centre = sum / static_cast<double>(vertices.size());
  f.size = std::max((hi - lo).norm(), 1e-300);
  return f;
}

MvcResult mean_value_coordinates(const Eigen::Vector3d& point, const CageView& cage, const CageFrame& frame,
                                 std::span<double> scratch, std::span<double> weights) {
  const std::size_t n = cage.vertices.size();
  std::fill(weights.begin(), weights.end(), 0.0);
  const Eigen::Vector3d x = point - frame.centre;
  auto rel = [&](std::uint32_t j) -> Eigen::Vector3d { return cage.vertices[j] - frame.centre; };

  // Unit directions and distances to every cage vertex.
  for (std::size_t j = 0; j < n; ++j) {
    const Eigen::Vector3d e = rel(static_cast<std::uint32_t>(j)) - x;
    const double d = e.norm();
    if (d <= kOnVertex * frame.size) {
      weights[j] = 1.0;
      return finish(weights, MvcLocation::on_vertex, 0.0);
    }
    const Eigen::Vector3d unit = e / d;
    scratch[4 * j] = unit.x();
    scratch[4 * j + 1] = unit.y();
    scratch[4 * j + 2] = unit.z();
    scratch[4 * j + 3] = d;
  }

  for (const auto& t : cage.triangles) {
    const auto dir = [&](std::uint32_t j) {
      return Eigen::Vector3d(scratch[4 * j], scratch[4 * j + 1], scratch[4 * j + 2]);
    };
    const Eigen::Vector3d u[3] = {dir(t[0]), dir(t[1]), dir(t[2])};
    const Eigen::Vector3d c[3] = {u[1].cross(u[2]), u[2].cross(u[0]), u[0].cross(u[1])};
    const double det = u[0].dot(c[0]);
    // Signed solid angle (Van Oosterom and Strackee): tan(Ω/2) = det / (1 + Σ u_i·u_j).
    const double den = 1.0 + u[0].dot(u[1]) + u[1].dot(u[2]) + u[2].dot(u[0]);
    const double solid_angle = 2.0 * std::atan2(det, den);

    // On the face (or one of its edges): the face's barycentric coordinates, exactly. det is the
    // point's height over the plane scaled by area/(d0 d1 d2), so only a small det needs the test.
    if (std::abs(det) < kNearPlane) {
      const Eigen::Vector3d a = rel(t[0]), b = rel(t[1]), cc = rel(t[2]);
      const Eigen::Vector3d normal = (b - a).cross(cc - a);
      const double area2 = normal.norm();
      Eigen::Vector3d bary;
      if (area2 > 0.0 && std::abs((x - a).dot(normal)) <= kOnFace * frame.size * area2 &&
          face_coordinates(x, a, b, cc, bary)) {
        std::fill(weights.begin(), weights.end(), 0.0);
        for (int i = 0; i < 3; ++i) weights[t[static_cast<std::size_t>(i)]] += bary[i];
        return finish(weights, MvcLocation::on_face, 0.0);
      }
    }
    if (std::abs(solid_angle) < kEdgeOn || det == 0.0) continue;

    Eigen::Vector3d m = Eigen::Vector3d::Zero();
    for (int k = 0; k < 3; ++k) {
      const double s = c[k].norm();
      if (s == 0.0) continue;  // the edge subtends no angle: it adds nothing to m
      const double beta = std::atan2(s, u[(k + 1) % 3].dot(u[(k + 2) % 3]));
      m += (0.5 * beta / s) * c[k];
    }
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t j = t[static_cast<std::size_t>(i)];
      weights[j] += c[i].dot(m) / det / scratch[4 * j + 3];
    }
  }

  double total = 0.0;
  for (double w : weights) total += w;
  // A closed cage always gives a non-zero total (it is 4π/distance-like); guard anyway.
  if (total != 0.0)
    for (double& w : weights) w /= total;
  return finish(weights, MvcLocation::general, total);
}

}  // namespace haustra::kernels
