// Real intestine surfaces, imported with the defaults and put through the organ protocol: the
// table of docs/anatomy.md (decision 0097).
#include "haustra/studies/anatomy_cohort.hpp"

#include <fmt/chrono.h>
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <fstream>
#include <utility>

#include "haustra/error.hpp"
#include "haustra/studies/skin_stretch.hpp"
#include "haustra/world.hpp"

namespace haustra::import {
namespace {

using Clock = std::chrono::steady_clock;
using Points = std::vector<Eigen::Vector3d>;

constexpr double kAbove = 0.03;   // m: the grasper's tip above the middle of the centreline
constexpr double kReach = 0.03;   // m: it closes on what lies within this of its tip
constexpr double kClear = 0.05;   // m: it waits this far above the organ's highest point, alone
constexpr double kDescent = 0.5;  // s: it comes down from there before it closes
constexpr int kSampleEvery = 15;  // frames between measures of the mesh (a quarter second at 60 Hz)

std::string first_line(const std::string& s) { return s.substr(0, s.find('\n')); }

Points mesh_points(const World& w) {
  const auto p = w.mesh_positions();
  Points out(p.size());
  for (std::size_t v = 0; v < p.size(); ++v) out[v] = Eigen::Vector3d(p.x[v], p.y[v], p.z[v]);
  return out;
}

// The median and the largest distance of each vertex from where it rests.
std::pair<double, double> drift(const Points& now, const Points& rest) {
  std::vector<double> d(now.size());
  for (std::size_t v = 0; v < now.size(); ++v) d[v] = (now[v] - rest[v]).norm();
  if (d.empty()) return {0.0, 0.0};
  const double largest = *std::max_element(d.begin(), d.end());
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  return {d[d.size() / 2], largest};
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size() - 1) + 0.5))];
}

// The node `along` (a fraction of its nodes from its base) the world's longest organ (a rod: a
// segment, or a chain's pieces).
std::size_t node_along_longest_organ(const World& w, double along) {
  std::size_t first = 0, count = 0;
  for (std::size_t s = 0; s < w.segment_count(); ++s) {
    if (w.chain_of(s) != s) continue;
    std::size_t last = s;
    while (last + 1 < w.segment_count() && w.chain_of(last + 1) == s) ++last;
    const std::size_t begin = w.segment(s).nodes.offset;
    const std::size_t end = w.segment(last).nodes.offset + w.segment(last).nodes.count;
    if (end - begin > count) first = begin, count = end - begin;
  }
  const auto k = static_cast<std::size_t>(std::lround(std::clamp(along, 0.0, 1.0) * static_cast<double>(count - 1)));
  return first + k;
}

// The grasper of the protocol: the default instrument (a 30 cm capsule, a proxy) upright, waiting
// above the organ's highest point while the organ is left alone, then coming down (through whatever
// lies in the way) to 3 cm above the centreline `along` the organ (its middle by default) and closing (reach 3 cm),
// moving `distance` sideways (square to the organ and to gravity) in `pull`, holding, opening and going back up.
InstrumentDesc grasper(const World& rest, const Eigen::Vector3d& gravity, const OrganProtocol& p) {
  const std::size_t n = rest.node_count(), k = node_along_longest_organ(rest, p.along);
  const auto x = rest.node_positions();
  const Eigen::Vector3d up = gravity.norm() > 0.0 ? Eigen::Vector3d(-gravity.normalized()) : Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d tangent = x.get(std::min(k + 1, n - 1)) - x.get(k > 0 ? k - 1 : 0);
  Eigen::Vector3d side = up.cross(tangent);
  if (side.norm() < 1e-6 * tangent.norm()) side = up.unitOrthogonal();  // an upright organ: any way across
  side.normalize();
  const Eigen::Vector3d tip = x.get(k) + kAbove * up, aside = tip + p.distance * side;
  double top = -1e300;  // the organ's highest point above the tip, its beads included
  const auto centres = rest.bead_centres();
  const auto radii = rest.bead_radii();
  for (std::size_t b = 0; b < radii.size(); ++b) top = std::max(top, (centres.get(b) - tip).dot(up) + radii[b]);
  const Eigen::Vector3d high = tip + (std::max(top, 0.0) + kClear) * up;
  InstrumentDesc g;
  g.name = "grasper";
  g.grasp_reach = kReach;
  g.axis = up;
  g.tip = high;
  const double closes = p.rest + kDescent, release = closes + p.pull + p.hold;
  g.keyframes = {{0.0, high, up, false},      {p.rest, high, up, false},
                 {closes, tip, up, true},     {closes + p.pull, aside, up, true},
                 {release, aside, up, false}, {release + kDescent, aside + (high - tip), up, false}};
  return g;
}

// Steps the world through the protocol, measuring as it goes; an unstable frame ends it (thrown).
void run_phases(World& world, const OrganProtocol& p, CohortRow& row) {
  const Points rest = mesh_points(world);
  studies::SkinStretch skin(world);
  const double dt = world.dt();
  const int rest_frames = static_cast<int>(std::lround(p.rest / dt));
  const int total = static_cast<int>(std::lround((p.rest + kDescent + p.pull + p.hold + p.after) / dt));
  const int held_until = static_cast<int>(std::lround((p.rest + kDescent + p.pull + p.hold) / dt));
  std::vector<double> seconds;
  Eigen::Vector3d grasped_at = Eigen::Vector3d::Zero();
  for (int f = 1; f <= total; ++f) {
    const auto t0 = Clock::now();
    world.step();
    const auto mesh = world.mesh_positions();  // the mesh follows the rod when read: part of the frame
    const double s = std::chrono::duration<double>(Clock::now() - t0).count();
    seconds.push_back(s);
    row.frames_late += s > dt ? 1 : 0;
    row.frames = f;
    (void)mesh;
    const InstrumentReading g = world.instrument(0);
    if (f > rest_frames) row.largest_force = std::max(row.largest_force, g.force.norm());
    if (g.grasping && !row.grasped) {
      row.grasped = true;
      grasped_at = world.node_positions().get(world.segment(g.grasped_segment).nodes.offset + g.grasped_node);
    }
    if (g.grasping && f <= held_until)
      row.pulled =
          (world.node_positions().get(world.segment(g.grasped_segment).nodes.offset + g.grasped_node) - grasped_at)
              .norm();
    if (f % kSampleEvery != 0 && f != total) continue;
    const Points now = mesh_points(world);
    if (f <= rest_frames) {
      const auto [median, largest] = drift(now, rest);
      row.rest_median = std::max(row.rest_median, median);
      row.rest_max = std::max(row.rest_max, largest);
    }
    skin.measure(world, f <= rest_frames);
  }
  row.stretch_worst = skin.worst;
  row.stretch_raw = skin.worst_raw;
  row.stretch_edges = skin.edges_past;
  row.stretch_rest_worst = skin.worst_rest;
  row.stretch_rest_edges = skin.rest_edges_past;
  std::tie(row.after_median, row.after_max) = drift(mesh_points(world), rest);
  row.frame_median = percentile(seconds, 0.5);
  row.frame_p99 = percentile(seconds, 0.99);
}

// The grasper as a scene's [[instrument]] table, so the run can be replayed and looked at: the
// import's scene with it appended (`protocol.toml` beside it).
std::string instrument_toml(const InstrumentDesc& g) {
  auto v = [](const Eigen::Vector3d& x) { return fmt::format("[{:.9g}, {:.9g}, {:.9g}]", x.x(), x.y(), x.z()); };
  std::string t = fmt::format(
      "\n[[instrument]]   # the organ protocol's grasper (docs/anatomy.md)\nname = \"{}\"\n"
      "grasp_reach = {}\naxis = {}\ntip = {}\n",
      g.name, g.grasp_reach, v(g.axis), v(g.tip));
  for (const InstrumentKeyframe& k : g.keyframes)
    t += fmt::format("[[instrument.keyframe]]\ntime = {}\ntip = {}\naxis = {}\ngrasp = {}\n", k.time, v(k.tip),
                     v(k.axis), k.grasp);
  return t;
}

}  // namespace

SceneDesc with_protocol_grasper(SceneDesc scene, const OrganProtocol& protocol) {
  scene.world.instruments.clear();
  SceneDesc alone = scene;
  alone.world.threads = 1;
  const auto at_rest = create_world(alone);
  scene.world.instruments.push_back(grasper(*at_rest, scene.world.gravity, protocol));
  return scene;
}

CohortRow run_protocol(const SceneDesc& scene, const std::string& name, const OrganProtocol& protocol) {
  CohortRow row;
  row.name = name;
  row.imported = true;
  try {
    SceneDesc s = with_protocol_grasper(scene, protocol);
    s.world.threads = protocol.threads;
    if (protocol.skinning)
      for (SegmentDesc& seg : s.world.segments) seg.mesh.skinning = *protocol.skinning;
    row.force_limit = s.world.instruments.back().force_limit;
    const auto world = create_world(s);
    for (std::size_t seg = 0; seg < world->segment_count(); ++seg) {
      row.mesh_vertices += world->mesh(seg).vertices.count;
      row.skin_slots += world->mesh(seg).skin.slots_per_vertex * static_cast<double>(world->mesh(seg).vertices.count);
      row.outside += world->mesh(seg).cage.mesh_vertices_outside;
    }
    if (row.mesh_vertices > 0) row.skin_slots /= static_cast<double>(row.mesh_vertices);
    try {
      run_phases(*world, protocol, row);
    } catch (const Error& e) {
      row.error = first_line(e.what());
    }
    for (const Event& e : world->events()) {
      row.unstable += e.kind == Event::Kind::unstable ? 1 : 0;
      row.recovered += e.kind == Event::Kind::recovered ? 1 : 0;
      row.slipped = row.slipped || e.kind == Event::Kind::slipped;
    }
    for (const std::uint8_t intact : world->anchors_intact()) row.torn += intact == 0 ? 1 : 0;
    row.ran = row.error.empty() && row.unstable == 0;
    row.holds = row.ran && row.rest_max <= 5e-3 && row.rest_median <= 1e-3 &&
                row.largest_force <= row.force_limit * (1.0 + 1e-9) &&
                (row.after_max <= 5e-3 || row.torn > 0 || row.slipped);
  } catch (const std::exception& e) {
    row.error = first_line(e.what());
  }
  return row;
}

CohortRow run_cohort_surface(const std::filesystem::path& surface, const std::filesystem::path& out,
                             const OrganProtocol& protocol) {
  ImportOptions o;
  o.mesh = surface;
  o.out = out / "scene.toml";
  ImportReport report;
  try {
    report = import_surface(o);
  } catch (const std::exception& e) {
    CohortRow row;
    row.name = surface.stem().string();
    row.error = first_line(e.what());
    return row;
  }
  CohortRow row;
  try {
    const SceneDesc scene = load_scene(report.scene);
    {  // the scene with the protocol's grasper, to replay or look at (haustra view protocol.toml)
      std::ifstream in(report.scene);
      std::ofstream replay(out / "protocol.toml");
      replay << in.rdbuf() << instrument_toml(with_protocol_grasper(scene, protocol).world.instruments.back());
    }
    row = run_protocol(scene, surface.stem().string(), protocol);
  } catch (const std::exception& e) {
    row.name = surface.stem().string();
    row.imported = true;
    row.error = first_line(e.what());
  }
  row.report = std::move(report);
  return row;
}

std::vector<CohortRow> run_cohort(const std::filesystem::path& folder, const std::filesystem::path& out,
                                  const OrganProtocol& protocol) {
  std::vector<std::filesystem::path> surfaces;
  for (const auto& entry : std::filesystem::directory_iterator(folder))
    if (entry.path().extension() == ".obj") surfaces.push_back(entry.path());
  if (surfaces.empty()) throw Error(ErrorCode::io, fmt::format("{}: no .obj surfaces in this folder", folder.string()));
  std::sort(surfaces.begin(), surfaces.end());
  std::vector<CohortRow> rows;
  for (const auto& s : surfaces) {
    fmt::print(stderr, "anatomy: {}\n", s.filename().string());
    rows.push_back(run_cohort_surface(s, out / s.stem(), protocol));
  }
  return rows;
}

CohortRow run_abdomen(const std::filesystem::path& folder, const std::string& prefix, const std::filesystem::path& body,
                      const std::filesystem::path& out, const OrganProtocol& protocol) {
  CohortRow row;
  row.name = fmt::format("abdomen: {}* and {}", prefix, body.filename().string());
  std::vector<std::filesystem::path> surfaces;
  for (const auto& entry : std::filesystem::directory_iterator(folder))
    if (entry.path().extension() == ".obj" && entry.path().filename().string().starts_with(prefix))
      surfaces.push_back(entry.path());
  std::sort(surfaces.begin(), surfaces.end());
  if (surfaces.empty()) {
    row.error = fmt::format("no surface of {} starts with {}", folder.string(), prefix);
    return row;
  }
  ImportOptions o;
  o.mesh = surfaces.front();
  o.more_meshes.assign(surfaces.begin() + 1, surfaces.end());
  o.body = body;
  o.out = out / "abdomen.toml";
  std::filesystem::create_directories(out);
  SurfacesReport report;
  try {
    report = import_surfaces(o);
  } catch (const std::exception& e) {
    row.error = first_line(e.what());
    return row;
  }
  const SceneDesc scene = load_scene(report.scene);
  {
    std::ifstream in(report.scene);
    std::ofstream replay(out / "protocol.toml");
    replay << in.rdbuf() << instrument_toml(with_protocol_grasper(scene, protocol).world.instruments.back());
  }
  const std::string name = row.name;
  row = run_protocol(scene, name, protocol);
  // The row's import columns: the organs' sizes summed, the first organ's layout.
  ImportReport& r = row.report;
  r.layout = fmt::format("{} organs of {} surfaces, in the body{}", report.organs.size(), surfaces.size(),
                         report.unused.empty() ? "" : fmt::format(" ({} not joined)", report.unused.size()));
  for (const auto& organ : report.organs) {
    r.length += organ.report.length;
    r.nodes += organ.report.nodes;
    r.beads += organ.report.beads;
  }
  r.seconds = report.seconds;
  return row;
}

namespace {

std::string outcome(const CohortRow& r) {
  if (!r.ran) return "stops: " + r.error;
  std::vector<std::string> short_of;
  if (r.rest_max > 5e-3 || r.rest_median > 1e-3) short_of.push_back("drifts at rest");
  if (r.largest_force > r.force_limit * (1.0 + 1e-9)) short_of.push_back("force above its limit");
  if (r.after_max > 5e-3 && r.torn == 0 && !r.slipped) short_of.push_back("not back after release");
  if (!r.grasped) short_of.push_back("the grasp took nothing");
  std::string s = short_of.empty() ? "holds" : fmt::format("{}", fmt::join(short_of, ", "));
  if (r.slipped) s += " (the grasp let go: the wall stretched past its failure strain)";
  if (r.recovered > 0) s += fmt::format(" ({} frame{} redone)", r.recovered, r.recovered == 1 ? "" : "s");
  return s;
}

}  // namespace

std::string cohort_markdown(const std::vector<CohortRow>& rows, const std::filesystem::path& folder,
                            const OrganProtocol& p) {
  char host[256] = {};
  gethostname(host, sizeof host - 1);
  const std::time_t now = std::time(nullptr);
  std::size_t ok = 0;
  for (const auto& r : rows) ok += r.holds ? 1 : 0;
  std::string t = fmt::format(
      "# Real intestines, imported with the defaults\n\n"
      "Generated by `make anatomy` (`haustra anatomy {}`) on {:%Y-%m-%d} on {}; do not edit by hand.\n\n"
      "Every surface of the folder is imported with the defaults (`haustra import SURFACE`: the organ held by "
      "its connective tissue, decision 0095) and put through the organ protocol (decision 0097) at 60 Hz on {} "
      "threads: left alone {:g} s; the default grasper (a 30 cm capsule, upright, a proxy with an 8 N limit) "
      "comes down in 0.5 s from above the organ to {:g} cm above the middle of the centreline, through whatever "
      "lies in the way, closes (reach {:g} cm), moves {:g} cm sideways in {:g} s, holds {:g} s, opens and goes "
      "back up; then {:g} s alone. **{} of {} hold** (at rest every "
      "vertex within 5 mm of where the segmentation put it and the median within 1 mm; the pull never stops "
      "and its force never passes the limit; back within 5 mm, or the anchors that tore reported). A row named "
      "`abdomen:` is the surfaces of one body and its boundary imported as one scene (`haustra import A.obj B.obj "
      "... --body BODY`, decisions 0093, 0094; `make anatomy`'s ABDOMEN and BODY), the grasper on the middle of "
      "its longest organ.\n\n",
      folder.string(), fmt::localtime(now), host, p.threads, p.rest, 100 * kAbove, 100 * kReach, 100 * p.distance,
      p.pull, p.hold, p.after, ok, rows.size());
  t += "| surface | organ | length mm | nodes | beads | import s | at rest: median / farthest mm | force N | "
       "pulled mm | after release: median / farthest mm | torn | skin at rest: worst edge × (edges past 2×) | "
       "skin: worst edge × (edges past 2×), its own | skin slots per vertex | frame ms "
       "(p99) | late | outcome |\n";
  t += "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& r : rows) {
    if (!r.imported) {
      t += fmt::format("| {} | | | | | | | | | | | | | | | | import failed: {} |\n", r.name, r.error);
      continue;
    }
    const ImportReport& i = r.report;
    t += fmt::format(
        "| {} | {} | {:.0f} | {} | {} | {:.1f} | {:.2f} / {:.2f} | {:.2f} | {:.1f} | {:.2f} / {:.2f} | {} | {:.2f} "
        "({}) | {:.2f} ({}), {:.2f} own | {:.1f} | "
        "{:.2f} ({:.2f}) | {} | {} |\n",
        r.name, i.layout, 1e3 * i.length, i.nodes, i.beads, i.seconds, 1e3 * r.rest_median, 1e3 * r.rest_max,
        r.largest_force, 1e3 * r.pulled, 1e3 * r.after_median, 1e3 * r.after_max, r.torn, r.stretch_rest_worst,
        r.stretch_rest_edges, r.stretch_worst, r.stretch_edges, r.stretch_raw, r.skin_slots, 1e3 * r.frame_median,
        1e3 * r.frame_p99, r.frames_late, outcome(r));
  }
  t += "\nColumns: **organ** pieces, shells and left-out parts the import found; **length** of the computed "
       "centreline; **import s** the import's wall time; **at rest** how far the mesh's vertices went from where "
       "the segmentation put them while left alone (the median vertex and the farthest, the largest of measures "
       "every quarter second); **force** the largest force reported for the grasper (grasp and capsule "
       "together); **pulled** how far the grasped node went by the end of the hold; **after release** the "
       "vertices' distance from rest at the end; **torn** anchors of connective tissue torn; **skin at rest** "
       "and **skin** the largest ratio of a mesh edge's length to its rest length, over the rod's own stretch "
       "where it is (at each vertex's place along the rod, in the edge's direction: decision 0121), while left alone "
       "and over the whole run "
       "(the grasp pull included), and how many edges "
       "passed twice that (the "
       "skin tearing, not the tissue stretching: issue 35), and for the run the largest ratio of an edge's own, not "
       "divided by the rod's stretch; **skin slots per vertex** what skinning reads per "
       "mesh vertex (ring slots of its binding, padding included: the cost per vertex, decision 0117); **frame ms** "
       "the median (and 99th percentile) wall time of a frame with its mesh on this "
       "machine; **late** frames over 1/60 s.\n";
  return t;
}

}  // namespace haustra::import
