// haustra import: real and procedural surfaces to scenes that run, with no hand-tuning — one real
// surface per class (defects, short and wide, blind end, two shells, a shell folded back, whole
// organs), the CT colon against its midline, determinism and bad input.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <tuple>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "fused_hairpin.hpp"
#include "haustra/centreline.hpp"
#include "haustra/error.hpp"
#include "haustra/import/import.hpp"
#include "haustra/kernels/contact_geometry.hpp"
#include "haustra/mesh_io.hpp"
#include "haustra/scene.hpp"
#include "haustra/studies/anatomy_cohort.hpp"
#include "haustra/studies/anatomy_study.hpp"

namespace fs = std::filesystem;
using namespace haustra;

namespace {

const fs::path kData = fs::path(HAUSTRA_SOURCE_DIR) / "scenes" / "assets";
const fs::path kColon = kData / "large-intestine-A-DSJ.obj";
const fs::path kMidline = kData / "large-intestine-A-DSJ-centreline.json";
const fs::path kAnatomy = fs::path(HAUSTRA_SOURCE_DIR) / "tests" / "data" / "anatomy";

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / "haustra-import-test" / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

import::ImportOptions options(const fs::path& mesh, const fs::path& centreline,
                              const fs::path& out){import::ImportOptions o;
o.mesh = mesh;
o.centreline = centreline;
o.out = out;
return o;
}  // namespace

struct Imported {
  import::ImportReport report;
  double skin_error = 0.0;  // m: the mesh skinned with the scene's localization against full MVC, after the run
  double travel = 0.0;      // m: how far the mesh moved in the run (so the error means something)
};

// Imports, then runs 120 frames of gravity with both ends held, and measures the skinning's
// localization against full mean value coordinates of the same cage at the final pose.
Imported import_and_run(const import::ImportOptions& o) {
  Imported out{import::import_surface(o)};
  SceneDesc scene = load_scene(out.report.scene);
  scene.world.threads = 1;
  scene.world.segments[0].mesh.skinning = SkinningMethod::cage;  // the localization measured
  SceneDesc full = scene;
  full.world.segments[0].mesh.skinning = SkinningMethod::cage_full;
  auto world = create_world(scene);
  auto reference = create_world(full);
  const auto p0 = world->mesh_positions();
  std::vector<float> start(p0.x.begin(), p0.x.end());
  std::vector<float> start_z(p0.z.begin(), p0.z.end());
  for (int f = 0; f < 120; ++f) {
    world->step();
    reference->step();
  }
  const auto p = world->mesh_positions(), q = reference->mesh_positions();
  for (std::size_t v = 0; v < p.size(); ++v) {
    REQUIRE(std::isfinite(p.x[v] + p.y[v] + p.z[v]));
    const Eigen::Vector3d a(p.x[v], p.y[v], p.z[v]), b(q.x[v], q.y[v], q.z[v]);
    out.skin_error = std::max(out.skin_error, (a - b).norm());
    out.travel = std::max(out.travel, static_cast<double>(std::hypot(p.x[v] - start[v], p.z[v] - start_z[v])));
  }
  CHECK(world->events().empty());
  return out;
}

// docs/anatomy.md's protocol (decision 0097), shortened: imported with the defaults, left alone 2 s,
// grasped, pulled 5 cm sideways in 1 s, held 0.5 s, released and left alone 2 s. What "holds" asks
// of every surface: at rest every vertex within 5 mm of where the segmentation put it (the median
// within 1 mm); the pull never stops, its force never above the limit; back within 5 mm after the
// release, or the anchors that tore (or the grasp that tore out) reported.
import::CohortRow organ_protocol(const std::string& surface){import::OrganProtocol p;
p.rest = 2.0;
p.hold = 0.5;
p.after = 2.0;
const import::CohortRow row = import::run_cohort_surface(kAnatomy / (surface + ".obj"), scratch(surface), p);
MESSAGE(row.name << ": " << (row.imported ? row.report.text() : row.error) << "at rest " << row.rest_median * 1e3
                 << " / " << row.rest_max * 1e3 << " mm, force " << row.largest_force << " N, pulled "
                 << row.pulled * 1e3 << " mm, after " << row.after_median * 1e3 << " / " << row.after_max * 1e3
                 << " mm, torn " << row.torn << ", grasp torn out " << row.slipped << ", skin " << row.stretch_worst
                 << " (" << row.stretch_edges << " edges past 2x); " << row.error);
REQUIRE(row.imported);
CHECK(row.ran);
CHECK(row.unstable == 0);
CHECK(row.outside == 0);
CHECK(row.grasped);
CHECK(row.rest_max <= 5e-3);
CHECK(row.rest_median <= 1e-3);
CHECK(row.largest_force <= row.force_limit * (1.0 + 1e-9));
CHECK(row.largest_force > 0.5);  // it did pull
CHECK((row.after_max <= 5e-3 || row.torn > 0 || row.slipped));
CHECK(row.holds);
return row;
}

fs::path organ_file(const fs::path& file, const std::vector<std::pair<double, Eigen::Vector3d>>& pieces, double scale) {
  import::write_procedural_organ(file, pieces, scale);
  return file;
}

// One helix turn of radius R and the given pitch between two straight 0.1 m ends, written in
// millimetres: a pitch under the organ's diameter presses the walls of its two ends together.
fs::path helix_organ_file(const fs::path& file, double R, double pitch) {
  const double c = pitch / (2.0 * std::numbers::pi);
  const double k = R / (R * R + c * c), tau = c / (R * R + c * c);
  return organ_file(file,
                    {{0.1, Eigen::Vector3d::Zero()},
                     {2.0 * std::numbers::pi * std::sqrt(R * R + c * c), Eigen::Vector3d(k, 0, tau)},
                     {0.1, Eigen::Vector3d::Zero()}},
                    1000.0);
}

double hausdorff(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) {
  const auto one_way = [](const auto& from, const auto& to) {
    double worst = 0.0;
    for (const auto& p : from) {
      double best = 1e300;
      for (const auto& q : to) best = std::min(best, (p - q).squaredNorm());
      worst = std::max(worst, std::sqrt(best));
    }
    return worst;
  };
  return std::max(one_way(a, b), one_way(b, a));
}

std::string file_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

TEST_CASE("haustra import: the CT colon with its midline becomes a scene that runs, the skinning within its bound") {
  const fs::path dir = scratch("colon-midline");
  // Hung by its ends without its tissue (as before decision 0095), so that it sags centimetres
  // and the skinning is compared on a deformed organ.
  import::ImportOptions o = options(kColon, kMidline, dir / "colon.toml");
  o.ends = "held";
  o.tissue = "none";
  const Imported r = import_and_run(o);
  MESSAGE(r.report.text() << "skin error after 120 frames " << r.skin_error << " m, mesh moved " << r.travel << " m");
  CHECK(r.report.units == "mm");
  CHECK(r.report.length == doctest::Approx(0.749).epsilon(0.01));
  CHECK(r.travel > 0.01);
  CHECK(r.skin_error < 1e-3);
}

TEST_CASE("haustra import: the CT colon without its midline: the computed centreline lies along the CT one") {
  const fs::path dir = scratch("colon-computed");
  const Imported r = import_and_run(options(kColon, {}, dir / "colon.toml"));
  const auto computed = read_centreline(r.report.centreline_file).points;
  const auto ct = read_centreline(kMidline).points;
  const double d = hausdorff(computed, ct);
  // Within the CT midline's own stretch: each computed point's distance to it.
  double along = 0.0;
  for (const auto& p : computed) {
    double best = 1e300;
    for (const auto& q : ct) best = std::min(best, (p - q).norm());
    along = std::max(along, best);
  }
  MESSAGE(r.report.text() << "Hausdorff to the CT midline " << d << " m, computed to CT " << along << " m; skin error "
                          << r.skin_error << " m");
  CHECK(r.report.open_ends == 1);  // the anal end is closed
  // Measured 19.1 mm (the CT midline runs on into the anal cap, which the rod stops a radius short
  // of) and 7.0 mm along its length (the midline's own voxel wiggles).
  CHECK(d < 0.03);
  CHECK(along < 0.015);
  CHECK(r.skin_error < 1e-3);
}

TEST_CASE("haustra import: a colon mesh 20 mm shorter at each end than its centreline is trimmed to it") {
  const fs::path dir = scratch("colon-cut");
  // The surface without the vertices within 20 mm (along the midline) of either end.
  const TriangleMesh colon = load_mesh(kColon);
  const std::vector<Eigen::Vector3d> mid = read_centreline(kMidline).points;
  std::vector<double> arc{0.0};
  for (std::size_t i = 1; i < mid.size(); ++i) arc.push_back(arc.back() + (mid[i] - mid[i - 1]).norm());
  const auto kept = [&](const Eigen::Vector3d& v_mm) {
    const Eigen::Vector3d v = 1e-3 * v_mm;
    std::size_t best = 0;
    for (std::size_t i = 0; i < mid.size(); ++i)
      if ((mid[i] - v).squaredNorm() < (mid[best] - v).squaredNorm()) best = i;
    return arc[best] > 0.020 && arc[best] < arc.back() - 0.020;
  };
  std::vector<std::uint8_t> keep(colon.triangles.size());
  for (std::size_t t = 0; t < keep.size(); ++t)
    keep[t] = kept(colon.vertices[colon.triangles[t][0]]) && kept(colon.vertices[colon.triangles[t][1]]) &&
                      kept(colon.vertices[colon.triangles[t][2]])
                  ? 1
                  : 0;
  save_mesh(dir / "cut.obj", submesh(colon, keep));
  const Imported r = import_and_run(options(dir / "cut.obj", kMidline, dir / "cut.toml"));
  MESSAGE(r.report.text());
  CHECK(r.report.holes == 2);
  CHECK(r.report.trimmed_start == doctest::Approx(0.020).epsilon(0.3));
  CHECK(r.report.trimmed_end == doctest::Approx(0.020).epsilon(0.4));
  CHECK(r.skin_error < 1e-3);
  // Without the midline: the line runs from rim to rim.
  const Imported c = import_and_run(options(dir / "cut.obj", {}, dir / "cut-computed.toml"));
  MESSAGE(c.report.text() << "skin error " << c.skin_error);
  CHECK(c.report.open_ends == 2);
  CHECK(c.report.tightest_bend > 0.25 * c.report.median_radius);
  CHECK(c.skin_error < 1e-3);
}

TEST_CASE("haustra import: a procedural organ bent at 1.2 times its radius, closed, in metres") {
  const fs::path dir = scratch("tight-bend");
  const double kappa = 1.0 / (1.2 * 0.02);
  const fs::path mesh = organ_file(dir / "bend.obj",
                                   {{0.12, Eigen::Vector3d::Zero()},
                                    {std::numbers::pi / kappa, Eigen::Vector3d(kappa, 0, 0)},
                                    {0.12, Eigen::Vector3d::Zero()}},
                                   1.0);
  const Imported r = import_and_run(options(mesh, {}, dir / "bend.toml"));
  MESSAGE(r.report.text() << "skin error " << r.skin_error);
  CHECK(r.report.units == "m");
  CHECK(r.report.holes == 0);
  CHECK(r.report.open_ends == 0);
  // Designed at 24 mm; measured 19.8 mm: the sections' centroids, smoothed over half a radius, cut
  // the corner's inside by a sixth.
  CHECK(r.report.tightest_bend == doctest::Approx(1.0 / kappa).epsilon(0.25));
  CHECK(r.skin_error < 3e-4);  // measured 3.7e-5
}

TEST_CASE("haustra import: a procedural organ whose loop touches itself, in millimetres") {
  const fs::path dir = scratch("loop");
  // A helix turn of radius 50 mm whose pitch (42 mm) brings the walls of its two ends together.
  const fs::path mesh = helix_organ_file(dir / "loop.obj", 0.05, 0.042);
  const Imported r = import_and_run(options(mesh, {}, dir / "loop.toml"));
  MESSAGE(r.report.text() << "skin error " << r.skin_error);
  CHECK(r.report.units == "mm");
  CHECK_FALSE(r.report.touching.empty());
  CHECK(r.skin_error < 1e-3);
}

namespace {

// The largest ratio of a mesh edge's length to its rest length once the rod's nodes are put at
// `pulled`, each node's frame turned from its rest frame by the least rotation that takes its axis
// along the pulled line (no twist added), and the rod's own largest stretch (a node-to-node
// distance over its rest distance).
std::pair<double, double> skin_and_rod_stretch(World& world, const std::vector<Eigen::Vector3d>& pulled) {
  const auto rest = world.mesh_positions();
  const std::vector<float> x0(rest.x.begin(), rest.x.end()), y0(rest.y.begin(), rest.y.end()),
      z0(rest.z.begin(), rest.z.end());
  const auto nodes = world.node_positions();
  const auto turns = world.node_rotations();
  const std::size_t n = pulled.size();
  std::vector<double> px(n), py(n), pz(n), qw(n), qx(n), qy(n), qz(n);
  double rod = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t a = k > 0 ? k - 1 : 0, b = std::min(k + 1, n - 1);
    const Eigen::Quaterniond r0 = turns.get(k);
    const Eigen::Quaterniond q =
        Eigen::Quaterniond::FromTwoVectors(r0 * Eigen::Vector3d::UnitZ(), pulled[b] - pulled[a]) * r0;
    px[k] = pulled[k].x(), py[k] = pulled[k].y(), pz[k] = pulled[k].z();
    qw[k] = q.w(), qx[k] = q.x(), qy[k] = q.y(), qz[k] = q.z();
    if (k > 0) rod = std::max(rod, (pulled[k] - pulled[k - 1]).norm() / (nodes.get(k) - nodes.get(k - 1)).norm());
  }
  world.set_node_poses({px, py, pz}, {qw, qx, qy, qz}, 0.05);
  const auto now = world.mesh_positions();
  double skin = 0.0;
  for (const auto& t : world.mesh_triangles())
    for (std::size_t i = 0; i < 3; ++i) {
      const std::uint32_t a = t[i], b = t[(i + 1) % 3];
      const double before = Eigen::Vector3d(x0[a] - x0[b], y0[a] - y0[b], z0[a] - z0[b]).norm();
      const double after = (now.get(a) - now.get(b)).norm();
      if (before > 0.0) skin = std::max(skin, after / before);
    }
  return {skin, rod};
}

}  // namespace

// Issue 35: two loops of one organ touching at rest (the walls of a helix turn's ends, 14 cm across,
// pressed 2 mm into each other), then pulled 10 cm apart along the helix's axis. A vertex bound to its own place
// along the organ (the harmonic binding, the default for a surface) goes with its own loop: no edge
// of the skin stretches past 1.5x while the rod stretches under 10 %. Bound to its closest point of
// the centreline (the old binding), a vertex where the walls press into each other goes with the
// other loop and the skin between them tears: the counter-case.
TEST_CASE("two loops of one organ touching, pulled 10 cm apart: the skin goes with its own loop, not the other") {
  const fs::path dir = scratch("loops-apart");
  const fs::path mesh = helix_organ_file(dir / "loops.obj", 0.07, 0.038);
  const import::ImportReport report = import::import_surface(options(mesh, {}, dir / "loops.toml"));
  REQUIRE_FALSE(report.touching.empty());
  auto stretch_with = [&](CageBinding binding, SkinningMethod skin = SkinningMethod::cage) {
    SceneDesc scene = load_scene(report.scene);
    scene.world.threads = 1;
    scene.world.segments[0].mesh.cage.binding = binding;
    scene.world.segments[0].mesh.skinning = skin;
    auto world = create_world(scene);
    // The helix's axis: the direction in which its nodes spread least. The nodes between the
    // touching places drawn along it in proportion to their place between them, those past them
    // moved as one: the turn opens, the touching places part by 10 cm.
    const auto nodes = world->node_positions();
    const std::size_t n = nodes.size();
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < n; ++i) mean += nodes.get(i) / static_cast<double>(n);
    Eigen::Matrix3d spread = Eigen::Matrix3d::Zero();
    for (std::size_t i = 0; i < n; ++i) spread += (nodes.get(i) - mean) * (nodes.get(i) - mean).transpose();
    const Eigen::Vector3d axis = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(spread).eigenvectors().col(0);
    const auto [a1, a2] = report.touching.front();
    const double h = report.length / static_cast<double>(n - 1);
    std::vector<Eigen::Vector3d> pulled(n);
    for (std::size_t i = 0; i < n; ++i)
      pulled[i] = nodes.get(i) + 0.1 * std::clamp((static_cast<double>(i) * h - a1) / (a2 - a1), 0.0, 1.0) * axis;
    return skin_and_rod_stretch(*world, pulled);
  };
  const auto [own, rod] = stretch_with(CageBinding::harmonic);
  const auto [closest, rod_closest] = stretch_with(CageBinding::closest);
  // Decision 0117: the skin on the rings around each vertex's own place, no cage weights at all.
  const auto [along, rod_along] = stretch_with(CageBinding::harmonic, SkinningMethod::along_rod);
  MESSAGE("touching at " << report.touching.front().first * 1e3 << " and " << report.touching.front().second * 1e3
                         << " mm; rod stretched " << rod << "x; skin: own place " << own << "x, along the rod " << along
                         << "x, closest point " << closest << "x");
  CHECK(rod < 1.1);
  CHECK(rod_closest == rod);
  CHECK(rod_along == rod);
  CHECK(own < 1.5);
  CHECK(along < 1.5);
  CHECK(closest > 1.5);  // the counter-case: the old binding tears
}

// Issue 35: a hairpin whose legs the surface fuses where the loop starts (a sleeve of 3 rings joins
// their walls, as the atlas's ileum joins loops), then the loop opened so its legs part 10 cm there.
// The places along the rod jump across the sleeve (from one leg's to the other's): the engine cuts
// the surface there into two walls, so each leg's skin goes with its leg and no edge stretches past
// 1.5x. Bound to the closest point of the centreline (no cut: the counter-case), the sleeve is
// carried by both legs at once and tears.
TEST_CASE("a hairpin whose legs are fused, opened 10 cm: the surface is cut into two walls, the skin whole") {
  const fs::path dir = scratch("fused-apart");
  const double r = 0.01, d = 0.024;
  std::vector<Eigen::Vector3d> truth;
  save_mesh(dir / "fused.obj", test::fused_hairpin(r, d, 70, truth));
  const import::ImportReport report = import::import_surface(options(dir / "fused.obj", {}, dir / "fused.toml"));
  double fusion = 0.0;  // the fusion's place on the first leg (x = 0), and on the second, the tube's length less it
  for (std::size_t k = 1; k < truth.size() && truth[k].x() < 0.0; ++k) fusion += (truth[k] - truth[k - 1]).norm();
  // One piece, or a chain of two whose cut runs between the legs' fusions (their copies welded, the
  // fused cut's copies not).
  auto stretch_with = [&](CageBinding binding, std::size_t pieces) {
    SceneDesc scene = load_scene(report.scene);
    scene.world.threads = 1;
    SegmentDesc& seg = scene.world.segments[0];
    seg.mesh.cage.binding = binding;
    seg.mesh.skinning = SkinningMethod::along_rod;
    if (pieces > 1) {
      seg.chain_pieces = static_cast<int>(pieces);
      seg.nodes = (seg.nodes - 1) / static_cast<int>(pieces) + 1;
      seg.beads.count = seg.beads.count / static_cast<int>(pieces);
    }
    auto world = create_world(scene);
    const auto nodes = world->node_positions();
    const std::size_t n = nodes.size();
    const double h = report.length / static_cast<double>(n - 1), a1 = fusion, a2 = report.length - fusion;
    std::vector<Eigen::Vector3d> pulled(n);
    for (std::size_t i = 0; i < n; ++i) {  // smoothly: the rod's frames follow its line
      const double t = std::clamp((static_cast<double>(i) * h - a1) / (a2 - a1), 0.0, 1.0);
      pulled[i] = nodes.get(i) + 0.1 * t * t * (3.0 - 2.0 * t) * Eigen::Vector3d::UnitY();
    }
    const auto [skin, rod] = skin_and_rod_stretch(*world, pulled);
    return std::tuple{skin, rod, world->mesh_positions().size()};
  };
  const auto [cut, rod, vertices_cut] = stretch_with(CageBinding::harmonic, 1);
  const auto [chain, rod_chain, vertices_chain] = stretch_with(CageBinding::harmonic, 2);
  const auto [closest, rod_closest, vertices_closest] = stretch_with(CageBinding::closest, 1);
  MESSAGE("fused at " << fusion * 1e3 << " mm of " << report.length * 1e3 << " mm; rod stretched " << rod
                      << "x; skin: cut " << cut << "x (" << vertices_cut << " vertices), a chain of two " << chain
                      << "x (" << vertices_chain << "), closest point " << closest << "x (" << vertices_closest << ")");
  CHECK(rod < 1.1);
  CHECK(rod_closest == rod);
  CHECK(vertices_cut > vertices_closest);  // the cut's copies
  CHECK(cut < 1.5);
  CHECK(chain < 1.5);
  CHECK(closest > 3.0);  // the counter-case: the sleeve tears
}

// World::mesh_vertex_nodes: each vertex's node is the one at its place along the organ, whole or in a
// chain of two pieces, on the fused hairpin whose surface the import cut. The oracle: the along-rod
// skin's own binding (its GPU rows: a vertex's station pair and fraction), the node nearest that
// point of the rod's axis. Near the fusion and in the hairpin's turn the harmonic places are not the
// nearest node in space: the test counts those vertices, so it tells the two apart.
TEST_CASE("each mesh vertex's node is the one at its place along the organ, not the nearest in space") {
  const fs::path dir = scratch("vertex-nodes");
  std::vector<Eigen::Vector3d> axis;
  save_mesh(dir / "fused.obj", test::fused_hairpin(0.01, 0.024, 70, axis));
  const import::ImportReport report = import::import_surface(options(dir / "fused.obj", {}, dir / "fused.toml"));
  for (int pieces : {1, 2}) {
    SceneDesc scene = load_scene(report.scene);
    scene.world.threads = 1;
    SegmentDesc& seg = scene.world.segments[0];
    seg.mesh.skinning = SkinningMethod::along_rod;
    if (pieces > 1) {
      seg.chain_pieces = pieces;
      seg.nodes = (seg.nodes - 1) / pieces + 1;
      seg.beads.count = seg.beads.count / pieces;
    }
    auto world = create_world(scene);
    const auto nodes = world->node_positions();
    auto nearest_node = [&](const Eigen::Vector3d& p) {
      std::size_t best = 0;
      for (std::size_t k = 1; k < nodes.size(); ++k)
        if ((p - nodes.get(k)).squaredNorm() < (p - nodes.get(best)).squaredNorm()) best = k;
      return best;
    };
    const std::vector<std::uint32_t> node_of = world->mesh_vertex_nodes();
    REQUIRE(node_of.size() == world->mesh_buffer_size());
    const GpuSkinBinding& b = world->gpu_skin_binding();
    const auto x = world->mesh_positions();
    std::size_t same = 0, off_by_one = 0, elsewhere = 0, not_nearest = 0, ring_offset = 0;
    for (std::size_t p = 0; p < world->segment_count(); ++p) {
      const auto rings = world->ring_poses(p);
      const Range vertices = world->mesh(p).vertices;
      for (std::size_t v = vertices.offset; v < vertices.offset + vertices.count; ++v) {
        const std::uint32_t slot = b.slot_range[2 * v];
        REQUIRE((b.slot_ring[slot] & kGpuScrewSlot) != 0);
        const std::size_t g = (b.slot_ring[slot] & ~kGpuScrewSlot) - world->ring_count() - ring_offset;
        const double t = b.slot_coefficient[4 * slot];
        const std::size_t oracle = nearest_node((1.0 - t) * rings[g].centre + t * rings[g + 1].centre);
        const std::size_t gap = node_of[v] > oracle ? node_of[v] - oracle : oracle - node_of[v];
        (gap == 0 ? same : gap == 1 ? off_by_one : elsewhere) += 1;
        const std::size_t near = nearest_node(x.get(v).cast<double>());
        not_nearest += (node_of[v] > near ? node_of[v] - near : near - node_of[v]) > 1 ? 1 : 0;
      }
      ring_offset += rings.size();
    }
    MESSAGE(pieces << " piece(s): " << same << " vertices on the skin's own node, " << off_by_one
                   << " on its neighbour (a place halfway), " << elsewhere << " elsewhere; " << not_nearest
                   << " whose nearest node in space is two or more away");
    CHECK(elsewhere == 0);
    CHECK(off_by_one * 100 < node_of.size());
    CHECK(not_nearest > 0);
  }
}

TEST_CASE("haustra import: a CT segment with edges of three triangles is repaired and runs") {
  const import::CohortRow row = organ_protocol("EdinGCA-00020-large-intestine-SF--SF");
  CHECK(row.report.repairs.find("edges of three or more triangles split") != std::string::npos);
}

TEST_CASE("haustra import: a short wide flexure, as long as it is wide, becomes a few nodes, not a refusal") {
  const import::CohortRow row = organ_protocol("EdinGCA-00020-large-intestine-HF--HF");
  CHECK(row.report.length < 2.0 * row.report.median_radius);
  CHECK(row.report.nodes <= 15);
}

TEST_CASE("haustra import: a blind end (the appendix) stops a radius short of its tip") {
  const import::CohortRow row = organ_protocol("HuBMAPVHM-00070-large-intestine-Appendix");
  CHECK(row.report.open_ends == 1);
  CHECK(row.report.centreline_source.find("short of the closed end") != std::string::npos);
}

TEST_CASE("haustra import: a wall of two nested shells: the rod from the outer one, the thickness measured") {
  const fs::path surface = kAnatomy / "HuBMAPVHM-00070-large-intestine-Rectum.obj";
  const import::CohortRow row = organ_protocol("HuBMAPVHM-00070-large-intestine-Rectum");
  CHECK(row.report.shells == 1);
  // The thickness by brute force: each lumen vertex's distance to the nearest outer triangle, the
  // median, with the two shells told apart by their connected pieces here (the larger is outer).
  TriangleMesh m = load_mesh_as_read(surface);
  std::vector<int> piece(m.vertices.size(), -1);
  int pieces = 0;
  for (std::size_t seed = 0; seed < m.vertices.size(); ++seed) {
    if (piece[seed] >= 0) continue;
    std::vector<std::size_t> stack{seed};
    piece[seed] = pieces;
    while (!stack.empty()) {
      const std::size_t v = stack.back();
      stack.pop_back();
      for (const auto& t : m.triangles)
        if (t[0] == v || t[1] == v || t[2] == v)
          for (std::uint32_t w : t)
            if (piece[w] < 0) {
              piece[w] = pieces;
              stack.push_back(w);
            }
    }
    ++pieces;
  }
  REQUIRE(pieces == 2);
  std::array<double, 2> area{};
  for (const auto& t : m.triangles)
    area[static_cast<std::size_t>(piece[t[0]])] +=
        (m.vertices[t[1]] - m.vertices[t[0]]).cross(m.vertices[t[2]] - m.vertices[t[0]]).norm();
  const int outer = area[0] > area[1] ? 0 : 1;
  std::vector<double> d;
  for (std::size_t v = 0; v < m.vertices.size(); ++v) {
    if (piece[v] == outer) continue;
    double best = 1e300;
    for (const auto& t : m.triangles)
      if (piece[t[0]] == outer)
        best = std::min(best, (kernels::closest_point_on_triangle(m.vertices[v], m.vertices[t[0]], m.vertices[t[1]],
                                                                  m.vertices[t[2]]) -
                               m.vertices[v])
                                  .norm());
    d.push_back(best);
  }
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  const double reference = 1e-3 * d[d.size() / 2];  // the file is in millimetres
  MESSAGE("wall thickness " << row.report.wall_thickness << " m, brute force " << reference << " m");
  // Embree keeps the outer wall's vertices in float: a relative 1e-7 of a 0.2 m box.
  CHECK(row.report.wall_thickness == doctest::Approx(reference).epsilon(1e-4));
  // And with the atlas's midline: the same surface runs from it.
  const fs::path dir = scratch("rectum-midline");
  const Imported r = import_and_run(
      options(surface, kAnatomy / "HuBMAPVHM-00070-large-intestine-Rectum-centreline.json", dir / "r.toml"));
  CHECK(r.skin_error < 1e-3);
}

TEST_CASE("haustra import: a wall whose two shells are joined into one folded surface runs") {
  const import::CohortRow row = organ_protocol("HuBMAPVHM-00070-small-intestine-Ileum");
  CHECK(row.report.pieces == 1);
}

TEST_CASE("haustra import: the whole large intestine, eighteen separate pieces, becomes one organ that runs") {
  const import::CohortRow row = organ_protocol("HuBMAPVHM-00070-large-intestine");
  // Caecum, ascending, transverse, descending, sigmoid and rectum joined at their rims; the flexures
  // (surfaces that overlap the pieces either side of them) and the appendix left out.
  CHECK(row.report.pieces == 6);
  CHECK(row.report.shells == 6);
  CHECK(row.report.length > 1.2);
}

TEST_CASE("haustra import: the whole small intestine, in metres with degenerate triangles, runs") {
  const import::CohortRow row = organ_protocol("HuBMAPVHM-00070-small-intestine");
  CHECK(row.report.units == "m");
  CHECK(row.report.repairs.find("degenerate or duplicate triangles removed") != std::string::npos);
  CHECK(row.report.length > 1.5);
}

TEST_CASE("haustra import: the same surface gives the same files, byte for byte, and says what it does") {
  const fs::path surface = kAnatomy / "HuBMAPVHM-00070-large-intestine.obj";
  std::vector<std::string> phases;
  import::ImportOptions a = options(surface, {}, scratch("same-a") / "s.toml");
  a.progress = [&](std::string_view line) { phases.emplace_back(line); };
  const import::ImportReport ra = import::import_surface(a);
  const import::ImportReport rb = import::import_surface(options(surface, {}, scratch("same-b") / "s.toml"));
  CHECK(file_text(ra.centreline_file) == file_text(rb.centreline_file));
  CHECK(file_text(ra.surface_file) == file_text(rb.surface_file));
  CHECK(file_text(ra.scene).substr(file_text(ra.scene).find("[scene]")) ==
        file_text(rb.scene).substr(file_text(rb.scene).find("[scene]")));
  REQUIRE(phases.size() >= 5);  // read, repair, organ, centreline, built
  CHECK(phases[0].find("read") == 0);
  CHECK(phases[1].find("repair") == 0);
  CHECK(phases.back().find("built") == 0);
}

TEST_CASE(
    "haustra import: an imported whole organ (a chain of pieces, each its own mesh) steps to the same bits on 1 and 2 "
    "threads") {
  const import::ImportReport r = import::import_surface(
      options(kAnatomy / "HuBMAPVHM-00070-large-intestine.obj", {}, scratch("threads") / "s.toml"));
  REQUIRE(r.chain_pieces > 1);
  SceneDesc one = load_scene(r.scene), two = one;
  one.world.threads = 1;
  two.world.threads = 2;
  auto a = create_world(one), b = create_world(two);
  for (int f = 0; f < 30; ++f) {
    a->step();
    b->step();
  }
  const auto pa = a->mesh_positions(), pb = b->mesh_positions();
  REQUIRE(pa.size() == pb.size());
  std::size_t differ = 0;
  for (std::size_t v = 0; v < pa.size(); ++v)
    differ += (pa.x[v] != pb.x[v] || pa.y[v] != pb.y[v] || pa.z[v] != pb.z[v]) ? 1 : 0;
  const auto na = a->node_positions(), nb = b->node_positions();
  for (std::size_t k = 0; k < na.size(); ++k)
    differ += (na.x[k] != nb.x[k] || na.y[k] != nb.y[k] || na.z[k] != nb.z[k]) ? 1 : 0;
  CHECK(differ == 0);
}

TEST_CASE("haustra import: bad input fails with a clear message") {
  const fs::path dir = scratch("bad");
  CHECK_THROWS_WITH_AS(import::import_surface(options(dir / "missing.obj", {}, dir / "s.toml")),
                       doctest::Contains("missing.obj"), Error);
  // A flat disc, 100 mm across: no tube in it.
  TriangleMesh disc;
  disc.vertices.emplace_back(0.0, 0.0, 0.0);
  for (int i = 0; i < 24; ++i)
    disc.vertices.emplace_back(50.0 * std::cos(2.0 * std::numbers::pi * i / 24),
                               50.0 * std::sin(2.0 * std::numbers::pi * i / 24), 0.0);
  for (std::uint32_t i = 0; i < 24; ++i) disc.triangles.push_back({0, 1 + i, 1 + (i + 1) % 24});
  save_mesh(dir / "disc.obj", disc);
  CHECK_THROWS_WITH_AS(import::import_surface(options(dir / "disc.obj", {}, dir / "disc.toml")),
                       doctest::Contains("disc.obj: no tube in this mesh"), Error);
  // A colon a micrometre across: units that cannot be told.
  TriangleMesh tiny = load_mesh(kColon);
  for (auto& v : tiny.vertices) v *= 1e-8;
  save_mesh(dir / "tiny.obj", tiny);
  CHECK_THROWS_WITH_AS(import::import_surface(options(dir / "tiny.obj", {}, dir / "tiny.toml")),
                       doctest::Contains("give --units mm or --units m"), Error);
  // The CT midline moved half a metre away: outside the mesh.
  std::ofstream(dir / "away.json")
      << R"({"units": "m", "points": [[0.5, 0.5, 0.5], [0.6, 0.5, 0.5], [0.7, 0.5, 0.5]]})";
  CHECK_THROWS_WITH_AS(import::import_surface(options(kColon, dir / "away.json", dir / "away.toml")),
                       doctest::Contains("is outside the mesh"), Error);
  // A vertex that is no number: refused before anything looks at the surface.
  std::ofstream(dir / "nan.obj") << "v 0 0 0\nv 10 0 0\nv nan nan nan\nv 0 10 0\nv 5 5 5\nf 1 2 3\nf 1 3 4\nf 1 4 5\n";
  CHECK_THROWS_WITH_AS(import::import_surface(options(dir / "nan.obj", {}, dir / "nan.toml")),
                       doctest::Contains("nan.obj: a vertex is not a finite point"), Error);
  // A closed ball 60 mm across: as long as it is wide, no tube.
  TriangleMesh ball;
  constexpr int kRows = 24, kAround = 48;
  ball.vertices.emplace_back(0.0, 0.0, 30.0);
  for (int i = 1; i < kRows; ++i)
    for (int j = 0; j < kAround; ++j) {
      const double polar = std::numbers::pi * i / kRows, around = 2.0 * std::numbers::pi * j / kAround;
      ball.vertices.emplace_back(30.0 * std::sin(polar) * std::cos(around), 30.0 * std::sin(polar) * std::sin(around),
                                 30.0 * std::cos(polar));
    }
  ball.vertices.emplace_back(0.0, 0.0, -30.0);
  auto ring = [](int i, int j) { return static_cast<std::uint32_t>(1 + i * kAround + (j % kAround)); };
  const auto south = static_cast<std::uint32_t>(ball.vertices.size() - 1);
  for (int j = 0; j < kAround; ++j) {
    ball.triangles.push_back({0, ring(0, j), ring(0, j + 1)});
    for (int i = 0; i + 1 < kRows - 1; ++i) {
      ball.triangles.push_back({ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)});
      ball.triangles.push_back({ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)});
    }
    ball.triangles.push_back({south, ring(kRows - 2, j + 1), ring(kRows - 2, j)});
  }
  save_mesh(dir / "ball.obj", ball);
  CHECK_THROWS_WITH_AS(import::import_surface(options(dir / "ball.obj", {}, dir / "ball.toml")),
                       doctest::Contains("ball.obj: no tube in this mesh: it is closed"), Error);
}

TEST_CASE(
    "an anatomy row is the same on 1 and 2 threads but its frame time (a study's import runs on its cells' threads)") {
  const fs::path surface = kAnatomy / "HuBMAPVHM-00070-large-intestine-Appendix.obj";
  import::OrganProtocol p;
  p.rest = 0.5, p.pull = 0.5, p.hold = 0.25, p.after = 0.5;
  p.threads = 1;
  const import::CohortRow one = import::run_cohort_surface(surface, scratch("threads-1"), p);
  p.threads = 2;
  const import::CohortRow two = import::run_cohort_surface(surface, scratch("threads-2"), p);
  REQUIRE(one.ran);
  REQUIRE(two.ran);
  CHECK(one.rest_max == two.rest_max);
  CHECK(one.largest_force == two.largest_force);
  CHECK(one.pulled == two.pulled);
  CHECK(one.after_max == two.after_max);
  CHECK(one.stretch_worst == two.stretch_worst);
  CHECK(one.mesh_vertices == two.mesh_vertices);
  CHECK(one.pulled > 0.0);
}

// Decision 0113: a loop fused where it starts, shorter than 8 radii (a hairpin of 10 mm radius
// whose legs are 1 mm apart): the line leaves the fusion and comes back through the centroids of
// the contours round it, within half a radius of itself. Erased as "a loop no tube makes" (before
// 0113) the line was 366 mm of the tube's 407 and the wall of the loop up to 26 mm (the 99th
// percentile) from it; kept, 395 mm and 16 mm.
TEST_CASE("haustra import: a short loop fused where it starts stays in the centreline") {
  const fs::path dir = scratch("short-fused-loop");
  const double r = 0.01;
  std::vector<Eigen::Vector3d> truth;
  const TriangleMesh mesh = test::fused_hairpin(r, 0.021, 8, truth);
  save_mesh(dir / "hairpin.obj", mesh);
  const import::ImportReport report = import::import_surface(options(dir / "hairpin.obj", {}, dir / "hairpin.toml"));
  double tube = 0.0;
  for (std::size_t k = 1; k < truth.size(); ++k) tube += (truth[k] - truth[k - 1]).norm();
  const std::vector<Eigen::Vector3d> line = read_centreline(report.centreline_file).points;
  std::vector<double> off;  // each wall vertex from the nearest point of the line
  for (const Eigen::Vector3d& x : mesh.vertices) {
    double best = 1e300;
    for (std::size_t k = 1; k < line.size(); ++k) {
      const Eigen::Vector3d e = line[k] - line[k - 1];
      const double t = std::clamp((x - line[k - 1]).dot(e) / std::max(e.squaredNorm(), 1e-300), 0.0, 1.0);
      best = std::min(best, (line[k - 1] + t * e - x).norm());
    }
    off.push_back(best);
  }
  std::sort(off.begin(), off.end());
  const double p99 = off[off.size() * 99 / 100];
  MESSAGE("line " << report.length * 1e3 << " mm of the tube's " << tube * 1e3 << " mm; wall from it: 99th percentile "
                  << p99 * 1e3 << " mm");
  CHECK(report.length > 0.95 * tube);  // 0.97 measured (0.90 with the loop erased)
  CHECK(p99 < 2.0 * r);                // 1.6 r (2.6 r)
}
