// Several surfaces and the body around them as one scene: surfaces → units → repair, each → organs
// (their pieces joined where open ends meet) → each organ's centreline, rod and surface → the body
// closed → gravity → one scene → built once (decisions 0093, 0094).
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <map>
#include <optional>

#include "body.hpp"
#include "haustra/import/import.hpp"
#include "haustra/scene.hpp"
#include "import_phases.hpp"
#include "scene_files.hpp"
#include "surface_repair.hpp"

namespace haustra::import {
namespace {

namespace fs = std::filesystem;

struct Surfaces {
  std::vector<fs::path> files;
  std::vector<ImportReport> read;  // per file: counts as read, repairs
  std::vector<TriangleMesh> pieces;
  std::vector<std::size_t> source;  // per piece, its file
  double scale = 1.0;
  std::string units, units_reason;
};

// Every surface read, in one unit (from all their boxes together: one frame), and repaired on its own.
Surfaces read_surfaces(const ImportOptions& o, const Phase& phase) {
  Surfaces s;
  s.files.push_back(o.mesh);
  s.files.insert(s.files.end(), o.more_meshes.begin(), o.more_meshes.end());
  std::vector<TriangleMesh> raw;
  TriangleMesh all;  // every vertex, for the units
  for (const fs::path& file : s.files) {
    const auto t = Clock::now();
    ImportOptions one = o;
    one.mesh = file;
    one.units = std::string("m");  // as the file holds it: scaled below (a string: GCC 12 warns on the literal)
    ImportReport r;
    raw.push_back(read_in_metres(one, r));
    all.vertices.insert(all.vertices.end(), raw.back().vertices.begin(), raw.back().vertices.end());
    s.read.push_back(r);
    phase(fmt::format("read {}: {} vertices, {} triangles", file.filename().string(), r.vertices, r.triangles), t);
  }
  const std::string named = s.files.size() == 1 ? s.files[0].string() : fmt::format("the {} surfaces", s.files.size());
  std::tie(s.scale, s.units_reason) = decide_units(all, o.units, named);
  s.units = s.scale == 1.0 ? "m" : "mm";
  for (std::size_t f = 0; f < s.files.size(); ++f) {
    const auto t = Clock::now();
    for (auto& v : raw[f].vertices) v *= s.scale;
    RepairedSurface repaired = repair_surface(raw[f], s.files[f].string());
    s.read[f].repairs = repaired.report.text();
    for (auto& piece : repaired.pieces) {
      s.pieces.push_back(std::move(piece));
      s.source.push_back(f);
    }
    phase(fmt::format("repair {}: {}", s.files[f].filename().string(), s.read[f].repairs), t);
  }
  return s;
}

// An organ's name: what its surfaces' names share (their common start, less trailing separators),
// else its first surface's; made unique among the organs before it.
std::string organ_name(const std::vector<fs::path>& surfaces, const std::vector<std::string>& taken) {
  std::string common = surfaces.front().stem().string();
  for (const fs::path& f : surfaces) {
    const std::string stem = f.stem().string();
    std::size_t n = 0;
    while (n < common.size() && n < stem.size() && common[n] == stem[n]) ++n;
    common.resize(n);
  }
  while (!common.empty() && std::string("-_. ").find(common.back()) != std::string::npos) common.pop_back();
  if (common.size() < 3) common = surfaces.front().stem().string();
  std::string name = common;
  for (int k = 2; std::find(taken.begin(), taken.end(), name) != taken.end(); ++k)
    name = fmt::format("{}-{}", common, k);
  return name;
}

// Per-organ flags make sense for one surface only.
void check_surfaces_options(const ImportOptions& o) {
  if (o.ends != "held" && o.ends != "base" && o.ends != "free")
    throw Error(ErrorCode::invalid_argument, fmt::format("--ends: expected held, base or free, got '{}'", o.ends));
  if (o.tissue != "rest" && o.tissue != "none")
    throw Error(ErrorCode::invalid_argument, fmt::format("--tissue: expected rest or none, got '{}'", o.tissue));
  if (o.units != "auto" && o.units != "mm" && o.units != "m")
    throw Error(ErrorCode::invalid_argument, fmt::format("--units: expected auto, mm or m, got '{}'", o.units));
  if (o.more_meshes.empty()) return;
  const std::size_t n = o.more_meshes.size() + 1;
  auto refuse = [&](const char* flag, const char* why) {
    throw Error(ErrorCode::invalid_argument,
                fmt::format("{}: applies to one surface; with {} surfaces {}", flag, n, why));
  };
  if (!o.centreline.empty()) refuse("--centreline", "each organ's centreline is computed from its walls");
  if (o.nodes > 0) refuse("--nodes", "each organ gets a node per 5 mm of its centreline");
  if (o.beads > 0) refuse("--beads", "each organ gets a bead per three nodes");
  if (o.reverse) refuse("--reverse", "each organ runs from its wider open end");
}

// The command that made the scene, for its header: the surfaces' and the body's names, the options.
std::string command_of(const ImportOptions& o) {
  std::string c = o.mesh.filename().string();
  for (const fs::path& f : o.more_meshes) c += fmt::format(" {}", f.filename().string());
  if (!o.body.empty()) c += fmt::format(" --body {}", o.body.filename().string());
  if (!o.gravity.empty()) c += fmt::format(" --gravity {}", o.gravity);
  if (o.ends != ImportOptions{}.ends) c += fmt::format(" --ends {}", o.ends);
  if (o.tissue != ImportOptions{}.tissue) c += fmt::format(" --tissue {}", o.tissue);
  return c;
}

struct Organs {
  std::vector<ImportOptions> options;  // per organ: its first surface (for messages), the flags
  std::vector<std::vector<std::pair<double, double>>> profiles;
};

// Each organ's centreline, rod and surface, written beside the scene.
Organs make_organs(const ImportOptions& o, Surfaces& s, SurfacesReport& out, const Phase& phase) {
  const auto t = Clock::now();
  std::vector<OrganLayout> layouts = organ_layouts(std::move(s.pieces), s.source);
  phase(fmt::format("{} organ{} from {} surface{}", layouts.size(), layouts.size() == 1 ? "" : "s", s.files.size(),
                    s.files.size() == 1 ? "" : "s"),
        t);
  Organs organs;
  std::vector<std::string> names;
  std::vector<bool> used(s.files.size(), false);
  const std::string stem = (out.scene.parent_path() / out.scene.stem()).string();
  for (const OrganLayout& layout : layouts) {
    SurfacesReport::Organ organ;
    std::vector<std::size_t> files;  // on its path first, in order, then the others it took
    for (std::size_t p : layout.path) files.push_back(layout.pieces[p].source);
    for (const auto& piece : layout.pieces) files.push_back(piece.source);
    for (std::size_t f : files)
      if (!used[f]) {
        used[f] = true;
        organ.surfaces.push_back(s.files[f]);
        organ.report.vertices += s.read[f].vertices;
        organ.report.triangles += s.read[f].triangles;
        organ.report.repairs += fmt::format("{}{}: {}", organ.report.repairs.empty() ? "" : "; ",
                                            s.files[f].filename().string(), s.read[f].repairs);
      }
    organ.name = organ_name(organ.surfaces, names);
    names.push_back(organ.name);
    ImportOptions oi = o;
    oi.mesh = organ.surfaces.front();
    ImportReport& r = organ.report;
    r.units = s.units;
    r.units_reason = s.units_reason;
    r.scale = s.scale;
    r.scene = out.scene;
    std::vector<std::pair<double, double>> profile;
    const Polyline line = organ_rod(oi, layout, r, profile, phase);
    const TriangleMesh surface = surface_along(layout, line, r, oi.mesh.string());
    std::string from;  // its surfaces' names
    for (const fs::path& f : organ.surfaces)
      from += fmt::format("{}{}", from.empty() ? "" : ", ", f.filename().string());
    write_surface_and_centreline(layouts.size() == 1 ? stem : stem + "-" + organ.name, surface, line, from, r);
    organs.options.push_back(oi);
    organs.profiles.push_back(std::move(profile));
    out.organs.push_back(std::move(organ));
  }
  for (std::size_t f = 0; f < s.files.size(); ++f)
    if (!used[f]) out.unused.push_back(s.files[f]);
  return organs;
}

// The body read, closed and written beside the scene; the organs must lie inside it.
// (Before the organs are made: a body that does not hold them, or does not tell its back, fails in
// seconds; the repaired pieces are the organs' surfaces, what no centreline reaches included.)
Body make_body(const ImportOptions& o, const Surfaces& surfaces, SurfacesReport& out, const Phase& phase) {
  const auto t = Clock::now();
  Body body = read_body(o.body, o.units);
  out.body = o.body;
  out.body_units_reason = body.units_reason;
  out.body_repairs = body.repairs;
  out.body_capped = body.capped;
  out.body_volume = body.volume;
  out.body_vertices = body.mesh.vertices.size();
  out.body_triangles = body.mesh.triangles.size();
  std::vector<const TriangleMesh*> walls;
  for (const TriangleMesh& m : surfaces.pieces) walls.push_back(&m);
  out.outside_body = outside_body(body.mesh, walls);
  if (out.outside_body > 0.01)
    throw Error(ErrorCode::invalid_geometry,
                fmt::format("--body {}: {:.1f} % of the organs' surface lies outside the body (at most 1 %): the "
                            "organs and the body must share one frame and unit (the body: {}; the organs: {})",
                            o.body.string(), 100.0 * out.outside_body, body.units_reason, surfaces.units_reason));
  out.body_file = (out.scene.parent_path() / out.scene.stem()).string() + "-body.obj";
  write_obj(out.body_file, body.mesh,
            fmt::format("the body around the organs, closed by haustra import from {}", o.body.filename().string()));
  phase(fmt::format("body: {} triangles, {:.1f} L, {} open end{} capped", out.body_triangles, 1e3 * body.volume,
                    body.capped, body.capped == 1 ? "" : "s"),
        t);
  return body;
}

// Built once, as one surface's scene is: a cage that cannot embed its organ's mesh retried for
// that organ (more vertices per ring, then fewer beads), the others kept.
void build_surfaces_once(const SurfacesSceneInputs& in, SurfacesReport& out, const std::vector<ImportOptions>& options,
                         const Phase& phase) {
  const auto t = Clock::now();
  for (int attempt = 1;; ++attempt) {
    try {
      const auto world = create_world(load_scene(out.scene));
      std::size_t first = 0;
      for (auto& organ : out.organs) {
        const auto pieces = static_cast<std::size_t>(organ.report.chain_pieces);
        read_build(*world, first, pieces, organ.report);
        first += pieces;
      }
      break;
    } catch (const Error& e) {
      const auto* field = dynamic_cast<const FieldError*>(&e);
      std::size_t i = out.organs.size();
      if (field != nullptr && field->field().starts_with("segment[")) i = std::stoul(field->field().substr(8));
      if (i < out.organs.size() && retry_cage(options[i], out.organs[i].report, e, seconds_since(t))) {
        write_surfaces_scene(in);
        phase(fmt::format("build {} failed at {}'s cage; trying {} beads with rings of {}", attempt, out.organs[i].name,
                          out.organs[i].report.beads, out.organs[i].report.ring_vertices),
              t);
        continue;
      }
      throw Error(e.code(), fmt::format("{}\nthe imported scene {} does not build{}", e.what(), out.scene.string(),
                                        i < out.organs.size() ? fmt::format(" (organ {}, from {})", out.organs[i].name,
                                                                            options[i].mesh.string())
                                                              : ""));
    }
  }
  out.build_seconds = seconds_since(t);
  for (auto& organ : out.organs) organ.report.build_seconds = out.build_seconds;  // built together
  phase("built", t);
}

}  // namespace

std::string SurfacesReport::text() const {
  std::string t;
  for (std::size_t i = 0; i < organs.size(); ++i) {
    const Organ& organ = organs[i];
    std::string files;
    for (const auto& f : organ.surfaces) files += fmt::format("{}{}", files.empty() ? "" : ", ", f.filename().string());
    std::string what = organ.report.text();
    what = what.substr(0, what.rfind("import took"));  // the whole import's time is below
    t += fmt::format("organ {} of {}: {} ({} surface{}: {})\n", i + 1, organs.size(), organ.name, organ.surfaces.size(),
                     organ.surfaces.size() == 1 ? "" : "s", files);
    for (std::size_t at = 0; at < what.size();) {
      const std::size_t end = std::min(what.find('\n', at), what.size());
      t += fmt::format("  {}\n", what.substr(at, end - at));
      at = end + 1;
    }
  }
  for (const auto& f : unused) t += fmt::format("left out: {} (in no organ)\n", f.filename().string());
  if (!body.empty())
    t += fmt::format(
        "body: {}; units: {}; repair: {}; {} open end{} capped; {} vertices, {} triangles, {:.1f} L; a container "
        "(the beads stay inside it); {:.2f} % of the organs' vertices outside it\n",
        body.filename().string(), body_units_reason, body_repairs, body_capped, body_capped == 1 ? "" : "s",
        body_vertices, body_triangles, 1e3 * body_volume, 100.0 * outside_body);
  t += fmt::format("gravity: ({:.4g}, {:.4g}, {:.4g}) m/s², {}\n", gravity[0], gravity[1], gravity[2], gravity_reason);
  if (build_seconds > 0.0) t += fmt::format("built in {:.2f} s\n", build_seconds);
  t += fmt::format("import took {:.1f} s\n", seconds);
  return t;
}

SurfacesReport import_surfaces(const ImportOptions& o) {
  const auto started = Clock::now();
  check_surfaces_options(o);
  const GravityChoice gravity = parse_gravity(o.gravity.empty() ? (o.body.empty() ? "-z" : "supine") : o.gravity);
  if (gravity.kind != GravityChoice::Kind::direction && o.body.empty()) {  // refused before any work
    std::string unused;
    (void)resolve_gravity(gravity, nullptr, {}, unused);
  }
  const Phase phase = [&](const std::string& what, Clock::time_point since) {
    if (o.progress) o.progress(fmt::format("{} ({:.1f} s)", what, seconds_since(since)));
  };
  SurfacesReport out;
  out.scene = o.out.empty() ? fs::path(o.mesh.stem().string() + ".toml") : o.out;
  if (out.scene.has_parent_path()) fs::create_directories(out.scene.parent_path());
  Surfaces surfaces = read_surfaces(o, phase);
  std::optional<Body> body;
  if (!o.body.empty()) body = make_body(o, surfaces, out, phase);
  std::vector<const TriangleMesh*> walls;
  for (const TriangleMesh& m : surfaces.pieces) walls.push_back(&m);
  const Eigen::Vector3d g = resolve_gravity(gravity, body ? &*body : nullptr, walls, out.gravity_reason);
  if (o.gravity.empty() && o.body.empty())
    out.gravity_reason = "towards -z (the default without a body, which alone tells the back from the front)";
  out.gravity = {g.x(), g.y(), g.z()};
  const Organs organs = make_organs(o, surfaces, out, phase);
  const SurfacesSceneInputs scene{command_of(o), organs.options, out, organs.profiles};
  write_surfaces_scene(scene);
  build_surfaces_once(scene, out, organs.options, phase);
  out.seconds = seconds_since(started);
  write_surfaces_scene(scene);  // again, with what the build found in its comments
  return out;
}

}  // namespace haustra::import
