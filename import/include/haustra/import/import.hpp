#pragma once
// `haustra import`: a segmented organ surface (OBJ, STL, OFF, glTF; open, closed or blind ends; in
// millimetres or metres; one tube, a wall of two nested shells, or a whole organ in pieces) turned
// into a scene that runs: repaired (CGAL), its pieces and shells sorted out, its centreline read or
// computed from a harmonic function on the wall, the rod, beads, cage and mesh written as a scene
// file, and the scene built once to prove it (docs/decisions/0047, 0049, 0050).
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace haustra::import {

struct ImportOptions {
  std::filesystem::path mesh;
  std::filesystem::path centreline;  // a midline file (JSON, as ../shared/data); empty: computed
  std::filesystem::path out;         // the scene file; the repaired surface and centreline go beside it
  std::string units = "auto";        // auto (from the size), mm or m
  std::string ends = "free";         // held rigidly: both, base (the first only) or free (decision 0095)
  std::string tissue = "rest";       // connective tissue holding the organ in place (rest), or none
  int nodes = 0;                     // 0: one per 5 mm of centreline, 9 to 1,201
  int beads = 0;                     // 0: a third of the nodes (the paper's 55 on 167)
  bool reverse = false;              // run the rod from the other end
  // Called as each phase ends ("repair: ... (0.2 s)"); the command line prints it on a terminal.
  std::function<void(std::string_view)> progress;
};

struct ImportReport {
  std::string units;  // "mm" or "m", and how it was decided
  std::string units_reason;
  double scale = 1.0;                                         // file units to metres
  std::size_t vertices = 0, triangles = 0;                    // as read
  std::string repairs;                                        // what the repair did, one line
  std::size_t repaired_vertices = 0, repaired_triangles = 0;  // as written
  std::string layout;                                         // pieces, shells, left-out parts
  std::size_t pieces = 0, shells = 0;               // outer pieces on the organ's path; lumen shells inside them
  double wall_thickness = 0.0;                      // m, measured between the shells (0: one shell)
  int holes = 0;                                    // boundary loops of the kept surface
  int open_ends = 0;                                // of the organ's two ends
  std::string centreline_source;                    // the file, or "computed: ..."
  std::size_t off_path_vertices = 0;                // of the surface, beyond the centreline's reach: left out
  double length = 0.0;                              // m, as written
  double trimmed_start = 0.0, trimmed_end = 0.0;    // m cut where a given centreline ran past the mesh
  double median_radius = 0.0;                       // m, centreline to the outer wall
  double tightest_bend = 0.0;                       // m, smallest radius of curvature (smoothed)
  double tightest_bend_at = 0.0;                    // m along the centreline
  std::vector<std::pair<double, double>> touching;  // arc positions (m) of parts whose walls touch
  int nodes = 0, beads = 0, ring_vertices = 8;      // in all, along the whole rod
  int chain_pieces = 1;  // a long organ runs as a chain of pieces (decision 0030), each with its mesh and cage
  std::filesystem::path scene, centreline_file, surface_file;
  // From building the written scene once.
  std::size_t cage_rings = 0, dropped_rings = 0, rest_pose_outside = 0, binding_pieces = 0;
  double max_dropped_mass = 0.0, max_rest_correction = 0.0, build_seconds = 0.0, seconds = 0.0;
  std::vector<std::string> retries;        // builds that failed before the one written, and why
  [[nodiscard]] std::string text() const;  // what was done, for the terminal
};

// Throws haustra::Error naming the file and what was expected: no mesh, no tube in it, a
// centreline outside the mesh, units that cannot be told, a scene that does not build (with the
// place and the flag that gets past it).
ImportReport import_surface(const ImportOptions& options);

}  // namespace haustra::import
