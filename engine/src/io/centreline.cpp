// Centreline files (JSON polylines with units) read and checked.
#include "haustra/centreline.hpp"

#include <fmt/format.h>
#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>

#include "haustra/error.hpp"
#include "io/bounded_input.hpp"

namespace haustra {
namespace {

constexpr double kCuspDegrees = 170.0;

double unit_scale(const std::string& units, const std::string& file) {
  if (units == "m") return 1.0;
  if (units == "cm") return 1e-2;
  if (units == "mm") return 1e-3;
  throw Error(ErrorCode::parse,
              fmt::format("{}: field 'units': expected \"mm\", \"cm\" or \"m\", got \"{}\"", file, units));
}

// Closest distance between segments [p0, p1] and [q0, q1] (clamped closest points).
double segment_distance(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& q0,
                        const Eigen::Vector3d& q1) {
  const Eigen::Vector3d d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  const double c = d1.dot(r), b = d1.dot(d2);
  const double denom = a * e - b * b;
  double s = denom > 0.0 ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
  double t = (b * s + f) / e;
  if (t < 0.0) {
    t = 0.0;
    s = std::clamp(-c / a, 0.0, 1.0);
  } else if (t > 1.0) {
    t = 1.0;
    s = std::clamp((b - c) / a, 0.0, 1.0);
  }
  return (p0 + s * d1 - (q0 + t * d2)).norm();
}

// A value for a message, without recursing into it (the file is untrusted): its kind, its size,
// and a flat array's or a scalar's text when short.
std::string describe(const nlohmann::json& v) {
  constexpr std::size_t kShort = 80;
  if (v.is_array()) {
    const bool flat = std::none_of(v.begin(), v.end(), [](const auto& e) { return e.is_structured(); });
    if (flat && v.size() <= 8) {
      std::string text = v.dump();
      if (text.size() <= kShort) return text;
    }
    return fmt::format("an array of {} entr{}", v.size(), v.size() == 1 ? "y" : "ies");
  }
  if (v.is_object()) return fmt::format("an object of {} key{}", v.size(), v.size() == 1 ? "" : "s");
  std::string text = v.dump();
  if (text.size() > kShort) text = text.substr(0, kShort) + "…";
  return text;
}

}  // namespace

void check_centreline_points(const std::vector<Eigen::Vector3d>& points, const std::string& where) {
  if (points.size() < 2)
    throw Error(ErrorCode::invalid_geometry,
                fmt::format("{}: a centreline needs at least 2 points, got {}", where, points.size()));
  for (std::size_t i = 0; i < points.size(); ++i)
    if (!points[i].allFinite())
      throw Error(ErrorCode::invalid_argument, fmt::format("{}: point {} is not finite ({}, {}, {})", where, i,
                                                           points[i].x(), points[i].y(), points[i].z()));
  double length = 0.0;
  double extent = 0.0;
  for (const auto& p : points) extent = std::max(extent, (p - points.front()).norm());
  for (std::size_t i = 1; i < points.size(); ++i) {
    const double d = (points[i] - points[i - 1]).norm();
    if (!(d > 1e-12 * std::max(extent, 1e-300)))
      throw Error(ErrorCode::invalid_geometry,
                  fmt::format("{}: points {} and {} are the same point; remove the repeat", where, i - 1, i));
    length += d;
  }
  if (!(length > 0.0)) throw Error(ErrorCode::invalid_geometry, where + ": the centreline has zero length");
  for (std::size_t i = 1; i + 1 < points.size(); ++i) {
    const Eigen::Vector3d a = (points[i] - points[i - 1]).normalized();
    const Eigen::Vector3d b = (points[i + 1] - points[i]).normalized();
    const double turn = std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / std::numbers::pi;
    if (turn > kCuspDegrees)
      throw Error(ErrorCode::invalid_geometry,
                  fmt::format("{}: the path reverses at point {} (a turn of {:.1f}°, more than {:.0f}°): "
                              "a cusp is not a centreline",
                              where, i, turn, kCuspDegrees));
  }
  // A path that meets itself: two segments that are not neighbours closer than 1 % of the mean
  // point spacing (a real organ's loops lie a diameter apart). Pairs whose bounding spheres are
  // apart skip the exact distance.
  const std::size_t n = points.size() - 1;
  const double touch = 0.01 * length / static_cast<double>(n);
  for (std::size_t i = 0; i + 2 < n; ++i) {
    const Eigen::Vector3d ci = 0.5 * (points[i] + points[i + 1]);
    const double ri = 0.5 * (points[i + 1] - points[i]).norm();
    for (std::size_t j = i + 2; j < n; ++j) {
      const double rj = 0.5 * (points[j + 1] - points[j]).norm();
      if ((0.5 * (points[j] + points[j + 1]) - ci).norm() > ri + rj + touch) continue;
      const double d = segment_distance(points[i], points[i + 1], points[j], points[j + 1]);
      if (d < touch)
        throw Error(ErrorCode::invalid_geometry,
                    fmt::format("{}: the path crosses itself: segment {}–{} comes within {:.3g} m of segment {}–{}",
                                where, i, i + 1, d, j, j + 1));
    }
  }
}

Centreline parse_centreline(const std::string& text, const std::string& file) {
  // nlohmann's parser keeps its own stack, but dumping and walking a value recurse: bounded first.
  if (text.size() > io::kMaxCentrelineBytes)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("{}: {} bytes of centreline, more than the {} MiB a centreline file may have", file,
                            text.size(), io::kMaxCentrelineBytes >> 20));
  io::check_json_nesting(text, file);
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw Error(ErrorCode::parse, fmt::format("{}: not valid JSON: {}", file, e.what()));
  }
  if (!doc.is_object()) throw Error(ErrorCode::parse, file + ": expected a JSON object with 'units' and 'points'");
  if (!doc.contains("units") || !doc["units"].is_string())
    throw Error(ErrorCode::parse, file + ": field 'units': expected a string \"mm\", \"cm\" or \"m\"");
  if (!doc.contains("points") || !doc["points"].is_array())
    throw Error(ErrorCode::parse, file + ": field 'points': expected an array of [x, y, z]");
  Centreline c;
  c.units = doc["units"].get<std::string>();
  const double scale = unit_scale(c.units, file);
  if (doc.contains("source") && doc["source"].is_string()) c.source = doc["source"].get<std::string>();
  const auto& pts = doc["points"];
  c.points.reserve(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const auto& p = pts[i];
    if (!p.is_array() || p.size() != 3)
      throw Error(ErrorCode::parse, fmt::format("{}: points[{}]: expected [x, y, z], got {}", file, i, describe(p)));
    Eigen::Vector3d v;
    for (int j = 0; j < 3; ++j) {
      if (!p[static_cast<std::size_t>(j)].is_number())
        throw Error(ErrorCode::parse, fmt::format("{}: points[{}]: expected numbers, got {}", file, i, describe(p)));
      v[j] = p[static_cast<std::size_t>(j)].get<double>() * scale;
    }
    if (!v.allFinite())
      throw Error(ErrorCode::parse, fmt::format("{}: points[{}]: coordinates must be finite", file, i));
    c.points.push_back(v);
  }
  check_centreline_points(c.points, file);
  return c;
}

Centreline read_centreline(const std::filesystem::path& file) {
  return parse_centreline(io::read_bounded_file(file, "centreline file", io::kMaxCentrelineBytes), file.string());
}

}  // namespace haustra
