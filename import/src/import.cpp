// haustra import: surface → units → centreline (read or skeleton) → trimmed to the mesh →
// scene file → the scene built once to prove it.
#include "haustra/import/import.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "centreline_fit.hpp"
#include "haustra/centreline.hpp"
#include "haustra/embree_scene.hpp"
#include "haustra/error.hpp"
#include "haustra/mesh_io.hpp"
#include "haustra/scene.hpp"
#include "skeleton.hpp"

namespace haustra::import {
namespace {

constexpr double kSpacing = 0.001;  // m between resampled centreline points

std::size_t boundary_loops(const TriangleMesh& mesh) {
  // Border edges (used by one triangle), then loops by following them vertex to vertex.
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> uses;
  for (const auto& t : mesh.triangles)
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t a = t[static_cast<std::size_t>(i)], b = t[static_cast<std::size_t>((i + 1) % 3)];
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  std::map<std::uint32_t, std::vector<std::uint32_t>> next;
  for (const auto& [e, n] : uses)
    if (n == 1) {
      next[e.first].push_back(e.second);
      next[e.second].push_back(e.first);
    }
  std::set<std::uint32_t> seen;
  std::size_t loops = 0;
  for (const auto& [v, _] : next) {
    if (seen.count(v) != 0) continue;
    ++loops;
    std::vector<std::uint32_t> stack{v};
    while (!stack.empty()) {
      const std::uint32_t u = stack.back();
      stack.pop_back();
      if (!seen.insert(u).second) continue;
      for (std::uint32_t w : next[u]) stack.push_back(w);
    }
  }
  return loops;
}

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
  // An organ segment spans 2 cm to 3 m: in millimetres that is 20 to 3,000, in metres 0.02 to 3.
  if (size >= 20.0 && size <= 5000.0)
    return {1e-3, fmt::format("millimetres (the box is {:.4g} across: in metres no organ is that large)", size)};
  if (size >= 0.005 && size <= 5.0)
    return {1.0, fmt::format("metres (the box is {:.4g} across: in millimetres no organ is that small)", size)};
  throw Error(ErrorCode::invalid_argument,
              fmt::format("{}: the mesh's box is {:.4g} units across, which is neither an organ in millimetres "
                          "(20 to 5,000) nor in metres (0.005 to 5): give --units mm or --units m",
                          file, size));
}

void write_centreline(const std::filesystem::path& file, const Polyline& p, const std::string& source) {
  nlohmann::json j;
  j["units"] = "m";
  j["source"] = source;
  for (const auto& q : p) j["points"].push_back({q.x(), q.y(), q.z()});
  std::ofstream out(file);
  out << j.dump() << "\n";
  if (!out) throw Error(ErrorCode::io, fmt::format("{}: cannot write the centreline", file.string()));
}

std::string commented(const std::string& text) {
  std::string out;
  for (char c : text) out += c == '\n' ? std::string("\n#   ") : std::string(1, c);
  while (!out.empty() && (out.back() == ' ' || out.back() == '#')) out.pop_back();
  return out;
}

std::string toml_path(const std::filesystem::path& target, const std::filesystem::path& scene_dir) {
  std::error_code ec;
  const auto rel =
      std::filesystem::relative(std::filesystem::absolute(target), std::filesystem::absolute(scene_dir), ec);
  return ec || rel.empty() ? std::filesystem::absolute(target).string() : rel.string();
}

void write_scene(const ImportOptions& o, const ImportReport& r) {
  const std::string name = o.mesh.stem().string();
  std::string text = fmt::format(
      "# Written by `haustra import {}`. What it found:\n#   {}\n\n"
      "[scene]\nname = \"{}\"\ndescription = \"{} imported: {:.3f} m of centreline, {} vertices\"\nframes = 240\n\n"
      "[world]\ndt = 0.016666666666666666\ngravity = [0.0, 0.0, -9.81]\n\n"
      "[solver]\nmode = \"newton\"\niterations = 2\n\n"
      "[[segment]]\nname = \"{}\"\nnodes = {}\nradius = {:.6g}\nwall_thickness = {:.6g}\nbase = \"{}\"\n"
      "[segment.rest]\nshape = \"centreline\"\nfile = \"{}\"\n"
      "[segment.beads]\ncount = {}\nradius = \"mesh\"             # each bead as wide as the wall around its node\n"
      "[segment.mesh]\nfile = \"{}\"\nscale = {}\n"
      "[segment.mesh.cage]\nring_vertices = 8\n",
      o.mesh.filename().string(), commented(r.text()), name, name, r.length, r.vertices, name, r.nodes, r.median_radius,
      std::min(0.003, 0.25 * r.median_radius), o.ends == "free" ? "free" : "clamped",
      toml_path(r.centreline_file, r.scene.parent_path()), r.beads, toml_path(o.mesh, r.scene.parent_path()), r.scale);
  if (o.ends == "held") text += "[[segment.attachment]]\nnode = -1                   # the far end stays where it is\n";
  std::ofstream out(r.scene);
  out << text;
  if (!out) throw Error(ErrorCode::io, fmt::format("{}: cannot write the scene", r.scene.string()));
}

}  // namespace

std::string ImportReport::text() const {
  std::string t = fmt::format("surface: {} vertices, {} triangles, {} open end{}; units: {}\n", vertices, triangles,
                              holes, holes == 1 ? "" : "s", units_reason);
  t += fmt::format("centreline: {}\n", centreline_source);
  t += fmt::format(
      "length: {:.1f} mm (trimmed {:.1f} mm at the start and {:.1f} mm at the end, where it ran past the "
      "mesh)\n",
      1e3 * length, 1e3 * trimmed_start, 1e3 * trimmed_end);
  t += fmt::format(
      "radius: {:.1f} mm (median); tightest bend: radius {:.1f} mm (over 5 mm, the line smoothed over half a radius) "
      "at {:.0f} mm ({:.2f}x the organ's "
      "radius)\n",
      1e3 * median_radius, 1e3 * tightest_bend, 1e3 * tightest_bend_at,
      median_radius > 0 ? tightest_bend / median_radius : 0.0);
  if (touching.empty()) t += "loops: no part of the organ touches another\n";
  for (const auto& [a, b] : touching)
    t += fmt::format("loops: the wall at {:.0f} mm touches the wall at {:.0f} mm\n", 1e3 * a, 1e3 * b);
  t += fmt::format("rod: {} nodes, {} beads sized from the mesh\n", nodes, beads);
  for (const std::string& why : retries)
    t += fmt::format("fewer beads: the cage did not embed the mesh with {}\n", why.substr(0, why.find(" (mesh ")));
  if (cage_rings > 0)
    t += fmt::format(
        "built in {:.2f} s: cage of {} rings ({} dropped), {} mesh vertices outside it at the curved rest "
        "pose, weight left out by localization up to {:.3f}, rest correction up to {:.2f} mm\n",
        build_seconds, cage_rings, dropped_rings, rest_pose_outside, max_dropped_mass, 1e3 * max_rest_correction);
  return t;
}

ImportReport import_surface(const ImportOptions& o) {
  if (o.ends != "held" && o.ends != "base" && o.ends != "free")
    throw Error(ErrorCode::invalid_argument, fmt::format("--ends: expected held, base or free, got '{}'", o.ends));
  if (o.units != "auto" && o.units != "mm" && o.units != "m")
    throw Error(ErrorCode::invalid_argument, fmt::format("--units: expected auto, mm or m, got '{}'", o.units));
  const std::string file = o.mesh.string();
  TriangleMesh mesh = load_mesh(o.mesh);
  ImportReport r;
  r.vertices = mesh.vertices.size();
  r.triangles = mesh.triangles.size();
  r.holes = static_cast<int>(boundary_loops(mesh));
  std::tie(r.scale, r.units_reason) = decide_units(mesh, o.units, file);
  r.units = r.scale == 1.0 ? "m" : "mm";

  // The centreline, in metres.
  Polyline raw;
  if (!o.centreline.empty()) {
    raw = read_centreline(o.centreline).points;
    r.centreline_source = o.centreline.string();
  } else {
    const SkeletonResult sk = skeleton_path(mesh, file);
    for (const auto& p : sk.path) raw.push_back(r.scale * p);
    r.centreline_source = fmt::format(
        "computed by CGAL's mean curvature flow skeleton ({} skeleton vertices, {} at "
        "branches, {} holes filled first, {:.1f} s)",
        sk.skeleton_vertices, sk.branches, sk.holes_filled, sk.seconds);
  }
  if (o.reverse) std::reverse(raw.begin(), raw.end());
  Polyline line = resample(raw, kSpacing);
  std::vector<Eigen::Vector3d> wall_vertices;
  for (const auto& v : mesh.vertices) wall_vertices.push_back(r.scale * v);
  EmbreeScene wall;
  wall.add_triangles(wall_vertices, mesh.triangles);
  wall.commit();
  if (o.centreline.empty()) {
    // A skeleton is pulled towards haustral bulges (up to 11 mm off the CT colon's midline) and
    // stops about a radius short of each end: each point is moved to the middle of the wall
    // around it, three times, smoothed over half the organ's radius (measured first), so real
    // bends stay (a bend of radius R moves in by about σ²/2R: 1.3 mm for R = 1.2 radii).
    const Coverage first_look = coverage(wall, smooth(line, kSpacing, 0.005), 0.1);
    std::vector<double> rs;
    for (std::size_t i = 0; i < line.size(); ++i)
      if (first_look.covered[i]) rs.push_back(first_look.radius[i]);
    const double radius =
        rs.empty() ? 0.01
                   : (std::nth_element(rs.begin(), rs.begin() + static_cast<std::ptrdiff_t>(rs.size() / 2), rs.end()),
                      rs[rs.size() / 2]);
    line = recentre(
        wall, smooth(resample(remove_backtracks(line, 0.5 * radius, 2.0 * radius), kSpacing), kSpacing, 0.5 * radius),
        kSpacing, 0.5 * radius, 3);
    line = straighten_ends(line, kSpacing, radius);
    r.centreline_source += fmt::format(
        ", moved to the middle of the lumen and smoothed over {:.1f} mm (half its radius), "
        "its last {:.0f} mm at each end straight",
        0.5e3 * radius, 1e3 * radius);
  }
  r.raw_length = polyline_length(line);

  // Where the mesh surrounds the centreline: trim what runs past the open ends.
  const Coverage cov = coverage(wall, line, 0.1);
  const auto first = std::find(cov.covered.begin(), cov.covered.end(), true);
  if (first == cov.covered.end())
    throw Error(ErrorCode::invalid_geometry,
                fmt::format("{}: the centreline ({}) is outside the mesh: at none of its {} points does the surface "
                            "surround it (16 rays in the normal plane, within 0.1 m)",
                            file, r.centreline_source, line.size()));
  const auto begin = static_cast<std::size_t>(first - cov.covered.begin());
  const std::size_t end =
      cov.covered.size() -
      static_cast<std::size_t>(std::find(cov.covered.rbegin(), cov.covered.rend(), true) - cov.covered.rbegin());
  std::size_t inside = 0;
  std::vector<double> radii;
  for (std::size_t i = begin; i < end; ++i)
    if (cov.covered[i]) {
      ++inside;
      radii.push_back(cov.radius[i]);
    }
  if (inside < 10)
    throw Error(ErrorCode::invalid_geometry,
                fmt::format("{}: no tube in this mesh: the surface surrounds only {} mm of its centreline ({})", file,
                            inside, r.centreline_source));
  if (static_cast<double>(inside) < 0.8 * static_cast<double>(end - begin))
    throw Error(
        ErrorCode::invalid_geometry,
        fmt::format("{}: the centreline ({}) leaves the mesh: between its ends inside the surface only {} of {} "
                    "points have the wall around them — is it this mesh's midline, in its units?",
                    file, r.centreline_source, inside, end - begin));
  r.trimmed_start = static_cast<double>(begin) * kSpacing;
  r.trimmed_end = static_cast<double>(line.size() - end) * kSpacing;
  line = Polyline(line.begin() + static_cast<std::ptrdiff_t>(begin), line.begin() + static_cast<std::ptrdiff_t>(end));
  r.length = polyline_length(line);
  std::nth_element(radii.begin(), radii.begin() + static_cast<std::ptrdiff_t>(radii.size() / 2), radii.end());
  r.median_radius = radii[radii.size() / 2];
  if (r.length < 4.0 * r.median_radius)
    throw Error(
        ErrorCode::invalid_geometry,
        fmt::format("{}: no tube in this mesh: the centreline inside it is {:.1f} mm long for a radius of {:.1f} "
                    "mm (a tube is at least four radii long)",
                    file, 1e3 * r.length, 1e3 * r.median_radius));

  // Bends of the centreline smoothed over half a radius: a midline's voxel steps are not bends.
  const std::vector<double> bends = bend_radii(smooth(line, kSpacing, 0.5 * r.median_radius), kSpacing, 0.005);
  const auto tight = std::min_element(bends.begin(), bends.end());
  r.tightest_bend = *tight;
  r.tightest_bend_at = static_cast<double>(tight - bends.begin()) * kSpacing;
  r.touching = touching_parts(line, kSpacing, 6.0 * r.median_radius, 2.5 * r.median_radius);

  r.nodes = o.nodes > 0 ? o.nodes : std::clamp(static_cast<int>(std::lround(r.length / 0.005)) + 1, 41, 401);
  r.beads = o.beads > 0 ? o.beads : std::max(2, r.nodes / 3);
  r.scene = o.out.empty() ? std::filesystem::path(o.mesh.stem().string() + ".toml") : o.out;
  if (r.scene.has_parent_path()) std::filesystem::create_directories(r.scene.parent_path());
  r.centreline_file = r.scene.parent_path() / (r.scene.stem().string() + "-centreline.json");
  write_centreline(r.centreline_file, line, r.centreline_source);
  write_scene(o, r);

  // Built once: what fails here would fail in `haustra run`. A cage that cannot embed the mesh
  // gets fewer, wider-spaced rings (rings sit on beads): a quarter fewer beads at a time, down to
  // one bead per eight nodes, unless --beads fixed them.
  const auto t0 = std::chrono::steady_clock::now();
  for (;;) {
    try {
      const SceneDesc scene = load_scene(r.scene);
      const auto world = create_world(scene);
      const MeshInfo& m = world->mesh(0);
      r.cage_rings = m.cage.rings;
      r.dropped_rings = m.cage.dropped_rings;
      r.rest_pose_outside = m.cage.rest_pose_outside;
      r.max_dropped_mass = m.skin.max_dropped_mass;
      r.max_rest_correction = m.skin.max_rest_correction;
      break;
    } catch (const Error& e) {
      const int fewer = r.beads * 3 / 4;
      if (o.beads == 0 && e.code() == ErrorCode::invalid_geometry && fewer >= std::max(8, r.nodes / 8)) {
        r.retries.push_back(fmt::format("{} beads: {}", r.beads, e.what()));
        r.beads = fewer;
        write_scene(o, r);
        continue;
      }
      throw Error(e.code(),
                  fmt::format("{}\nthe imported scene {} does not build{}. Flags that change what failed: --nodes N "
                              "and --beads N (rings sit on beads: fewer beads, fewer rings to cross), "
                              "--centreline FILE (a midline of your own), --units",
                              e.what(), r.scene.string(),
                              r.retries.empty() ? ""
                                                : fmt::format(" (with {} beads, after {} tries with more)", r.beads,
                                                              r.retries.size())));
    }
  }
  r.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  write_scene(o, r);  // again, with what the build found in its comments
  return r;
}

}  // namespace haustra::import
