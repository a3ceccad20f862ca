// Rest shapes: straight, arc, or a centreline resampled into biarcs and turned into rest strains.
#include "haustra/rest_shape.hpp"

#include <fmt/format.h>
#include <algorithm>
#include <cmath>

#include "haustra/error.hpp"
#include "haustra/kernels/rod_forward_sweep.hpp"
#include "haustra/rod_pose_buffer.hpp"

namespace haustra {
namespace {

using kernels::Pose;

// Arc-length parametrized polyline.
class Polyline {
 public:
  explicit Polyline(std::span<const Eigen::Vector3d> points) : points_(points) {
    arc_.resize(points.size());
    arc_[0] = 0.0;
    for (std::size_t i = 1; i < points.size(); ++i) arc_[i] = arc_[i - 1] + (points[i] - points[i - 1]).norm();
  }
  [[nodiscard]] double length() const { return arc_.back(); }
  [[nodiscard]] Eigen::Vector3d at(double s) const {
    s = std::clamp(s, 0.0, length());
    const auto it = std::upper_bound(arc_.begin(), arc_.end(), s);
    const std::size_t i = std::min<std::size_t>(static_cast<std::size_t>(it - arc_.begin()), points_.size() - 1);
    const std::size_t a = i - 1;
    const double span = arc_[i] - arc_[a];
    const double t = span > 0.0 ? (s - arc_[a]) / span : 0.0;
    return (1.0 - t) * points_[a] + t * points_[i];
  }
  [[nodiscard]] double median_segment() const {
    std::vector<double> seg(points_.size() - 1);
    for (std::size_t i = 0; i + 1 < points_.size(); ++i) seg[i] = arc_[i + 1] - arc_[i];
    std::nth_element(seg.begin(), seg.begin() + static_cast<std::ptrdiff_t>(seg.size() / 2), seg.end());
    return seg[seg.size() / 2];
  }

 private:
  std::span<const Eigen::Vector3d> points_;
  std::vector<double> arc_;
};

struct Section {
  Eigen::Vector3d u;  // body-frame curvature/torsion
  double length;
};

// The circular, torsion-free section that leaves `start` along its d3 and ends at `end`.
Section arc_to(const Pose& start, const Eigen::Vector3d& end, const std::string& where) {
  const Eigen::Vector3d chord = end - start.position;
  const double c = chord.norm();
  if (!(c > 0.0)) throw Error(ErrorCode::invalid_geometry, where + ": two interpolation points coincide");
  const Eigen::Vector3d dir = chord / c;
  const Eigen::Vector3d tangent = start.rotation * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d binormal = tangent.cross(dir);
  const double sin_a = binormal.norm();
  const double alpha = std::atan2(sin_a, tangent.dot(dir));  // half the turning angle
  if (alpha > 0.9 * std::numbers::pi)
    throw Error(ErrorCode::invalid_geometry,
                where + fmt::format(": the centreline turns back on itself ({:.0f}° within one section); "
                                    "it has a cusp or a bend tighter than the node spacing",
                                    2.0 * alpha * 180.0 / std::numbers::pi));
  if (sin_a < 1e-14) return {Eigen::Vector3d::Zero(), c};
  const double alpha_over_sin = alpha < 1e-4 ? 1.0 + alpha * alpha / 6.0 : alpha / std::sin(alpha);
  const double curvature = 2.0 * sin_a / c;
  Eigen::Vector3d u = start.rotation.conjugate() * (binormal * (curvature / sin_a));
  u.z() = 0.0;  // rotation about the binormal only: no twist (rounding aside)
  return {u, c * alpha_over_sin};
}

}  // namespace

RestShape rest_shape_constant_strain(int nodes, double length, const Eigen::Vector3d& curvature_torsion,
                                     const kernels::Pose& base) {
  if (nodes < 2) throw Error(ErrorCode::invalid_argument, fmt::format("nodes must be at least 2, got {}", nodes));
  if (!(length > 0.0) || !std::isfinite(length))
    throw Error(ErrorCode::invalid_argument, fmt::format("length must be positive, got {}", length));
  RestShape rest;
  const auto sections = static_cast<std::size_t>(nodes - 1);
  rest.section_length.assign(sections, length / static_cast<double>(sections));
  rest.strain.assign(4 * static_cast<std::size_t>(nodes), 0.0);
  for (std::size_t k = 0; k < static_cast<std::size_t>(nodes); ++k)
    for (std::size_t c = 0; c < 3; ++c) rest.strain[4 * k + c] = curvature_torsion[static_cast<Eigen::Index>(c)];
  rest.base = base;
  rest.length = length;
  return rest;
}

std::vector<double> node_strains_from_sections(std::span<const double> section_strain,
                                               std::span<const double> section_length) {
  const std::size_t sections = section_length.size();
  const std::size_t nodes = sections + 1;
  std::vector<double> q(4 * nodes, 0.0);
  for (std::size_t c = 0; c < 4; ++c) {
    // Particular solution with a_0 = 0; the general one is a_k + (−1)^k C.
    std::vector<double> a(nodes, 0.0);
    for (std::size_t k = 0; k < sections; ++k) a[k + 1] = 2.0 * section_strain[4 * k + c] - a[k];
    double num = 0.0;
    double den = 0.0;
    for (std::size_t k = 0; k < nodes; ++k) {
      const double h_prev = k > 0 ? section_length[k - 1] : 0.0;
      const double h_next = k < sections ? section_length[k] : 0.0;
      const double s_prev = k > 0 ? section_strain[4 * (k - 1) + c] : 0.0;
      const double s_next = k < sections ? section_strain[4 * k + c] : 0.0;
      const double w = 0.5 * (h_prev + h_next);
      const double mean = (h_prev * s_prev + h_next * s_next) / (h_prev + h_next);
      const double sign = (k % 2 == 0) ? 1.0 : -1.0;
      num += w * sign * (mean - a[k]);
      den += w;
    }
    const double alternating = num / den;
    for (std::size_t k = 0; k < nodes; ++k) q[4 * k + c] = a[k] + ((k % 2 == 0) ? alternating : -alternating);
  }
  return q;
}

double max_distance_to_rod(std::span<const Eigen::Vector3d> points, std::span<const double> section_length,
                           std::span<const double> strain, const kernels::Pose& base) {
  constexpr int kSubdivisions = 8;
  const std::size_t sections = section_length.size();
  std::vector<Eigen::Vector3d> curve;
  curve.reserve(sections * kSubdivisions + 1);
  Pose pose = base;
  curve.push_back(pose.position);
  double rod_length = 0.0;
  for (std::size_t k = 0; k < sections; ++k) {
    const Eigen::Vector3d u(0.5 * (strain[4 * k] + strain[4 * k + 4]), 0.5 * (strain[4 * k + 1] + strain[4 * k + 5]),
                            0.5 * (strain[4 * k + 2] + strain[4 * k + 6]));
    const double eps = 0.5 * (strain[4 * k + 3] + strain[4 * k + 7]);
    for (int i = 1; i <= kSubdivisions; ++i)
      curve.push_back((pose * kernels::section_exp(u, eps, section_length[k] * i / kSubdivisions)).position);
    pose = pose * kernels::section_exp(u, eps, section_length[k]);
    rod_length += section_length[k];
  }
  // Both curves run the same way: search each point near its proportional position, with a
  // window wide enough for the difference between chord and arc lengths.
  const Polyline source(points);
  const std::size_t segs = curve.size() - 1;
  const std::size_t window = segs / 8 + 4 * kSubdivisions;
  double worst = 0.0;
  double arc = 0.0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (i > 0) arc += (points[i] - points[i - 1]).norm();
    const auto centre =
        static_cast<std::size_t>(std::llround(arc / std::max(source.length(), 1e-300) * static_cast<double>(segs)));
    const std::size_t lo = centre > window ? centre - window : 0;
    const std::size_t hi = std::min(segs, centre + window);
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t j = lo; j < hi; ++j) {
      const Eigen::Vector3d ab = curve[j + 1] - curve[j];
      const double t = std::clamp((points[i] - curve[j]).dot(ab) / std::max(ab.squaredNorm(), 1e-300), 0.0, 1.0);
      best = std::min(best, (points[i] - (curve[j] + t * ab)).norm());
    }
    worst = std::max(worst, best);
  }
  (void)rod_length;
  return worst;
}

namespace {

// The junction of a biarc from `pose` to `end` (arriving along t1) with equal tangent lengths a:
// J = (P0 + P1)/2 + a (t0 − t1)/2.
Eigen::Vector3d biarc_junction(const Pose& pose, const Eigen::Vector3d& end, const Eigen::Vector3d& t1,
                               const std::string& where) {
  const Eigen::Vector3d t0 = pose.rotation * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d v = end - pose.position;
  const double vt = v.dot(t0 + t1);
  const double denom = vt + std::sqrt(vt * vt + 2.0 * (1.0 - t0.dot(t1)) * v.squaredNorm());
  if (!(denom > 1e-12 * v.norm()))
    throw Error(ErrorCode::invalid_geometry,
                where +
                    ": the tangents point away from the chord; the centreline has a cusp or "
                    "a bend tighter than the node spacing");
  const double a = v.squaredNorm() / denom;
  return 0.5 * (pose.position + end) + 0.5 * a * (t0 - t1);
}

}  // namespace

RestShape rest_shape_from_centreline(std::span<const Eigen::Vector3d> points, int nodes,
                                     const Eigen::Vector3d& normal_hint, const std::string& source) {
  if (nodes < 2)
    throw Error(ErrorCode::invalid_argument, fmt::format("{}: nodes must be at least 2, got {}", source, nodes));
  if (points.size() < 2)
    throw Error(ErrorCode::invalid_geometry,
                fmt::format("{}: a centreline needs at least 2 points, got {}", source, points.size()));
  const Polyline line(points);
  const double total = line.length();
  if (!(total > 0.0)) throw Error(ErrorCode::invalid_geometry, source + ": the centreline has zero length");

  const auto sections = static_cast<std::size_t>(nodes - 1);
  // Intervals of two sections (biarcs); with an odd section count the last is a single arc.
  const std::size_t intervals = sections / 2 + sections % 2;
  std::vector<std::size_t> first_section(intervals + 1);
  for (std::size_t j = 0; j <= intervals; ++j) first_section[j] = std::min(2 * j, sections);

  std::vector<Eigen::Vector3d> sample(intervals + 1);
  std::vector<Eigen::Vector3d> tangent(intervals + 1);
  // Tangents by central differences over a window that follows the node spacing but never drops
  // below two source segments, so voxel-scale noise does not reach the curvature.
  const double window = std::max(total / static_cast<double>(sections), 2.0 * line.median_segment());
  for (std::size_t j = 0; j <= intervals; ++j) {
    const double s = total * static_cast<double>(first_section[j]) / static_cast<double>(sections);
    sample[j] = line.at(s);
    const Eigen::Vector3d d = line.at(s + window) - line.at(s - window);
    if (!(d.norm() > 0.0))
      throw Error(ErrorCode::invalid_geometry,
                  fmt::format("{}: no tangent at arc length {:.4g} m (the centreline folds back there)", source, s));
    tangent[j] = d.normalized();
  }

  std::vector<double> section_strain(4 * sections, 0.0);
  std::vector<double> section_length(sections, 0.0);
  Pose pose{kernels::frame_from_tangent(tangent[0], normal_hint), sample[0]};
  const Pose base = pose;
  std::size_t k = 0;
  auto emit = [&](const Section& s) {
    section_strain[4 * k] = s.u.x();
    section_strain[4 * k + 1] = s.u.y();
    section_length[k] = s.length;
    pose = pose * kernels::section_exp(s.u, 0.0, s.length);
    ++k;
  };
  for (std::size_t j = 0; j < intervals; ++j) {
    const std::string where =
        fmt::format("{}: between arc lengths {:.4g} m and {:.4g} m", source,
                    total * static_cast<double>(first_section[j]) / static_cast<double>(sections),
                    total * static_cast<double>(first_section[j + 1]) / static_cast<double>(sections));
    const Eigen::Vector3d end = sample[j + 1];
    if (first_section[j + 1] - first_section[j] == 1) {
      emit(arc_to(pose, end, where));
      continue;
    }
    const Eigen::Vector3d junction = biarc_junction(pose, end, tangent[j + 1], where);
    emit(arc_to(pose, junction, where));
    emit(arc_to(pose, end, where));
  }

  RestShape rest;
  rest.section_length = std::move(section_length);
  rest.strain = node_strains_from_sections(section_strain, rest.section_length);
  rest.base = base;
  for (double h : rest.section_length) rest.length += h;

  // Reconstruct with the engine's own sweep and measure.
  RodPoseBuffer buffer(static_cast<std::size_t>(nodes));
  const kernels::RodPoses<double> poses = buffer.view();
  kernels::rod_forward_sweep(base, rest.section_length, kernels::StrainView<const double>{rest.strain}, poses);
  for (std::size_t j = 0; j <= intervals; ++j)
    rest.node_deviation = std::max(rest.node_deviation, (poses.node_position.get(first_section[j]) - sample[j]).norm());
  rest.polyline_deviation = max_distance_to_rod(points, rest.section_length, rest.strain, base);
  return rest;
}

}  // namespace haustra
