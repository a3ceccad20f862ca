#pragma once
// The phases of an import that one surface's (import.cpp) and several surfaces' (import_surfaces.cpp)
// share: units, reading, the organ's centreline and rod, the surface and files it writes, the build.
#include <chrono>
#include <filesystem>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "centreline_fit.hpp"
#include "haustra/embree_scene.hpp"
#include "haustra/error.hpp"
#include "haustra/import/import.hpp"
#include "haustra/mesh_io.hpp"
#include "haustra/world.hpp"
#include "organ_layout.hpp"

namespace haustra::import {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t);
// Told as each phase ends: what was done, and since when.
using Phase = std::function<void(const std::string&, Clock::time_point)>;

// File units to metres, and why: asked (mm, m), or from the size of the mesh's box.
std::pair<double, std::string> decide_units(const TriangleMesh& mesh, const std::string& asked,
                                            const std::string& file);
// The surface o.mesh as the file holds it, in metres (r: its counts and units).
TriangleMesh read_in_metres(const ImportOptions& o, ImportReport& r);
// The wall's thickness where it is two shells (0: one shell).
double wall_thickness(const OrganLayout& layout);
// The organ's centreline (given or computed) measured into r, and the beads' radius profile.
Polyline centreline_of(const ImportOptions& o, const OrganLayout& layout, const EmbreeScene& wall, ImportReport& r,
                       std::vector<std::pair<double, double>>& profile);
// Nodes, beads and chain pieces from the centreline's length (or o.nodes, o.beads).
void size_the_rod(const ImportOptions& o, ImportReport& r);
// The surface the scene uses: the organ's outer pieces and lumens, less what the centreline misses.
TriangleMesh surface_along(const OrganLayout& layout, const Polyline& line, ImportReport& r, const std::string& file);
// The surface and centreline written as `<stem>-surface.obj` and `<stem>-centreline.json`.
void write_surface_and_centreline(const std::string& stem, const TriangleMesh& surface, const Polyline& line,
                                  const std::string& source_name, ImportReport& r);
// The organ's layout into r (pieces, shells, holes, wall thickness), its centreline (into r) and
// rod (size_the_rod): what every organ of an import goes through once its pieces are sorted out.
Polyline organ_rod(const ImportOptions& o, const OrganLayout& layout, ImportReport& r,
                   std::vector<std::pair<double, double>>& profile, const Phase& phase);
// What a build of the scene found about segments [first, first + count) (an organ, its chain's pieces).
void read_build(const World& world, std::size_t first, std::size_t count, ImportReport& r);
// After a build failed with `e`: a cage that could not embed its mesh is retried with more vertices
// per ring, then fewer beads (unless o.beads was given), within the import's time budget (true,
// with r changed and the try recorded); anything else is not (false). A repaired surface the
// engine refuses is the repair's defect: thrown as Error{internal} naming it.
bool retry_cage(const ImportOptions& o, ImportReport& r, const Error& e, double elapsed);

}  // namespace haustra::import
