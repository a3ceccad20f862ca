#pragma once
// `haustra import`: a segmented organ surface (OBJ, STL, OFF, glTF; open, closed or blind ends; in
// millimetres or metres; one tube, a wall of two nested shells, or a whole organ in pieces) turned
// into a scene that runs: repaired (CGAL), its pieces and shells sorted out, its centreline read or
// computed from a harmonic function on the wall, the rod, beads, cage and mesh written as a scene
// file, and the scene built once to prove it (docs/decisions/0047, 0049, 0050).
#include <array>
#include <cstdint>
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
  // Several organs in one scene and the body around them (import_surfaces; decisions 0093, 0094):
  std::vector<std::filesystem::path> more_meshes;  // further surfaces, joined to an organ where open ends meet
  std::filesystem::path body;                      // the body's boundary: a container the beads stay inside
  // Gravity's direction in the surfaces' frame: -x, +x, -y, +y, -z, +z, supine (towards the body's
  // back), prone, or a vector "x,y,z"; empty: supine with a body, else -z (as one surface has had).
  std::string gravity;
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
  std::size_t fused_copies = 0;  // vertices copied where the surface fused loops and was cut apart (issue 35)
  double max_dropped_mass = 0.0, max_rest_correction = 0.0, build_seconds = 0.0, seconds = 0.0;
  std::vector<std::string> retries;        // builds that failed before the one written, and why
  [[nodiscard]] std::string text() const;  // what was done, for the terminal
};

// Throws haustra::Error naming the file and what was expected: no mesh, no tube in it, a
// centreline outside the mesh, units that cannot be told, a scene that does not build (with the
// place and the flag that gets past it). One surface: options.more_meshes, body and gravity unused.
ImportReport import_surface(const ImportOptions& options);

// What `--gravity` says, before a body is looked at: an axis or a vector (direction, unit length),
// or the body's back or front (`supine`, `prone`: resolved from the body). Throws
// Error{invalid_argument} naming --gravity and what it takes.
struct GravityChoice {
  enum class Kind : std::uint8_t { direction, supine, prone } kind = Kind::direction;
  std::array<double, 3> direction{0.0, 0.0, -1.0};
};
GravityChoice parse_gravity(const std::string& value);

// Several surfaces, and the body around them, as one scene (`haustra import A B … [--body BODY]`):
// each surface repaired on its own, the organs made of the surfaces whose open ends meet (each the
// longest chain of joined pieces, as one surface's pieces are joined: decision 0094), each organ a
// [[segment]] sized, beaded and caged as import_surface does one, the body a container
// (decision 0093), gravity as asked. Built once. Throws as import_surface does, naming the surface.
struct SurfacesReport {
  struct Organ {
    std::string name;                             // the segment's: its surfaces' common name
    std::vector<std::filesystem::path> surfaces;  // on its path, in order along it
    ImportReport report;                          // as one surface's import would say it
  };
  std::vector<Organ> organs;
  std::vector<std::filesystem::path> unused;  // surfaces no organ took (nothing in them joins)
  // The body, when given.
  std::filesystem::path body, body_file;  // as given; as written beside the scene (metres)
  std::string body_units_reason, body_repairs;
  std::size_t body_vertices = 0, body_triangles = 0;  // as written
  int body_capped = 0;                                // open ends (the scan's) closed by a fan each
  double body_volume = 0.0;                           // m³
  double outside_body = 0.0;                          // fraction of the organs' vertices outside it
  std::array<double, 3> gravity{0.0, 0.0, -9.81};     // m/s², as written
  std::string gravity_reason;
  std::filesystem::path scene;
  double build_seconds = 0.0, seconds = 0.0;
  [[nodiscard]] std::string text() const;  // what was done, for the terminal
};
SurfacesReport import_surfaces(const ImportOptions& options);

}  // namespace haustra::import
