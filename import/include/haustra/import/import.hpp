#pragma once
// `haustra import`: a segmented organ surface (OBJ, STL, OFF, glTF; open or closed ends; in
// millimetres or metres) turned into a scene that runs — its centreline read or computed (CGAL's
// mean curvature flow skeleton), trimmed to the mesh, the rod, beads, cage and mesh written as a
// scene file, and the scene built once to prove it (docs/decisions/0047-import.md).
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace haustra::import {

struct ImportOptions {
  std::filesystem::path mesh;
  std::filesystem::path centreline;  // a midline file (JSON, as ../shared/data); empty: computed
  std::filesystem::path out;         // the scene file; its centreline is written beside it
  std::string units = "auto";        // auto (from the size), mm or m
  std::string ends = "held";         // held (both), base (the first only) or free
  int nodes = 0;                     // 0: one per 5 mm of centreline, 41 to 401
  int beads = 0;                     // 0: a third of the nodes (the paper's 55 on 167)
  bool reverse = false;              // run the rod from the other end
};

struct ImportReport {
  std::string units;  // "mm" or "m", and how it was decided
  std::string units_reason;
  double scale = 1.0;  // file units to metres
  std::size_t vertices = 0, triangles = 0;
  int holes = 0;                                    // boundary loops of the surface (open ends)
  std::string centreline_source;                    // the file, or "computed: ..."
  double raw_length = 0.0;                          // m, before trimming
  double length = 0.0;                              // m, as written
  double trimmed_start = 0.0, trimmed_end = 0.0;    // m cut where the centreline ran past the mesh
  double median_radius = 0.0;                       // m, centreline to wall
  double tightest_bend = 0.0;                       // m, smallest radius of curvature (smoothed over 5 mm)
  double tightest_bend_at = 0.0;                    // m along the centreline
  std::vector<std::pair<double, double>> touching;  // arc positions (m) of parts whose walls touch
  int nodes = 0, beads = 0;
  std::filesystem::path scene, centreline_file;
  // From building the written scene once.
  std::size_t cage_rings = 0, dropped_rings = 0, rest_pose_outside = 0;
  double max_dropped_mass = 0.0, max_rest_correction = 0.0, build_seconds = 0.0;
  std::vector<std::string> retries;        // builds that failed with more beads (the cage), and why
  [[nodiscard]] std::string text() const;  // what was done, for the terminal
};

// Throws haustra::Error naming the file and what was expected: no mesh, no tube in it, a
// centreline outside the mesh, units that cannot be told, a scene that does not build (with the
// place and the flag that gets past it).
ImportReport import_surface(const ImportOptions& options);

}  // namespace haustra::import
