// haustra import: surface → units → repair → pieces and shells → centreline (read or computed) →
// beads from the wall → scene files → the scene built once to prove it.
#include "haustra/import/import.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <map>

#include "haustra/centreline.hpp"
#include "haustra/scene.hpp"
#include "haustra/tube_axis.hpp"
#include "import_phases.hpp"
#include "organ_centreline.hpp"
#include "scene_files.hpp"
#include "surface_repair.hpp"

namespace haustra::import {
namespace {

constexpr double kSpacing = 0.001;            // m between resampled centreline points
constexpr double kBuildBudgetSeconds = 45.0;  // tries at building the scene stop after this

}  // namespace

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

std::pair<double, std::string> decide_units(const TriangleMesh& mesh, const std::string& asked,
                                            const std::string& file) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (const auto& v : mesh.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  const double size = (hi - lo).norm();
  if (asked == "mm") return {1e-3, fmt::format("millimetres (--units mm; the box is {:.4g} mm across)", size)};
  if (asked == "m") return {1.0, fmt::format("metres (--units m; the box is {:.4g} m across)", size)};
  // An organ's box spans 5 mm (a short flexure) to 5 m (a whole bowel, coiled): in millimetres
  // 20 to 5,000 (below 20 mm it would be metres: 20 m), in metres 0.005 to 5.
  if (size >= 20.0 && size <= 5000.0)
    return {1e-3, fmt::format("millimetres (the box is {:.4g} across: in metres no organ is that large)", size)};
  if (size >= 0.005 && size <= 5.0)
    return {1.0, fmt::format("metres (the box is {:.4g} across: in millimetres no organ is that small)", size)};
  throw Error(ErrorCode::invalid_argument,
              fmt::format("{}: the mesh's box is {:.4g} units across, which is neither an organ in millimetres "
                          "(20 to 5,000) nor in metres (0.005 to 5): give --units mm or --units m",
                          file, size));
}

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// A given midline: kept where the outer wall surrounds it (what runs past the open ends is cut).
Polyline trimmed_midline(const EmbreeScene& wall, Polyline line, const std::string& file, const std::string& source,
                         ImportReport& r) {
  const Coverage cov = coverage(wall, line, 0.1);
  const auto first = std::find(cov.covered.begin(), cov.covered.end(), true);
  if (first == cov.covered.end())
    throw Error(ErrorCode::invalid_geometry,
                fmt::format("{}: the centreline ({}) is outside the mesh: at none of its {} points does the surface "
                            "surround it (16 rays in the normal plane, within 0.1 m)",
                            file, source, line.size()));
  const auto begin = static_cast<std::size_t>(first - cov.covered.begin());
  const std::size_t end =
      cov.covered.size() -
      static_cast<std::size_t>(std::find(cov.covered.rbegin(), cov.covered.rend(), true) - cov.covered.rbegin());
  const auto inside =
      static_cast<std::size_t>(std::count(cov.covered.begin() + static_cast<std::ptrdiff_t>(begin),
                                          cov.covered.begin() + static_cast<std::ptrdiff_t>(end), true));
  if (static_cast<double>(inside) < 0.8 * static_cast<double>(end - begin))
    throw Error(
        ErrorCode::invalid_geometry,
        fmt::format("{}: the centreline ({}) leaves the mesh: between its ends inside the surface only {} of {} "
                    "points have the wall around them — is it this mesh's midline, in its units?",
                    file, source, inside, end - begin));
  r.trimmed_start = static_cast<double>(begin) * kSpacing;
  r.trimmed_end = static_cast<double>(line.size() - end) * kSpacing;
  return Polyline(line.begin() + static_cast<std::ptrdiff_t>(begin), line.begin() + static_cast<std::ptrdiff_t>(end));
}

// The beads' radius along the rod: the median distance to the outer wall over the rays (of 16 in
// each normal plane, at least half) that meet it, smoothed over a radius; where fewer meet it (past
// an open end), the nearest value.
std::vector<std::pair<double, double>> radius_profile(const EmbreeScene& wall, const Polyline& line, double& median_r) {
  const Coverage cov = coverage(wall, line, 0.1, 8);
  std::vector<double> r(line.size(), 0.0), known;
  for (std::size_t i = 0; i < line.size(); ++i)
    if (cov.covered[i]) known.push_back(cov.radius[i]);
  median_r = median(known);
  if (known.empty()) return {{0.0, median_r}, {1.0, median_r}};
  // Fill the gaps from the nearest covered point on each side.
  std::ptrdiff_t last = -1;
  for (std::size_t i = 0; i < line.size(); ++i)
    if (cov.covered[i]) {
      for (auto j = static_cast<std::size_t>(last + 1); j < i; ++j)
        r[j] = last < 0
                   ? cov.radius[i]
                   : (j - static_cast<std::size_t>(last) < i - j ? r[static_cast<std::size_t>(last)] : cov.radius[i]);
      r[i] = cov.radius[i];
      last = static_cast<std::ptrdiff_t>(i);
    }
  for (auto j = static_cast<std::size_t>(last + 1); j < line.size(); ++j) r[j] = r[static_cast<std::size_t>(last)];
  // Smoothed (a moving median over a radius: a haustral fold or a ray through a side
  // opening is not the organ's width), sampled at up to 65 places.
  const auto half = static_cast<std::ptrdiff_t>(std::max(1.0, std::round(median_r / kSpacing)));
  const auto n = static_cast<std::ptrdiff_t>(line.size());
  std::vector<double> smoothed(line.size());
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    std::vector<double> window;
    for (std::ptrdiff_t j = std::max<std::ptrdiff_t>(0, i - half); j <= std::min(n - 1, i + half); ++j)
      window.push_back(r[static_cast<std::size_t>(j)]);
    smoothed[static_cast<std::size_t>(i)] = median(window);
  }
  std::vector<std::pair<double, double>> profile;
  const std::size_t samples = std::min<std::size_t>(65, line.size());
  for (std::size_t k = 0; k < samples; ++k) {
    const std::size_t i = (k * (line.size() - 1)) / std::max<std::size_t>(1, samples - 1);
    profile.emplace_back(static_cast<double>(i) / static_cast<double>(line.size() - 1), smoothed[i]);
  }
  return profile;
}

}  // namespace

// The wall's thickness where it is two shells: the median distance from the lumen's vertices to
// the outer wall.
double wall_thickness(const OrganLayout& layout) {
  if (layout.lumens.empty()) return 0.0;
  EmbreeScene outer;
  for (std::size_t p : layout.path)
    outer.add_triangles(layout.pieces[p].mesh.vertices, layout.pieces[p].mesh.triangles);
  outer.commit();
  std::vector<double> d;
  for (std::size_t p : layout.lumens) {
    const auto& vs = layout.pieces[p].mesh.vertices;
    const std::size_t stride = std::max<std::size_t>(1, vs.size() / 2000);
    for (std::size_t v = 0; v < vs.size(); v += stride) {
      const EmbreeScene::Hit h = outer.closest(vs[v], 1.0);
      if (h.found) d.push_back(h.distance);
    }
  }
  return median(d);
}

std::string ImportReport::text() const {
  std::string t = fmt::format("surface: {} vertices, {} triangles; units: {}\n", vertices, triangles, units_reason);
  t += fmt::format("repair: {}\n", repairs);
  t += fmt::format(
      "organ: {}; {} open end{}, {} boundary loop{} in all{}\n", layout, open_ends, open_ends == 1 ? "" : "s", holes,
      holes == 1 ? "" : "s",
      wall_thickness > 0.0 ? fmt::format("; wall {:.1f} mm thick (between the shells)", 1e3 * wall_thickness) : "");
  t += fmt::format("centreline: {}\n", centreline_source);
  if (off_path_vertices > 0)
    t += fmt::format("left out: {} vertices of the surface farther than eight radii from the centreline\n",
                     off_path_vertices);
  t += fmt::format("length: {:.1f} mm", 1e3 * length);
  if (trimmed_start > 0.0 || trimmed_end > 0.0)
    t += fmt::format(" (trimmed {:.1f} mm at the start and {:.1f} mm at the end, where it ran past the mesh)",
                     1e3 * trimmed_start, 1e3 * trimmed_end);
  // A bend wider than a hundred radii is no bend: the line is straight.
  t += median_radius > 0.0 && tightest_bend < 100.0 * median_radius
           ? fmt::format(
                 "\nradius: {:.1f} mm (median); tightest bend: radius {:.1f} mm at {:.0f} mm ({:.2f}x the "
                 "organ's radius)\n",
                 1e3 * median_radius, 1e3 * tightest_bend, 1e3 * tightest_bend_at, tightest_bend / median_radius)
           : fmt::format("\nradius: {:.1f} mm (median); straight (no bend tighter than a hundred radii)\n",
                         1e3 * median_radius);
  if (touching.empty()) t += "loops: no part of the organ touches another\n";
  const std::size_t shown = std::min<std::size_t>(touching.size(), 6);
  for (std::size_t i = 0; i < shown; ++i)
    t += fmt::format("loops: the wall at {:.0f} mm touches the wall at {:.0f} mm\n", 1e3 * touching[i].first,
                     1e3 * touching[i].second);
  if (touching.size() > shown) t += fmt::format("loops: ... {} more touching places\n", touching.size() - shown);
  t += fmt::format("rod: {} nodes, {} beads sized from the outer wall, rings of {} vertices{}\n", nodes, beads,
                   ring_vertices,
                   chain_pieces > 1 ? fmt::format(", as a chain of {} pieces of {} nodes (each its own mesh and cage)",
                                                  chain_pieces, (nodes - 1) / chain_pieces + 1)
                                    : "");
  for (const std::string& why : retries) t += fmt::format("retried: {}\n", why.substr(0, why.find(" (mesh ")));
  if (cage_rings > 0)
    t += fmt::format(
        "built in {:.2f} s: cage of {} rings ({} dropped), binding from a harmonic function on {} piece{}{}, {} mesh "
        "vertices outside the cage at the curved rest pose, weight left out by localization up to {:.3f}, rest "
        "correction up to {:.2f} mm\n",
        build_seconds, cage_rings, dropped_rings, binding_pieces, binding_pieces == 1 ? "" : "s",
        fused_copies > 0
            ? fmt::format(", the surface cut apart where it fuses loops ({} copies of its vertices)", fused_copies)
            : "",
        rest_pose_outside, max_dropped_mass, 1e3 * max_rest_correction);
  t += fmt::format("import took {:.1f} s\n", seconds);
  return t;
}

// The surface as the file holds it, in metres.
TriangleMesh read_in_metres(const ImportOptions& o, ImportReport& r) {
  TriangleMesh raw = load_mesh_as_read(o.mesh);
  r.vertices = raw.vertices.size();
  r.triangles = raw.triangles.size();
  if (raw.triangles.empty())
    throw Error(ErrorCode::invalid_geometry, fmt::format("{}: the mesh holds no triangles", o.mesh.string()));
  for (std::size_t v = 0; v < raw.vertices.size(); ++v)
    if (!raw.vertices[v].allFinite())
      // (No index: the reader renumbers the file's vertices.)
      throw Error(ErrorCode::parse,
                  fmt::format("{}: a vertex is not a finite point: ({}, {}, {}); every vertex "
                              "must be three finite numbers",
                              o.mesh.string(), raw.vertices[v].x(), raw.vertices[v].y(), raw.vertices[v].z()));
  std::tie(r.scale, r.units_reason) = decide_units(raw, o.units, o.mesh.string());
  r.units = r.scale == 1.0 ? "m" : "mm";
  for (auto& v : raw.vertices) v *= r.scale;
  return raw;
}

namespace {

// How many of a given centreline's two ends lie at an open end: within the radius of a rim's
// centre (side holes and the rims where a whole organ's pieces meet lie elsewhere along it).
int open_ends_of(const OrganLayout& layout, const Polyline& line) {
  int open = 0;
  for (const Eigen::Vector3d& end : {line.front(), line.back()}) {
    bool at_rim = false;
    for (std::size_t p : layout.path)
      for (const auto& loop : layout.pieces[p].loops) {
        const LoopShape rim = loop_shape(layout.pieces[p].mesh, loop);
        at_rim = at_rim || (rim.centre - end).norm() < rim.radius;
      }
    open += at_rim ? 1 : 0;
  }
  return open;
}

}  // namespace

// The centreline (given or computed), measured: length, radius, bends, touching parts; and the
// beads' radius profile from the outer wall.
Polyline centreline_of(const ImportOptions& o, const OrganLayout& layout, const EmbreeScene& wall, ImportReport& r,
                       std::vector<std::pair<double, double>>& profile) {
  const std::string file = o.mesh.string();
  Polyline line;
  if (!o.centreline.empty()) {
    Polyline given = read_centreline(o.centreline).points;
    if (o.reverse) std::reverse(given.begin(), given.end());
    r.centreline_source = o.centreline.string();
    line = trimmed_midline(wall, resample(given, kSpacing), file, r.centreline_source, r);
    r.open_ends = open_ends_of(layout, line);
  } else {
    OrganCentreline c;
    try {
      c = organ_centreline(layout, o.reverse);
    } catch (const Error& e) {
      throw Error(e.code(), fmt::format("{}: {} (give its midline with --centreline)", file, e.what()));
    }
    line = std::move(c.points);
    r.centreline_source = c.text;
    r.open_ends = c.open_ends;
  }
  try {
    check_centreline_points(line, "the centreline");
  } catch (const Error& e) {
    throw Error(ErrorCode::invalid_geometry,
                fmt::format("{}: {} ({}); give its midline with --centreline", file, e.what(), r.centreline_source));
  }
  r.length = polyline_length(line);
  profile = radius_profile(wall, line, r.median_radius);
  if (!(r.median_radius > 0.0))
    throw Error(ErrorCode::invalid_geometry,
                fmt::format("{}: no tube in this mesh: nowhere along its centreline does the wall surround it (16 "
                            "rays in each normal plane; give its midline with --centreline)",
                            file));
  if (r.length < r.median_radius)
    throw Error(ErrorCode::invalid_geometry,
                fmt::format("{}: no tube in this mesh: the centreline inside it is {:.1f} mm long for a radius of "
                            "{:.1f} mm (a tube is at least as long as its radius)",
                            file, 1e3 * r.length, 1e3 * r.median_radius));
  if (r.open_ends == 0 && r.length < 2.0 * r.median_radius)
    throw Error(ErrorCode::invalid_geometry,
                fmt::format("{}: no tube in this mesh: it is closed and its centreline is {:.1f} mm long for a radius "
                            "of {:.1f} mm, a blob rather than a tube (a closed organ is longer than it is wide; give "
                            "its midline with --centreline if it is one)",
                            file, 1e3 * r.length, 1e3 * r.median_radius));
  // Bends of the centreline smoothed over half a radius: a midline's voxel steps are not bends.
  const std::vector<double> bends =
      bend_radii(smooth(line, kSpacing, 0.5 * r.median_radius), kSpacing, std::min(0.005, 0.25 * r.length));
  const auto tight = std::min_element(bends.begin(), bends.end());
  r.tightest_bend = *tight;
  r.tightest_bend_at = static_cast<double>(tight - bends.begin()) * kSpacing;
  r.touching = touching_parts(line, kSpacing, 6.0 * r.median_radius, 2.5 * r.median_radius);
  return line;
}

// A node per 5 mm; past 201 nodes, a chain of pieces of at most 101 nodes each (the cage and the
// skinning per piece, the solve still one rod: decision 0030); a bead per three nodes.
void size_the_rod(const ImportOptions& o, ImportReport& r) {
  r.nodes = o.nodes > 0 ? o.nodes : std::clamp(static_cast<int>(std::lround(r.length / 0.005)) + 1, 9, 1201);
  if (r.nodes > 201) {
    r.chain_pieces = (r.nodes - 1 + 99) / 100;
    r.nodes = r.chain_pieces * ((r.nodes - 1 + r.chain_pieces - 1) / r.chain_pieces) + 1;
  }
  r.beads = o.beads > 0 ? o.beads : std::max(2 * r.chain_pieces, r.nodes / 3);
}

namespace {

// Parts of the surface the centreline does not reach (farther from it than eight times the organ's
// median radius: a branch or a loop the computed line passes by) are left out and counted, so that
// the rest runs; more than a quarter of the surface is a centreline that misses the organ: refused.
void off_the_path(TriangleMesh& surface, const Polyline& line, ImportReport& r, const std::string& file) {
  const double far = 8.0 * r.median_radius, cell = far;
  std::map<std::array<long, 3>, std::vector<std::uint32_t>> grid;  // centreline points by cell
  auto key = [&](const Eigen::Vector3d& x) {
    return std::array<long, 3>{std::lround(std::floor(x.x() / cell)), std::lround(std::floor(x.y() / cell)),
                               std::lround(std::floor(x.z() / cell))};
  };
  for (std::uint32_t i = 0; i < line.size(); ++i) grid[key(line[i])].push_back(i);
  std::vector<std::uint8_t> off(surface.vertices.size(), 1);
  for (std::size_t v = 0; v < surface.vertices.size(); ++v) {
    const auto k = key(surface.vertices[v]);
    for (long dx = -1; dx <= 1 && off[v] != 0; ++dx)
      for (long dy = -1; dy <= 1 && off[v] != 0; ++dy)
        for (long dz = -1; dz <= 1 && off[v] != 0; ++dz) {
          const auto it = grid.find({k[0] + dx, k[1] + dy, k[2] + dz});
          if (it == grid.end()) continue;
          for (std::uint32_t i : it->second)
            if ((line[i] - surface.vertices[v]).norm() < far) {
              off[v] = 0;
              break;
            }
        }
  }
  const auto left = static_cast<std::size_t>(std::count(off.begin(), off.end(), std::uint8_t{1}));
  if (left == 0) return;
  if (4 * left > surface.vertices.size())
    throw Error(ErrorCode::invalid_geometry,
                fmt::format("{}: the centreline ({}) reaches only {} of the surface's {} vertices (within eight "
                            "radii): it misses the organ; give its midline with --centreline",
                            file, r.centreline_source, surface.vertices.size() - left, surface.vertices.size()));
  std::vector<std::uint8_t> keep(surface.triangles.size());
  for (std::size_t t = 0; t < keep.size(); ++t) {
    const auto& tri = surface.triangles[t];
    keep[t] = off[tri[0]] == 0 && off[tri[1]] == 0 && off[tri[2]] == 0 ? 1 : 0;
  }
  TriangleMesh kept = submesh(surface, keep);
  r.off_path_vertices = surface.vertices.size() - kept.vertices.size();
  surface = std::move(kept);
}

}  // namespace

// The surface the scene uses: the outer pieces on the organ's path and their lumens (and, of
// several surfaces, the pieces joined to the path off it), as one mesh, less what the centreline
// does not reach.
TriangleMesh surface_along(const OrganLayout& layout, const Polyline& line, ImportReport& r, const std::string& file) {
  std::vector<const TriangleMesh*> kept;
  for (std::size_t p : layout.path) kept.push_back(&layout.pieces[p].mesh);
  for (std::size_t p : layout.lumens) kept.push_back(&layout.pieces[p].mesh);
  for (std::size_t p : layout.joined_off_path) kept.push_back(&layout.pieces[p].mesh);
  TriangleMesh surface = joined_apart(kept);
  off_the_path(surface, line, r, file);
  r.repaired_vertices = surface.vertices.size();
  r.repaired_triangles = surface.triangles.size();
  return surface;
}

void write_surface_and_centreline(const std::string& stem, const TriangleMesh& surface, const Polyline& line,
                                  const std::string& source_name, ImportReport& r) {
  r.centreline_file = stem + "-centreline.json";
  r.surface_file = stem + "-surface.obj";
  write_obj(r.surface_file, surface, fmt::format("repaired by haustra import from {}", source_name));
  write_centreline(r.centreline_file, line, r.centreline_source);
}

bool retry_cage(const ImportOptions& o, ImportReport& r, const Error& e, double elapsed) {
  const auto* field = dynamic_cast<const FieldError*>(&e);
  if (field != nullptr && field->field().ends_with(".mesh.file"))
    throw Error(ErrorCode::internal,
                fmt::format("{}: the repaired surface {} does not pass the engine's checks: {}\nThat is a defect "
                            "the repair left, not one of the flags: please report it with the surface.",
                            o.mesh.string(), r.surface_file.string(), field->detail()));
  const int fewer = r.beads * 3 / 4;
  const bool more_vertices = r.ring_vertices < 16;
  const bool can_thin = o.beads == 0 && fewer >= std::max(2 * r.chain_pieces, r.nodes / 8);
  const bool cage = field != nullptr && field->field().ends_with(".mesh.cage");
  if (!cage || !(more_vertices || can_thin) || elapsed >= kBuildBudgetSeconds) return false;
  r.retries.push_back(fmt::format("{} beads, rings of {}: {}", r.beads, r.ring_vertices, e.what()));
  if (more_vertices)
    r.ring_vertices += 4;
  else
    r.beads = fewer;
  return true;
}

namespace {

// The surface and the centreline, beside the scene.
void write_beside_scene(const ImportOptions& o, const TriangleMesh& surface, const Polyline& line, ImportReport& r) {
  r.scene = o.out.empty() ? std::filesystem::path(o.mesh.stem().string() + ".toml") : o.out;
  if (r.scene.has_parent_path()) std::filesystem::create_directories(r.scene.parent_path());
  write_surface_and_centreline((r.scene.parent_path() / r.scene.stem()).string(), surface, line,
                               o.mesh.filename().string(), r);
}

// Built once: what fails here would fail in `haustra run`. A cage that cannot embed the mesh gets
// more vertices per ring, then fewer, wider-spaced rings (rings sit on beads), within a time budget.
void build_once(const ImportOptions& o, const SceneFileInputs& scene, ImportReport& r, const Phase& phase) {
  const auto t = Clock::now();
  for (int attempt = 1;; ++attempt) {
    try {
      const auto world = create_world(load_scene(r.scene));
      read_build(*world, 0, world->segment_count(), r);
      break;
    } catch (const Error& e) {
      if (retry_cage(o, r, e, seconds_since(t))) {
        write_scene(scene);
        phase(fmt::format("build {} failed at the cage; trying {} beads with rings of {}", attempt, r.beads,
                          r.ring_vertices),
              t);
        continue;
      }
      throw Error(e.code(),
                  fmt::format("{}\nthe imported scene {} does not build{}. Flags that change what failed: --nodes N "
                              "and --beads N (rings sit on beads: fewer beads, fewer rings to cross), "
                              "--centreline FILE (a midline of your own), --units",
                              e.what(), r.scene.string(),
                              r.retries.empty() ? ""
                                                : fmt::format(" (with {} beads and rings of {}, after {} tries)",
                                                              r.beads, r.ring_vertices, r.retries.size())));
    }
  }
  r.build_seconds = seconds_since(t);
  phase(fmt::format("built: cage of {} rings", r.cage_rings), t);
}

}  // namespace

Polyline organ_rod(const ImportOptions& o, const OrganLayout& layout, ImportReport& r,
                   std::vector<std::pair<double, double>>& profile, const Phase& phase) {
  auto t = Clock::now();
  if (layout.path.empty())
    throw Error(ErrorCode::invalid_geometry, fmt::format("{}: no outer wall in this mesh to follow", o.mesh.string()));
  r.layout = layout.text();
  r.pieces = layout.path.size();
  r.shells = layout.lumens.size();
  for (std::size_t p : layout.path) r.holes += static_cast<int>(layout.pieces[p].loops.size());
  r.wall_thickness = wall_thickness(layout);
  phase("organ: " + r.layout, t);

  t = Clock::now();
  EmbreeScene wall;
  for (std::size_t p : layout.path) wall.add_triangles(layout.pieces[p].mesh.vertices, layout.pieces[p].mesh.triangles);
  wall.commit();
  const Polyline line = centreline_of(o, layout, wall, r, profile);
  phase(fmt::format("centreline: {:.0f} mm, radius {:.1f} mm", 1e3 * r.length, 1e3 * r.median_radius), t);
  size_the_rod(o, r);
  return line;
}

void read_build(const World& world, std::size_t first, std::size_t count, ImportReport& r) {
  r.cage_rings = r.dropped_rings = r.rest_pose_outside = r.binding_pieces = r.fused_copies = 0;
  for (std::size_t s = first; s < first + count; ++s) {  // a chain: each piece's mesh and cage
    const MeshInfo& m = world.mesh(s);
    r.cage_rings += m.cage.rings;
    r.dropped_rings += m.cage.dropped_rings;
    r.rest_pose_outside += m.cage.rest_pose_outside;
    r.binding_pieces += m.cage.binding_pieces;
    r.fused_copies += m.cage.fused_copies;
    r.max_dropped_mass = std::max(r.max_dropped_mass, m.skin.max_dropped_mass);
    r.max_rest_correction = std::max(r.max_rest_correction, m.skin.max_rest_correction);
  }
}

ImportReport import_surface(const ImportOptions& o) {
  const auto started = Clock::now();
  if (o.ends != "held" && o.ends != "base" && o.ends != "free")
    throw Error(ErrorCode::invalid_argument, fmt::format("--ends: expected held, base or free, got '{}'", o.ends));
  if (o.tissue != "rest" && o.tissue != "none")
    throw Error(ErrorCode::invalid_argument, fmt::format("--tissue: expected rest or none, got '{}'", o.tissue));
  if (o.units != "auto" && o.units != "mm" && o.units != "m")
    throw Error(ErrorCode::invalid_argument, fmt::format("--units: expected auto, mm or m, got '{}'", o.units));
  const Phase phase = [&](const std::string& what, Clock::time_point since) {
    if (o.progress) o.progress(fmt::format("{} ({:.1f} s)", what, seconds_since(since)));
  };
  ImportReport r;
  auto t = Clock::now();
  const TriangleMesh raw = read_in_metres(o, r);
  phase(fmt::format("read {} vertices, {} triangles, in {}", r.vertices, r.triangles, r.units), t);

  t = Clock::now();
  RepairedSurface repaired = repair_surface(raw, o.mesh.string());
  r.repairs = repaired.report.text();
  phase("repair: " + r.repairs, t);

  t = Clock::now();
  const OrganLayout layout = organ_layout(std::move(repaired.pieces));
  std::vector<std::pair<double, double>> profile;
  const Polyline line = organ_rod(o, layout, r, profile, phase);
  write_beside_scene(o, surface_along(layout, line, r, o.mesh.string()), line, r);
  const SceneFileInputs scene{.options = o, .report = r, .radius_profile = profile};
  write_scene(scene);
  build_once(o, scene, r, phase);
  r.seconds = seconds_since(started);
  write_scene(scene);  // again, with what the build found in its comments
  return r;
}

}  // namespace haustra::import
