// haustra: the command line. `haustra run SCENE` steps a scene and reports per-stage timings;
// `haustra validate` runs the reference cases against analytic and independent solutions.
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "haustra/error.hpp"
#include "haustra/import/import.hpp"
#include "haustra/import/scratch_import.hpp"
#include "haustra/mesh_io.hpp"
#include "haustra/render/render.hpp"
#include "haustra/scene.hpp"
#include "haustra/studies/anatomy_cohort.hpp"
#include "haustra/studies/anatomy_study.hpp"
#include "haustra/studies/skinning_study.hpp"
#include "haustra/studies/stability.hpp"
#include "haustra/studies/tradeoff_study.hpp"
#include "haustra/studies/validation.hpp"
#include "run_report.hpp"

namespace {

using namespace haustra;
namespace fs = std::filesystem;

// Exit codes: 0 ok, 1 a reference case failed, 2 bad input, 3 the simulation went unstable.
constexpr int kExitFailedCase = 1;
constexpr int kExitBadInput = 2;
constexpr int kExitUnstable = 3;

class ProgressBar {
 public:
  ProgressBar(int total, bool enabled) : total_(total), enabled_(enabled && isatty(STDERR_FILENO) != 0) {}
  void update(int done) {
    if (!enabled_) return;
    const auto now = std::chrono::steady_clock::now();
    if (done != total_ && now - last_ < std::chrono::milliseconds(100)) return;
    last_ = now;
    constexpr int kWidth = 40;
    const int filled = total_ > 0 ? done * kWidth / total_ : kWidth;
    fmt::print(stderr, "\r[{}{}] {}/{} frames", std::string(static_cast<std::size_t>(filled), '#'),
               std::string(static_cast<std::size_t>(kWidth - filled), '.'), done, total_);
    if (done == total_) fmt::print(stderr, "\n");
    std::fflush(stderr);
  }
  void abort() {
    if (enabled_) fmt::print(stderr, "\n");
  }

 private:
  int total_;
  bool enabled_;
  std::chrono::steady_clock::time_point last_{};
};

struct RunOptions {
  std::string scene;
  std::optional<int> frames;
  std::optional<double> dt;
  std::optional<int> threads;
  std::vector<std::string> sets;
  std::string out;
  bool quiet = false;
  int mesh_every = 10;
  std::string mesh_format = "ply";
};

// Where a scene is expected, a surface is imported first with the defaults (a surface to a running
// organ is one command), into a temporary folder that goes when the run ends.
std::unique_ptr<import::ScratchImport> import_if_surface(const fs::path& given) {
  if (!import::is_surface(given)) return nullptr;
  auto imported = std::make_unique<import::ScratchImport>(
      given, [](std::string_view line) { fmt::print(stderr, "import: {}\n", line); });
  const import::ImportReport& r = imported->report();
  fmt::print(stderr,
             "import: {} is now the scene {} ({:.2f} m of centreline, {} nodes, {} beads; removed at exit, "
             "`haustra import` keeps one)\n",
             given.string(), r.scene.string(), r.length, r.nodes, r.beads);
  return imported;
}

// What `run` says before the first frame: the scene, the world's size, each segment's rest shape and mesh.
void print_run_header(const SceneDesc& scene, const World& world) {
  fmt::print("haustra run: {} ({})\n", scene.name, scene.file.string());
  if (!scene.description.empty()) fmt::print("  {}\n", scene.description);
  fmt::print("  {} segment{}, {} nodes; dt = {:.6g} s; {} frames; solver {}; {} thread{}\n", world.segment_count(),
             world.segment_count() == 1 ? "" : "s", world.node_count(), world.dt(), scene.frames,
             solver_mode_name(scene.world.solver.mode), world.threads(), world.threads() == 1 ? "" : "s");
  for (std::size_t s = 0; s < world.segment_count(); ++s) {
    const SegmentInfo& info = world.segment(s);
    if (info.rest_polyline_deviation > 0.0)
      fmt::print(
          "  segment '{}': rest shape from a centreline, {:.4g} m long; interpolation nodes within {:.2g} m, "
          "source polyline within {:.3g} mm of the rod\n",
          info.name, info.length, info.rest_node_deviation, info.rest_polyline_deviation * 1e3);
  }

  for (std::size_t s = 0; s < world.segment_count(); ++s) cli::print_mesh_info(stdout, world, s);
}

// The files of `run --out`: the summary, the per-frame table, the final nodes, and the recorders' files.
void write_run_outputs(const RunOptions& o, const SceneDesc& scene, const World& world, cli::RunRecord& record,
                       const cli::TrackRecorder* tracks, cli::MeshRecorder* meshes, const std::string& status,
                       const std::string& error) {
  const std::filesystem::path dir(o.out);
  std::filesystem::create_directories(dir);
  record.write_summary(dir / "summary.json", scene, world, scene.frames, status, error);
  record.write_frames_csv(dir / "frames.csv");
  cli::write_nodes_csv(dir / "nodes.csv", world);
  fmt::print(
      "\noutputs in {}/: summary.json (counts, per-stage times, final node positions, per-frame "
      "penetrations and instrument forces), frames.csv (per-frame times, contacts, forces), nodes.csv "
      "(final nodes and strains)\n",
      std::filesystem::absolute(dir).lexically_normal().string());
  if (tracks != nullptr)
    fmt::print("centreline and beads every {} frames: {}, {}\n", o.mesh_every, (dir / "centreline.csv").string(),
               (dir / "beads.csv").string());
  if (meshes != nullptr) {
    meshes->finish(dir / "mesh.glb");
    fmt::print("deformed meshes: {} frames in {}/ ({}), all of them animated in {}\n", meshes->frames(),
               std::filesystem::absolute(dir / "mesh").lexically_normal().string(), o.mesh_format,
               std::filesystem::absolute(dir / "mesh.glb").lexically_normal().string());
  }
}

int run(const RunOptions& o) {
  const std::unique_ptr<import::ScratchImport> imported = import_if_surface(o.scene);
  SceneDesc scene = load_scene(imported ? imported->scene() : fs::path(o.scene), o.sets);
  if (o.frames) scene.frames = *o.frames;
  // The command line's own values are named as such, not blamed on the scene file.
  if (o.dt && !(*o.dt >= 1e-6 && *o.dt <= 1.0))
    throw Error(ErrorCode::invalid_argument, fmt::format("--dt {}: expected a time step in [1e-06, 1] s", *o.dt));
  if (o.threads && (*o.threads < 0 || *o.threads > 1024))
    throw Error(ErrorCode::invalid_argument,
                fmt::format("--threads {}: expected 0 (all hardware threads) to 1024", *o.threads));
  if (o.dt) scene.world.dt = *o.dt;
  if (o.threads) scene.world.threads = *o.threads;
  if (scene.frames < 0) throw Error(ErrorCode::invalid_argument, "--frames: expected a non-negative count");
  std::unique_ptr<World> world = create_world(scene);
  print_run_header(scene, *world);

  cli::RunRecord record;
  record.watch_skin(*world);
  // Deformed organ meshes: every mesh_every frames (and the first and last) as files, and all of
  // them as one animated glTF.
  std::unique_ptr<cli::MeshRecorder> meshes;
  bool any_mesh = false;
  for (std::size_t s = 0; s < world->segment_count(); ++s) any_mesh = any_mesh || world->mesh(s).enabled;
  if (!o.out.empty() && any_mesh && o.mesh_every > 0)
    meshes = std::make_unique<cli::MeshRecorder>(*world, std::filesystem::path(o.out) / "mesh", o.mesh_format);
  if (meshes) meshes->record(*world);
  // The centreline and the beads every mesh_every frames, as CSV.
  std::unique_ptr<cli::TrackRecorder> tracks;
  if (!o.out.empty() && o.mesh_every > 0) tracks = std::make_unique<cli::TrackRecorder>(std::filesystem::path(o.out));
  if (tracks) tracks->record(*world);
  ProgressBar bar(scene.frames, !o.quiet);
  std::string status = "ok";
  std::string error;
  for (int f = 0; f < scene.frames; ++f) {
    try {
      world->step();
    } catch (const Error& e) {
      if (e.code() != ErrorCode::unstable) throw;
      record.add(world->last_profile(), *world);
      record.measure_skin(*world, f, true);  // the last good frame (the failed one was restored)
      bar.abort();
      status = "unstable";
      error = e.what();
      break;
    }
    record.add(world->last_profile(), *world);
    record.measure_skin(*world, f + 1, f + 1 == scene.frames);
    const bool keep = o.mesh_every > 0 && ((f + 1) % o.mesh_every == 0 || f + 1 == scene.frames);
    if (meshes && keep) meshes->record(*world);
    if (tracks && keep) tracks->record(*world);
    bar.update(f + 1);
  }
  if (!o.quiet) {
    record.print_stage_table(stdout);
    record.print_contacts(stdout, *world);
    record.print_skin(stdout);
  }
  for (const Event& e : world->events())
    if (e.kind != Event::Kind::unstable) fmt::print("  event: {}\n", e.message());
  if (!o.out.empty()) write_run_outputs(o, scene, *world, record, tracks.get(), meshes.get(), status, error);
  if (status != "ok") {
    fmt::print(stderr, "error: {}\n", error);
    return kExitUnstable;
  }
  return 0;
}

// `haustra estimate SCENE`: what the world will take before it is built (decisions 0038, 0106) — the
// numbers World::create, the C API and Python use; exit 2 when it would not fit, with the reason.
struct EstimateOptions {
  std::string scene;
  std::vector<std::string> sets;
  bool json = false;
};

int estimate(const EstimateOptions& o) {
  const SceneDesc scene = load_scene(o.scene, o.sets);
  const MemoryEstimate e = estimate_memory(scene.world);
  const std::size_t available = available_memory();
  std::string refusal;
  try {
    check_fits(scene.world);
  } catch (const Error& err) {
    refusal = err.what();
  }
  if (o.json) {
    nlohmann::ordered_json j;
#define HAUSTRA_JSON_FIELD(type, name, initial, meaning) j[#name] = e.name;
    HAUSTRA_MEMORY_FIELDS(HAUSTRA_JSON_FIELD)
#undef HAUSTRA_JSON_FIELD
    j["available"] = available;
    j["fits"] = refusal.empty();
    fmt::print("{}\n", j.dump(2));
  } else {
    auto mb = [](std::size_t b) { return static_cast<double>(b) / 1e6; };
    fmt::print("haustra estimate: {} ({})\n", scene.name, scene.file.string());
    fmt::print(
        "  memory: about {:.1f} MB — {} nodes: rods {:.1f} MB, Newton workspace {:.1f} MB; {} beads {:.1f} MB, "
        "{} pairs of beads within reach {:.1f} MB; procedural meshes {:.1f} MB; {:.1f} MB available\n",
        mb(e.total), e.nodes, mb(e.rod_bytes), mb(e.solver_bytes), e.beads, mb(e.bead_bytes), e.bead_pairs,
        mb(e.pair_bytes), mb(e.mesh_bytes), mb(available));
    fmt::print("  time on one core: about {:.3g} s to build, {:.3g} ms a frame at rest\n", e.build_seconds,
               1e3 * e.step_seconds);
  }
  if (!refusal.empty()) {
    fmt::print(stderr, "error: {}\n", refusal);
    return kExitBadInput;
  }
  return 0;
}

int validate(bool json, bool markdown, const std::string& assets) {
  validation::Options options;
  if (!assets.empty()) options.assets = assets;
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<validation::CaseResult> results = validation::run_all(options);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  int failed = 0;
  for (const auto& r : results) failed += r.pass ? 0 : 1;
  if (json) {
    nlohmann::json j = nlohmann::json::array();
    for (const auto& r : results)
      j.push_back({{"case", r.name},
                   {"quantity", r.quantity},
                   {"reference", r.reference},
                   {"value", r.value},
                   {r.absolute ? "absolute_error" : "relative_error", r.error},
                   {"tolerance", r.tolerance},
                   {"pass", r.pass},
                   {"note", r.note}});
    fmt::print("{}\n", j.dump(2));
  } else if (markdown) {
    // The table of docs/results.md: one row per check, the numbers as measured.
    fmt::print("| case | quantity | reference | value | {} error | tolerance | |\n|---|---|---|---|---|---|---|\n",
               "relative / absolute");
    for (const auto& r : results)
      fmt::print("| {} | {} | {:.8g} | {:.8g} | {:.3g}{} | {:.3g} | {} |\n", r.name, r.quantity, r.reference, r.value,
                 r.error, r.absolute ? " (abs.)" : "", r.tolerance, r.pass ? "pass" : "**FAIL**");
  } else {
    for (const auto& r : results) {
      fmt::print("{} {}\n     {}\n     reference {:<14.8g} value {:<14.8g} {} error {:<10.3g} tolerance {:<8.3g}{}\n",
                 r.pass ? "PASS" : "FAIL", r.name, r.quantity, r.reference, r.value,
                 r.absolute ? "absolute" : "relative", r.error, r.tolerance, r.note.empty() ? "" : "\n     " + r.note);
    }
    fmt::print("\n{} of {} checks passed in {:.1f} s\n", results.size() - static_cast<std::size_t>(failed),
               results.size(), seconds);
  }
  return failed == 0 ? 0 : kExitFailedCase;
}

struct RenderCommand {
  std::string scene;
  std::vector<int> frames{0};
  std::vector<std::string> sets;
  std::vector<std::string> overlays;
  std::string colour = "tissue";
  int width = 960, height = 600, columns = 0;
  std::vector<double> view;
  std::string out = "render.png";
};

// Runs the scene and renders the chosen frames (a contact sheet when there are several), with one
// camera framing all of them.
int render_frames(const RenderCommand& c) {
  SceneDesc scene = load_scene(c.scene, c.sets);
  std::vector<int> frames = c.frames;
  std::sort(frames.begin(), frames.end());
  frames.erase(std::unique(frames.begin(), frames.end()), frames.end());
  if (frames.empty() || frames.front() < 0)
    throw Error(ErrorCode::invalid_argument, "--frames: expected frame numbers >= 0");
  render::RenderOptions o;
  o.width = c.width;
  o.height = c.height;
  for (const auto& name : c.overlays) {
    if (name == "beads")
      o.overlays.beads = true;
    else if (name == "cage")
      o.overlays.cage = true;
    else if (name == "centreline")
      o.overlays.centreline = true;
    else if (name == "contacts")
      o.overlays.contacts = true;
    else
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("--overlay {}: expected beads, cage, centreline or contacts", name));
  }
  o.overlays.colour = c.colour == "strain"        ? render::Colouring::strain
                      : c.colour == "penetration" ? render::Colouring::penetration
                                                  : render::Colouring::tissue;
  if (c.view.size() == 3) o.view_from = Eigen::Vector3d(c.view[0], c.view[1], c.view[2]);
  // Pass 1: where everything goes over the frames asked for.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = Eigen::Vector3d::Constant(-1e300);
  {
    std::unique_ptr<World> w = create_world(scene);
    for (int f = 0; f <= frames.back(); ++f) {
      if (std::find(frames.begin(), frames.end(), f) != frames.end()) render::grow_bounds(*w, lo, hi);
      if (f < frames.back()) w->step();
    }
  }
  o.camera = render::fit_camera(lo, hi, o.view_from, 35.0, static_cast<double>(o.width) / o.height);
  // Pass 2: the same run (deterministic), rendered.
  std::unique_ptr<World> w = create_world(scene);
  std::vector<render::Image> tiles;
  for (int f = 0; f <= frames.back(); ++f) {
    if (std::find(frames.begin(), frames.end(), f) != frames.end()) {
      const render::Picture p = render::render(*w, scene.world, o);
      tiles.push_back(p.image);
      if (o.overlays.colour != render::Colouring::tissue)
        fmt::print("frame {}: colour overlay from {:.4g} to {:.4g}\n", f, p.colour_min, p.colour_max);
    }
    if (f < frames.back()) w->step();
  }
  const int columns = c.columns > 0 ? c.columns : std::min<int>(static_cast<int>(tiles.size()), 3);
  const render::Image out = tiles.size() == 1 ? tiles.front() : render::contact_sheet(tiles, columns);
  out.save_png(c.out);
  fmt::print("wrote {} ({} frame{}: {})\n", std::filesystem::absolute(c.out).lexically_normal().string(), tiles.size(),
             tiles.size() == 1 ? "" : "s", fmt::join(frames, ", "));
  return 0;
}

// The paper's Fig. 6: (a) the organ with its beads, (b) the cross-section templates, (c) the tight
// cage, (d) the final cage, and one sharp bend skinned (e) by linear blending and (f) by the cage.
int figure_cage(const std::string& out, int width, int height) {
  const std::vector<validation::StudyPose> poses = validation::study_poses();
  auto world = [](SkinningMethod m) { return World::create(validation::study_organ(m)); };
  const std::unique_ptr<World> mvc = world(SkinningMethod::cage), lbs = world(SkinningMethod::linear_blend);
  const WorldDesc desc = validation::study_organ(SkinningMethod::cage);
  render::RenderOptions o;
  o.width = width;
  o.height = height;
  o.view_from = Eigen::Vector3d(0.3, -1.0, 0.8);
  std::vector<render::Image> tiles;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = Eigen::Vector3d::Constant(-1e300);
  render::grow_bounds(*mvc, lo, hi);
  lbs->pose_rod(0, lbs->base_pose(0), poses.front().strain);
  render::grow_bounds(*lbs, lo, hi);
  o.camera = render::fit_camera(lo, hi, o.view_from, 35.0, static_cast<double>(width) / height);
  o.overlays.beads = true;
  tiles.push_back(render::render(*mvc, desc, o).image);  // (a) the organ and its beads
  o.overlays.beads = false;
  // (b) the cross-section templates: a ring of m vertices on every bead's surface (and halfway
  // between beads), in its station's frame; (c) the tight cage joining them, before inflation.
  const double bead_radius = desc.segments[0].beads.radius;
  const auto rings = mvc->ring_poses(0);
  const auto ring_of = mvc->cage_vertex_rings(0);
  const std::vector<Eigen::Vector3d> cage = mvc->cage_vertices(0);
  std::vector<Eigen::Vector3d> tight(cage.size());
  for (std::size_t j = 0; j < cage.size(); ++j) {
    const kernels::RingPose& r = rings[ring_of[j]];
    Eigen::Vector3d offset = r.rotation.transpose() * (cage[j] - r.centre);
    const double radial = offset.head<2>().norm();
    offset = radial > 1e-9 ? Eigen::Vector3d(bead_radius * offset.x() / radial, bead_radius * offset.y() / radial, 0.0)
                           : Eigen::Vector3d(0.0, 0.0, offset.z() > 0.0 ? 0.5 * bead_radius : -0.5 * bead_radius);
    tight[j] = r.centre + r.rotation * offset;
  }
  std::vector<std::vector<Eigen::Vector3d>> templates(rings.size());
  for (std::size_t j = 0; j < cage.size(); ++j)
    if (std::abs((rings[ring_of[j]].rotation.transpose() * (tight[j] - rings[ring_of[j]].centre)).z()) < 1e-12)
      templates[ring_of[j]].push_back(tight[j]);
  for (auto& t : templates)
    if (!t.empty()) t.push_back(t.front());  // closed rings
  o.wires = templates;
  tiles.push_back(render::render(*mvc, desc, o).image);
  std::vector<std::vector<Eigen::Vector3d>> edges;
  for (const auto& t : mvc->cage_triangles(0))
    for (int i = 0; i < 3; ++i)
      edges.push_back({tight[t[static_cast<std::size_t>(i)]], tight[t[static_cast<std::size_t>((i + 1) % 3)]]});
  o.wires = edges;
  tiles.push_back(render::render(*mvc, desc, o).image);
  o.wires.clear();
  o.overlays.cage = true;
  tiles.push_back(render::render(*mvc, desc, o).image);  // (d) the final cage, pushed out around the mesh
  o.overlays.cage = false;
  tiles.push_back(render::render(*lbs, desc, o).image);  // (e) linear blend, bent
  mvc->pose_rod(0, mvc->base_pose(0), poses.front().strain);
  tiles.push_back(render::render(*mvc, desc, o).image);  // (f) the cage's MVC, bent
  render::contact_sheet(tiles, 3).save_png(out);
  fmt::print("wrote {}\n", std::filesystem::absolute(out).lexically_normal().string());
  return 0;
}

int skinning(bool markdown) {
  const validation::SkinningStudy study = validation::run_skinning_study();
  if (markdown) {
    fmt::print("{}", validation::skinning_markdown(study));
    return 0;
  }
  for (const auto& r : study.rows)
    fmt::print(
        "{:<26} slots {:>3.0f}  skin {:>8.1f} us  vs MVC max {:>6.3f} mm p99 {:>6.3f} mm  vs rigid sections max "
        "{:>6.2f} mm "
        "p99 {:>6.2f} mm  volume bend {:+6.2f} %  twist {:+6.2f} %\n",
        r.method, r.slots, r.skin_us, 1e3 * r.max_error, 1e3 * r.p99_error, 1e3 * r.transport_max,
        1e3 * r.transport_p99, 100.0 * r.bend_volume_change, 100.0 * r.twist_volume_change);
  fmt::print("{:<26} volume bend {:+6.2f} %  twist {:+6.2f} %\n", "rigid cross-sections",
             100.0 * study.transport_bend_volume_change, 100.0 * study.transport_twist_volume_change);
  return 0;
}

int stability(bool markdown, const std::string& csv) {
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<validation::StabilityCell> cells = validation::stability_sweep({});
  const std::vector<validation::StabilityCell> large =
      validation::stability_sweep(validation::stability_large_n_options());
  cells.insert(cells.end(), large.begin(), large.end());
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  int bad = 0;
  for (const auto& c : cells) bad += (!c.finite || !c.names_cause) ? 1 : 0;
  if (!csv.empty()) {  // for the heat map (scripts/plots.py stability)
    std::ofstream out(csv);
    out << "nodes,youngs_modulus,dt,load,law,outcome,fast_outcome\n";
    for (const auto& c : cells)
      out << fmt::format("{},{:g},{:g},{},{},{},{}\n", c.nodes, c.youngs_modulus, c.dt, c.load, c.law, c.outcome,
                         c.fast_outcome);
    if (!out) throw Error(ErrorCode::io, fmt::format("cannot write '{}'", csv));
  }
  if (markdown) {
    fmt::print("{}", validation::stability_markdown(cells));
  } else {
    for (const auto& c : cells)
      fmt::print("E {:<8g} dt {:<9.4g} N {:<6} {:<8} {:<8} {:<7} {}\n", c.youngs_modulus, c.dt, c.nodes, c.load, c.law,
                 c.outcome, c.detail);
    fmt::print("\n{} cells in {:.1f} s; {} not finite or without a named cause\n", cells.size(), seconds, bad);
  }
  return bad == 0 ? 0 : kExitFailedCase;
}

int study(bool markdown, const std::string& csv) {
  const validation::TradeoffStudy s = validation::run_tradeoff_study([&](const std::string& knob) {
    if (!markdown) fmt::print(stderr, "study: {}\n", knob);
  });
  if (!csv.empty()) {
    std::ofstream out(csv);
    out << validation::tradeoff_csv(s);
    if (!out) throw Error(ErrorCode::io, fmt::format("cannot write '{}'", csv));
  }
  fmt::print("{}", validation::tradeoff_markdown(s));
  return 0;
}

// `haustra view ...` is haustra-view, the binary beside this one: the command line stays free of
// GLFW and OpenGL (decision 0046).
int open_viewer(const char* self, const std::vector<std::string>& args) {
  std::error_code ec;
  fs::path here = fs::read_symlink("/proc/self/exe", ec);
  if (ec) here = fs::absolute(self);
  const fs::path viewer = here.parent_path() / "haustra-view";
  std::vector<std::string> words{viewer.string()};
  words.insert(words.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& w : words) argv.push_back(w.data());
  argv.push_back(nullptr);
  execv(viewer.c_str(), argv.data());
  fmt::print(stderr, "error: the viewer is not built ({}: {}): `make view` builds it\n", viewer.string(),
             std::strerror(errno));
  return kExitBadInput;
}

// Every subcommand's options, filled by CLI11 from the command line (declare_* below) and read by
// dispatch().
struct Commands {
  CLI::App *run_cmd = nullptr, *validate_cmd = nullptr, *stability_cmd = nullptr, *skinning_cmd = nullptr,
           *study_cmd = nullptr, *render_cmd = nullptr, *figure_cmd = nullptr, *import_cmd = nullptr,
           *anatomy_cmd = nullptr, *view_cmd = nullptr, *estimate_cmd = nullptr;
  RunOptions run;
  EstimateOptions estimate;
  bool json = false, validate_markdown = false;
  std::string assets;
  bool markdown = false;
  std::string stability_csv;
  bool skinning_markdown = false, skinning_anatomy = false;
  std::string skinning_assets = HAUSTRA_DEFAULT_ASSETS;
  bool study_markdown = false;
  std::string study_csv;
  RenderCommand render;
  std::string figure_out = "fig6-cage.png";
  import::ImportOptions import_options;
  std::vector<fs::path> import_meshes;
  fs::path anatomy_folder, anatomy_out = fs::temp_directory_path() / "haustra-anatomy";
  int anatomy_threads = 2;
  std::string anatomy_skinning;  // empty: the imported scenes' own
  std::string anatomy_abdomen;   // a prefix: those surfaces and the body as one more row
  fs::path anatomy_body;
};

void declare_run(CLI::App& app, Commands& c) {
  c.run_cmd = app.add_subcommand("run", "step a scene and report per-stage timings");
  c.run_cmd->add_option("scene", c.run.scene, "scene file (TOML), or a surface to import first with the defaults")
      ->required()
      ->check(CLI::ExistingFile);
  c.run_cmd->add_option("--frames", c.run.frames, "number of frames (default: the scene's)");
  c.run_cmd->add_option("--dt", c.run.dt, "time step in seconds (default: the scene's)");
  c.run_cmd->add_option("--threads", c.run.threads, "worker threads (0: all)");
  c.run_cmd->add_option("--set", c.run.sets, "override a scene value, e.g. --set segment.nodes=333")->take_all();
  c.run_cmd->add_option("--out", c.run.out, "directory for summary.json, frames.csv and nodes.csv");
  c.run_cmd->add_flag("--quiet", c.run.quiet, "no progress bar or timing table");
  c.run_cmd
      ->add_option("--mesh-every", c.run.mesh_every,
                   "with --out: write the deformed organ mesh, the centreline and the beads every N frames (0: never)")
      ->check(CLI::NonNegativeNumber);
  c.run_cmd->add_option("--mesh-format", c.run.mesh_format, "ply, obj or stl")
      ->check(CLI::IsMember({"ply", "obj", "stl"}));

  c.estimate_cmd = app.add_subcommand(
      "estimate", "what a scene's world will take in memory and time, before it is built; exit 2 if it would not fit");
  c.estimate_cmd->add_option("scene", c.estimate.scene, "scene file (TOML)")->required()->check(CLI::ExistingFile);
  c.estimate_cmd->add_option("--set", c.estimate.sets, "override a scene value, e.g. --set segment.nodes=333")
      ->take_all();
  c.estimate_cmd->add_flag("--json", c.estimate.json, "print the estimate as JSON");
}

// The reference cases and the studies: validate, stability, skinning, study.
void declare_studies(CLI::App& app, Commands& c) {
  c.validate_cmd = app.add_subcommand("validate", "run the reference cases against analytic solutions");
  c.validate_cmd->add_flag("--json", c.json, "print the results as JSON");
  c.validate_cmd->add_flag("--markdown", c.validate_markdown,
                           "print the results as a Markdown table (docs/results.md)");
  c.validate_cmd->add_option("--assets", c.assets, "directory holding large-intestine-A-DSJ-centreline.json");

  c.stability_cmd =
      app.add_subcommand("stability", "sweep E, dt, N and load: where the lagged scheme holds, recovers or stops");
  c.stability_cmd->add_flag("--markdown", c.markdown, "print the tables of docs/stability.md");
  c.stability_cmd->add_option("--csv", c.stability_csv, "also write every cell to this CSV file (for the heat map)");

  c.skinning_cmd = app.add_subcommand(
      "skinning", "the skin choice (mesh.skinning): each skin against cost and error, and linear-blend skinning");
  c.skinning_cmd->add_flag("--markdown", c.skinning_markdown, "print the table of docs/skinning.md");
  c.skinning_cmd->add_flag(
      "--anatomy", c.skinning_anatomy,
      "the real-anatomy table instead: the CT colon and procedural organs imported, deformed, K = 4 "
      "against the per-vertex localization");
  c.skinning_cmd->add_option("--assets", c.skinning_assets,
                             "directory holding large-intestine-A-DSJ.obj and its centreline");

  c.study_cmd = app.add_subcommand(
      "study", "speed against accuracy: each simplification as a knob, error against a reference and cost per frame");
  c.study_cmd->add_flag("--markdown", c.study_markdown, "print docs/tradeoff.md (progress goes to stderr otherwise)");
  c.study_cmd->add_option("--csv", c.study_csv, "also write every row to this CSV file (for the plots)");
}

void declare_pictures(CLI::App& app, Commands& c) {
  c.render_cmd =
      app.add_subcommand("render", "run a scene and ray-cast chosen frames to a PNG (a contact sheet for several)");
  c.render_cmd->add_option("scene", c.render.scene, "scene file (TOML)")->required()->check(CLI::ExistingFile);
  c.render_cmd->add_option("--frames", c.render.frames, "frames to render, e.g. --frames 0 60 270")->expected(1, -1);
  c.render_cmd->add_option("--set", c.render.sets, "override a scene value")->take_all();
  c.render_cmd->add_option("--overlay", c.render.overlays, "beads, cage, centreline, contacts")->expected(1, -1);
  c.render_cmd->add_option("--colour", c.render.colour, "tissue, strain (bending, 1/m) or penetration (beads)")
      ->check(CLI::IsMember({"tissue", "strain", "penetration"}));
  c.render_cmd->add_option("--width", c.render.width, "pixels")->check(CLI::Range(16, 8192));
  c.render_cmd->add_option("--height", c.render.height, "pixels")->check(CLI::Range(16, 8192));
  c.render_cmd->add_option("--columns", c.render.columns, "contact sheet columns");
  c.render_cmd->add_option("--view", c.render.view, "direction from the subject to the camera, x y z")->expected(3);
  c.render_cmd->add_option("--out", c.render.out, "PNG file");

  c.figure_cmd =
      app.add_subcommand("figure-cage", "the paper's Fig. 6: beads, cage, linear blend and MVC under a sharp bend");
  c.figure_cmd->add_option("--out", c.figure_out, "PNG file");
}

// Surfaces to scenes: import one, or a folder of them (anatomy).
void declare_import(CLI::App& app, Commands& c) {
  c.import_cmd = app.add_subcommand(
      "import",
      "segmented organ surfaces to a scene that runs: centreline read or computed, trimmed, rod, beads, cage; "
      "several surfaces are joined into organs where their open ends meet, a body keeps them inside");
  c.import_cmd
      ->add_option("mesh", c.import_meshes,
                   "surfaces (OBJ, STL, OFF, glTF), open or closed ends, mm or m; several: one scene, an organ per "
                   "chain of surfaces whose open ends meet")
      ->required()
      ->check(CLI::ExistingFile);
  c.import_cmd
      ->add_option("--body", c.import_options.body,
                   "the body's boundary around them (same frame): a container the organs stay inside")
      ->check(CLI::ExistingFile);
  c.import_cmd->add_option("--gravity", c.import_options.gravity,
                           "gravity's direction in the surfaces' frame: -x +x -y +y -z +z, supine (towards the "
                           "body's back), prone, or x,y,z (default: supine with --body, else -z)");
  c.import_cmd
      ->add_option("--centreline", c.import_options.centreline,
                   "its midline (JSON with units and points); default: computed")
      ->check(CLI::ExistingFile);
  c.import_cmd->add_option("--out", c.import_options.out, "the scene file to write (default: MESH's name .toml here)");
  c.import_cmd->add_option("--units", c.import_options.units, "auto (default: from the size), mm or m")
      ->check(CLI::IsMember({"auto", "mm", "m"}));
  c.import_cmd
      ->add_option("--ends", c.import_options.ends,
                   "ends held rigidly: free (default: the tissue holds the organ), held (both) or base (the first)")
      ->check(CLI::IsMember({"held", "base", "free"}));
  c.import_cmd
      ->add_option("--tissue", c.import_options.tissue,
                   "connective tissue holding the organ where the surface put it: rest (default) or none")
      ->check(CLI::IsMember({"rest", "none"}));
  c.import_cmd->add_option("--nodes", c.import_options.nodes, "rod nodes (default: one per 5 mm, 9 to 1,201)")
      ->check(CLI::Range(3, 20000));
  c.import_cmd->add_option("--beads", c.import_options.beads, "beads (default: a third of the nodes)")
      ->check(CLI::Range(2, 20000));
  c.import_cmd->add_flag("--reverse", c.import_options.reverse, "run the rod from the other end");

  c.anatomy_cmd = app.add_subcommand(
      "anatomy",
      "import every surface of a folder with the defaults and put each through the organ protocol (left alone, "
      "grasped, pulled 5 cm, released): docs/anatomy.md's table");
  c.anatomy_cmd->add_option("folder", c.anatomy_folder, "folder of surfaces (.obj)")
      ->required()
      ->check(CLI::ExistingDirectory);
  c.anatomy_cmd->add_option("--out", c.anatomy_out, "where the imported scenes go");
  c.anatomy_cmd->add_option("--abdomen", c.anatomy_abdomen,
                            "and one more row: every surface whose name starts with this, and --body, as one scene");
  c.anatomy_cmd->add_option("--body", c.anatomy_body, "the body boundary around the --abdomen's surfaces")
      ->check(CLI::ExistingFile);
  c.anatomy_cmd
      ->add_option("--threads", c.anatomy_threads,
                   "threads each organ's worlds run on, 0: all (default 2, docs/anatomy.md's; the same bits on any)")
      ->check(CLI::Range(0, 1024));
  c.anatomy_cmd
      ->add_option("--skinning", c.anatomy_skinning,
                   "bind every organ's mesh with this skin instead of the imported scene's (decision 0117)")
      ->check(CLI::IsMember({"along-rod", "cage", "cage-full", "linear-blend"}));
}

int dispatch(Commands& c) {
  if (*c.run_cmd) return run(c.run);
  if (*c.estimate_cmd) return estimate(c.estimate);
  if (*c.import_cmd) {
    // A line per phase on a terminal (a whole organ takes a minute): what was done and how long.
    if (isatty(fileno(stderr)) != 0)
      c.import_options.progress = [](std::string_view line) { fmt::print(stderr, "import: {}\n", line); };
    c.import_options.mesh = c.import_meshes.front();
    c.import_options.more_meshes.assign(c.import_meshes.begin() + 1, c.import_meshes.end());
    if (c.import_options.more_meshes.empty() && c.import_options.body.empty() && c.import_options.gravity.empty()) {
      const import::ImportReport report = import::import_surface(c.import_options);
      fmt::print("{}scene: {} (centreline: {})\nrun it: haustra run {}\n", report.text(), report.scene.string(),
                 report.centreline_file.string(), report.scene.string());
      return 0;
    }
    const import::SurfacesReport report = import::import_surfaces(c.import_options);
    fmt::print("{}scene: {}\nrun it: haustra run {}\n", report.text(), report.scene.string(), report.scene.string());
    return 0;
  }
  if (*c.anatomy_cmd) {
    import::OrganProtocol protocol;
    protocol.threads = c.anatomy_threads;
    if (!c.anatomy_skinning.empty())
      protocol.skinning = c.anatomy_skinning == "cage"        ? SkinningMethod::cage
                          : c.anatomy_skinning == "cage-full" ? SkinningMethod::cage_full
                          : c.anatomy_skinning == "along-rod" ? SkinningMethod::along_rod
                                                              : SkinningMethod::linear_blend;
    if (!c.anatomy_abdomen.empty() && c.anatomy_body.empty())
      throw Error(ErrorCode::invalid_argument, "--abdomen needs --body: the body boundary around its surfaces");
    auto rows = import::run_cohort(c.anatomy_folder, c.anatomy_out, protocol);
    if (!c.anatomy_abdomen.empty()) {
      fmt::print(stderr, "anatomy: the abdomen ({}* and {})\n", c.anatomy_abdomen, c.anatomy_body.filename().string());
      rows.push_back(import::run_abdomen(c.anatomy_folder, c.anatomy_abdomen, c.anatomy_body, c.anatomy_out / "abdomen",
                                         protocol));
    }
    fmt::print("{}", import::cohort_markdown(rows, c.anatomy_folder, protocol));
    std::size_t ok = 0;
    for (const auto& r : rows) ok += r.holds ? 1 : 0;
    return ok == rows.size() ? 0 : kExitFailedCase;
  }
  if (*c.validate_cmd) return validate(c.json, c.validate_markdown, c.assets);
  if (*c.stability_cmd) return stability(c.markdown, c.stability_csv);
  if (*c.skinning_cmd && c.skinning_anatomy) {
    const auto organs =
        import::import_study_organs(c.skinning_assets, fs::temp_directory_path() / "haustra-anatomy-study");
    fmt::print("{}", import::anatomy_markdown(import::run_anatomy_study(organs)));
    return 0;
  }
  if (*c.skinning_cmd) return skinning(c.skinning_markdown);
  if (*c.study_cmd) return study(c.study_markdown, c.study_csv);
  if (*c.render_cmd) return render_frames(c.render);
  if (*c.figure_cmd) return figure_cage(c.figure_out, 720, 480);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  haustra::import::remove_scratch_on_signals();  // a surface imported on the fly leaves nothing behind
  CLI::App app{"haustra: beads-on-string soft organ engine (Chang et al., The Visual Computer 2011)"};
  app.set_version_flag("--version", std::string("haustra " HAUSTRA_VERSION));
  app.require_subcommand(1);
  Commands c;
  declare_run(app, c);
  declare_studies(app, c);
  declare_pictures(app, c);
  declare_import(app, c);
  c.view_cmd = app.add_subcommand("view", "open a scene in the interactive viewer (haustra-view; `make view`)");
  c.view_cmd->prefix_command();
  c.view_cmd->set_help_flag();  // --help goes to the viewer

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version are a success; a missing file or a bad value is bad input (exit 2).
    const int code = app.exit(e);
    return code == 0 ? 0 : kExitBadInput;
  }
  // The viewer reads its own options (a surface for a scene included).
  if (*c.view_cmd) return open_viewer(argv[0], c.view_cmd->remaining());
  try {
    return dispatch(c);
  } catch (const haustra::Error& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return e.code() == haustra::ErrorCode::unstable ? kExitUnstable : kExitBadInput;
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitBadInput;
  }
}
