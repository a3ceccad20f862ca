#pragma once
// Centreline files: {"units": "mm" | "cm" | "m", "points": [[x, y, z], ...], "source": "..."}
// (the format of ../shared/data/*-centreline.json). Read into metres, checked point by point.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <filesystem>
#include <string>
#include <vector>

namespace haustra {

struct Centreline {
  std::vector<Eigen::Vector3d> points;  // metres
  std::string units;                    // as written in the file
  std::string source;
};

// Throws Error{io} or Error{parse} / Error{invalid_geometry} naming the file, the field or point
// index, and what was expected: fewer than 2 points, non-finite coordinates, repeated points,
// zero length, and cusps (a turn of more than 170° between consecutive segments).
Centreline read_centreline(const std::filesystem::path& file);
Centreline parse_centreline(const std::string& text, const std::string& file_name);

// The checks alone, on points already in metres; `where` names them in messages.
void check_centreline_points(const std::vector<Eigen::Vector3d>& points, const std::string& where);

}  // namespace haustra
