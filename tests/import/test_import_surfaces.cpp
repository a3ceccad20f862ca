// haustra import of several surfaces and a body (decisions 0093, 0094): surfaces whose open ends meet
// become one organ, apart two; a body becomes a container the organs stay in, with gravity towards
// its back when supine; --gravity read and refused; the same files give the same scene, bit for bit.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "haustra/error.hpp"
#include "haustra/import/import.hpp"
#include "haustra/mesh_io.hpp"
#include "haustra/scene.hpp"
#include "haustra/studies/anatomy_cohort.hpp"
#include "haustra/studies/anatomy_study.hpp"

namespace fs = std::filesystem;
using namespace haustra;

namespace {

const fs::path kSurfaceData = fs::path(HAUSTRA_SOURCE_DIR) / "tests" / "data" / "anatomy";

fs::path fresh_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / "haustra-import-surfaces-test" / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// A straight procedural organ (radius 20 mm, 300 mm along z, in millimetres) cut across its middle
// by its triangles' centres: two surfaces whose open ends share their points. The second is moved
// by `shift` (mm).
std::pair<fs::path, fs::path> cut_organ(const fs::path& dir, const Eigen::Vector3d& shift) {
  import::write_procedural_organ(dir / "whole.obj", {{ 0.3, Eigen::Vector3d::Zero() }}, 1000.0);
  const TriangleMesh whole = load_mesh(dir / "whole.obj");
  std::vector<std::uint8_t> first(whole.triangles.size()), second(whole.triangles.size());
  for (std::size_t t = 0; t < whole.triangles.size(); ++t) {
    const auto& tri = whole.triangles[t];
    const double z = (whole.vertices[tri[0]].z() + whole.vertices[tri[1]].z() + whole.vertices[tri[2]].z()) / 3.0;
    first[t] = z < 150.0 ? 1 : 0;
    second[t] = 1 - first[t];
  }
  TriangleMesh a = submesh(whole, first), b = submesh(whole, second);
  for (auto& v : b.vertices) v += shift;
  save_mesh(dir / "lower.obj", a);
  save_mesh(dir / "upper.obj", b);
  return {dir / "lower.obj", dir / "upper.obj"};
}

// The box [lo, hi] (mm) as 12 triangles wound outward; `open_top`: without its two top triangles.
fs::path box_body(const fs::path& file, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, bool open_top = false) {
  TriangleMesh m;
  for (int k = 0; k < 8; ++k)
    m.vertices.emplace_back((k & 1) != 0 ? hi.x() : lo.x(), (k & 2) != 0 ? hi.y() : lo.y(),
                            (k & 4) != 0 ? hi.z() : lo.z());
  m.triangles = {{0, 2, 3}, {0, 3, 1}, {0, 1, 5}, {0, 5, 4}, {2, 6, 7}, {2, 7, 3},
                 {0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}, {4, 5, 7}, {4, 7, 6}};
  if (open_top) m.triangles.resize(10);
  save_mesh(file, m);
  return file;
}

import::ImportOptions surfaces(const std::vector<fs::path>& meshes, const fs::path& out){import::ImportOptions o;
o.mesh = meshes.front();
o.more_meshes.assign(meshes.begin() + 1, meshes.end());
o.out = out;
return o;
}  // namespace

std::string bytes_of(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// A scene's text less its lines about time taken.
std::string timeless(const fs::path& scene) {
  std::stringstream in(bytes_of(scene));
  std::string out, line;
  while (std::getline(in, line))
    if (line.find("took") == std::string::npos && line.find("built in") == std::string::npos) out += line + "\n";
  return out;
}

void check_runs(const fs::path& scene, int frames) {
  SceneDesc sc = load_scene(scene);
  sc.world.threads = 1;
  auto w = create_world(sc);
  for (int f = 0; f < frames; ++f) w->step();
  CHECK(w->events().empty());
  for (std::size_t k = 0; k < w->node_count(); ++k) REQUIRE(w->node_positions().get(k).allFinite());
}

}  // namespace

TEST_CASE("haustra import of several surfaces: open ends that meet make one organ, apart two, each beads colliding") {
  const fs::path dir = fresh_dir("join");
  {  // Cut in two: the rims share their points.
    const auto [lower, upper] = cut_organ(dir / ".", Eigen::Vector3d::Zero());
    const import::SurfacesReport r = import::import_surfaces(surfaces({lower, upper}, dir / "cut.toml"));
    MESSAGE(r.text());
    REQUIRE(r.organs.size() == 1);
    CHECK(r.organs[0].surfaces.size() == 2);
    CHECK(r.organs[0].report.pieces == 2);
    CHECK(r.organs[0].report.length == doctest::Approx(0.3).epsilon(0.15));  // less a radius at each closed end
    CHECK(load_scene(r.scene).world.segments.size() == 1);
    check_runs(r.scene, 30);
  }
  {  // 1 mm apart along the axis: the rims' centres meet (within half a radius), no point is shared.
    const auto [lower, upper] = cut_organ(dir / ".", Eigen::Vector3d(0.0, 0.0, 1.0));
    const import::SurfacesReport r = import::import_surfaces(surfaces({lower, upper}, dir / "gap.toml"));
    REQUIRE(r.organs.size() == 1);
    CHECK(r.organs[0].report.pieces == 2);
  }
  // 100 mm aside: two organs, two segments, whose beads collide with each other.
  const auto [lower, upper] = cut_organ(dir / ".", Eigen::Vector3d(100.0, 0.0, 0.0));
  const import::SurfacesReport r = import::import_surfaces(surfaces({lower, upper}, dir / "apart.toml"));
  MESSAGE(r.text());
  REQUIRE(r.organs.size() == 2);
  CHECK(r.organs[0].name == "lower");
  CHECK(r.organs[1].name == "upper");
  const SceneDesc sc = load_scene(r.scene);
  REQUIRE(sc.world.segments.size() == 2);
  CHECK(sc.world.contact.rest_exclusions == RestExclusions::world);
  CHECK(sc.world.gravity.isApprox(Eigen::Vector3d(0.0, 0.0, -9.81)));  // no body: -z, as one surface has had
  const auto w = create_world(sc);
  const std::size_t first_of_second = w->segment(0).nodes.count;  // beads are numbered organ by organ
  std::size_t across = 0;
  for (std::size_t a = 0; a < w->bead_count(); ++a)
    for (std::size_t b = a + 1; b < w->bead_count(); ++b)
      if (w->bead_nodes()[a] < first_of_second && w->bead_nodes()[b] >= first_of_second) {
        ++across;
        CHECK(w->beads_may_collide(a, b));  // 100 mm apart at rest: nothing excluded between them
      }
  CHECK(across > 0);
  check_runs(r.scene, 30);
}

TEST_CASE("haustra import of several surfaces: a flexure's wedge shares its one rim with its neighbour: one organ") {
  // HF--HF's one boundary loop runs along the cuts to both its neighbours; HF-HF+ shares 75 of its points.
  const fs::path dir = fresh_dir("wedge");
  const import::SurfacesReport r =
      import::import_surfaces(surfaces({kSurfaceData / "EdinGCA-00020-large-intestine-HF--HF.obj",
                                        kSurfaceData / "EdinGCA-00020-large-intestine-HF-HF+.obj"},
                                       dir / "flexure.toml"));
  MESSAGE(r.text());
  REQUIRE(r.organs.size() == 1);
  CHECK(r.organs[0].name == "EdinGCA-00020-large-intestine-HF");  // what the surfaces' names share
  CHECK(r.organs[0].report.pieces == 2);
  check_runs(r.scene, 30);
}

TEST_CASE("haustra import --body: a container the organs stay in, gravity towards its back when supine") {
  const fs::path dir = fresh_dir("body");
  const auto [lower, upper] = cut_organ(dir / ".", Eigen::Vector3d(100.0, 0.0, 0.0));
  // A trunk 400 wide, 250 deep (y), 500 long (z), the organs 25 mm in front of its centre (−y).
  import::ImportOptions o = surfaces({lower, upper}, dir / "abdomen.toml");
  o.body = box_body(dir / "body.obj", {-200.0, -100.0, -100.0}, {200.0, 150.0, 400.0}, true);
  const import::SurfacesReport r = import::import_surfaces(o);
  MESSAGE(r.text());
  CHECK(r.body_capped == 1);  // its open top closed by a fan
  CHECK(r.body_volume == doctest::Approx(0.4 * 0.25 * 0.5).epsilon(1e-9));
  CHECK(r.outside_body == 0.0);
  CHECK(r.gravity[0] == 0.0);
  CHECK(r.gravity[1] == doctest::Approx(9.81));  // supine by default with a body: towards its back, +y
  CHECK(r.gravity[2] == 0.0);
  const SceneDesc sc = load_scene(r.scene);
  REQUIRE(sc.world.environment.meshes.size() == 1);
  CHECK(sc.world.environment.meshes[0].container);
  CHECK(sc.world.gravity.isApprox(Eigen::Vector3d(0.0, 9.81, 0.0)));
  check_runs(r.scene, 30);

  // prone: the other way; an axis as given.
  o.gravity = "prone";
  o.out = dir / "prone.toml";
  CHECK(import::import_surfaces(o).gravity[1] == doctest::Approx(-9.81));
  // The organs at the body's centre: its back cannot be told from its front.
  o.gravity = "";
  o.body = box_body(dir / "centred.obj", {-200.0, -125.0, -100.0}, {200.0, 125.0, 400.0});
  CHECK_THROWS_WITH_AS(import::import_surfaces(o), doctest::Contains("--gravity supine: the organs lie"), Error);
  o.gravity = "+y";
  CHECK_NOTHROW(import::import_surfaces(o));
  // A body that does not hold the organs (in metres, 1000 times too large a frame for them).
  o.body = box_body(dir / "elsewhere.obj", {1000.0, 1000.0, 1000.0}, {1400.0, 1250.0, 1500.0});
  CHECK_THROWS_WITH_AS(import::import_surfaces(o), doctest::Contains("of the organs' surface lies outside the body"),
                       Error);
}

TEST_CASE("haustra import --gravity: axes, vectors, supine and prone read, anything else refused naming the option") {
  using Kind = import::GravityChoice::Kind;
  const auto d = [](const std::string& v) { return import::parse_gravity(v).direction; };
  CHECK(d("-z") == std::array<double, 3>{0.0, 0.0, -1.0});
  CHECK(d("+Y") == std::array<double, 3>{0.0, 1.0, 0.0});
  CHECK(d("x") == std::array<double, 3>{1.0, 0.0, 0.0});
  CHECK(d("0,0,-2") == std::array<double, 3>{0.0, 0.0, -1.0});
  CHECK(d("[3, 4, 0]")[0] == doctest::Approx(0.6));
  CHECK(import::parse_gravity("supine").kind == Kind::supine);
  CHECK(import::parse_gravity("Prone").kind == Kind::prone);
  for (const std::string bad : {"", "up", "-w", "0,0,0", "1,2", "1,2,3,4", "nan,0,1", "1,,2", "++z"}) {
    CAPTURE(bad);
    CHECK_THROWS_WITH_AS(import::parse_gravity(bad), doctest::Contains("--gravity: expected -x, +x"), Error);
  }
  // supine needs a body, and says so before any work; several surfaces refuse one surface's flags.
  const fs::path dir = fresh_dir("gravity");
  import::ImportOptions o = surfaces({kSurfaceData / "EdinGCA-00020-large-intestine-HF--HF.obj"}, dir / "s.toml");
  o.gravity = "supine";
  CHECK_THROWS_WITH_AS(import::import_surfaces(o), doctest::Contains("--gravity supine: needs --body"), Error);
  o.gravity = "down";
  CHECK_THROWS_WITH_AS(import::import_surfaces(o), doctest::Contains("got 'down'"), Error);
  o.gravity = "";
  o.more_meshes = {kSurfaceData / "EdinGCA-00020-large-intestine-HF-HF+.obj"};
  o.nodes = 41;
  CHECK_THROWS_WITH_AS(import::import_surfaces(o), doctest::Contains("--nodes: applies to one surface"), Error);
}

TEST_CASE(
    "haustra import of several surfaces: the same files give the same scene, bit for bit, and one in a body "
    "gives one surface's organ") {
  const fs::path dir = fresh_dir("same");
  const auto [lower, upper] = cut_organ(dir / ".", Eigen::Vector3d(100.0, 0.0, 0.0));
  const fs::path body = box_body(dir / "body.obj", {-200.0, -100.0, -100.0}, {200.0, 150.0, 400.0});
  import::ImportOptions a = surfaces({lower, upper}, dir / "a" / "s.toml"),
                        b = surfaces({lower, upper}, dir / "b" / "s.toml");
  a.body = b.body = body;
  (void)import::import_surfaces(a);
  (void)import::import_surfaces(b);
  CHECK(timeless(dir / "a" / "s.toml") == timeless(dir / "b" / "s.toml"));
  for (const char* f : {"s-lower-surface.obj", "s-upper-centreline.json", "s-body.obj"}) {
    CAPTURE(f);
    CHECK(bytes_of(dir / "a" / f) == bytes_of(dir / "b" / f));
  }
  // One surface in a body: its organ is the one surface's import, bit for bit.
  import::ImportOptions one = surfaces({lower}, dir / "one" / "s.toml");
  one.body = body;
  (void)import::import_surfaces(one);
  import::ImportOptions alone = surfaces({lower}, dir / "alone" / "s.toml");
  (void)import::import_surface(alone);
  CHECK(bytes_of(dir / "one" / "s-surface.obj") == bytes_of(dir / "alone" / "s-surface.obj"));
  CHECK(bytes_of(dir / "one" / "s-centreline.json") == bytes_of(dir / "alone" / "s-centreline.json"));
}

TEST_CASE(
    "an abdomen (two organs in a body) goes through the organ protocol and holds, the grasp on its longest organ") {
  const fs::path dir = fresh_dir("abdomen-protocol");
  // Two organs side by side (the upper half 100 mm aside), both named organ-*, and a trunk around them.
  fs::create_directories(dir / "surfaces");
  const auto [lower, upper] = cut_organ(dir / "surfaces", Eigen::Vector3d(100.0, 0.0, 0.0));
  fs::rename(lower, dir / "surfaces" / "organ-lower.obj");
  fs::rename(upper, dir / "surfaces" / "organ-upper.obj");
  fs::remove(dir / "surfaces" / "whole.obj");
  const fs::path body = box_body(dir / "body.obj", {-200.0, -100.0, -100.0}, {200.0, 150.0, 400.0});
  import::OrganProtocol p;
  p.rest = 1.0, p.pull = 0.5, p.hold = 0.25, p.after = 1.5;
  const import::CohortRow row = import::run_abdomen(dir / "surfaces", "organ-", body, dir / "out", p);
  MESSAGE(row.name << ": " << row.report.layout << "; at rest " << row.rest_max * 1e3 << " mm, force "
                   << row.largest_force << " N, pulled " << row.pulled * 1e3 << " mm, after " << row.after_max * 1e3
                   << " mm; " << row.error);
  CHECK(row.report.layout.find("2 organs of 2 surfaces, in the body") == 0);
  CHECK(row.ran);
  CHECK(row.grasped);
  CHECK(row.rest_max <= 1e-3);  // the support lets the weight sink it 0.5 mm
  CHECK(row.largest_force <= row.force_limit * (1.0 + 1e-9));
  CHECK(row.pulled > 0.01);  // it followed the grasper
  CHECK(row.after_max <= 5e-3);
  CHECK(row.holds);
  CHECK(fs::exists(dir / "out" / "protocol.toml"));
}
