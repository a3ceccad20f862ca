#include "haustra/centreline.hpp"

#include <cmath>
#include <fmt/format.h>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "haustra/error.hpp"

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

}  // namespace

void check_centreline_points(const std::vector<Eigen::Vector3d>& points, const std::string& where) {
  if (points.size() < 2)
    throw Error(ErrorCode::invalid_geometry,
                fmt::format("{}: a centreline needs at least 2 points, got {}", where, points.size()));
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
}

Centreline parse_centreline(const std::string& text, const std::string& file) {
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw Error(ErrorCode::parse, fmt::format("{}: not valid JSON: {}", file, e.what()));
  }
  if (!doc.is_object())
    throw Error(ErrorCode::parse, file + ": expected a JSON object with 'units' and 'points'");
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
      throw Error(ErrorCode::parse, fmt::format("{}: points[{}]: expected [x, y, z], got {}", file, i, p.dump()));
    Eigen::Vector3d v;
    for (int j = 0; j < 3; ++j) {
      if (!p[static_cast<std::size_t>(j)].is_number())
        throw Error(ErrorCode::parse, fmt::format("{}: points[{}]: expected numbers, got {}", file, i, p.dump()));
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
  std::ifstream in(file, std::ios::binary);
  if (!in) throw Error(ErrorCode::io, fmt::format("{}: cannot open the centreline file", file.string()));
  std::ostringstream text;
  text << in.rdbuf();
  return parse_centreline(text.str(), file.string());
}

}  // namespace haustra
