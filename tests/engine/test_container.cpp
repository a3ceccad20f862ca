// Containers (decision 0093): a bead chain dropped in a closed box rests on its bottom at the
// penalty's equilibrium depth, as on a floor; a chain outside is pushed back in; a container wound
// inward acts as one wound outward; an open or inconsistently wound one is refused naming its field.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "haustra/error.hpp"
#include "haustra/mesh_io.hpp"
#include "haustra/scene.hpp"
#include "haustra/world.hpp"
#include "measured.hpp"

using namespace haustra;

namespace {

// The box [lo, hi] as 12 triangles wound outward.
TriangleMesh closed_box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  TriangleMesh m;
  for (int k = 0; k < 8; ++k)
    m.vertices.emplace_back((k & 1) != 0 ? hi.x() : lo.x(), (k & 2) != 0 ? hi.y() : lo.y(),
                            (k & 4) != 0 ? hi.z() : lo.z());
  m.triangles = {{0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}, {0, 1, 5}, {0, 5, 4},
                 {2, 6, 7}, {2, 7, 3}, {0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}};
  return m;
}

MeshObstacleDesc as_container(const TriangleMesh& m) {
  MeshObstacleDesc d;
  d.name = "box";
  d.source = "box.obj";
  d.vertices = m.vertices;
  d.triangles = m.triangles;
  d.container = true;
  return d;
}

constexpr double kChainBeadRadius = 0.01;  // m
constexpr int kChainBeads = 26;
constexpr double kChainLength = 0.5;  // m

// A straight free rod along x at height z (its centre at x_mid), with evenly spread beads, in the
// box [-0.5, 0.5]² × [0, 0.5] (a container) or over a floor at z = 0.
SceneDesc chain_scene(double x_mid, double z, bool in_container) {
  SceneDesc sc;
  sc.name = "container";
  WorldDesc& w = sc.world;
  w.threads = 1;
  SegmentDesc s;
  s.name = "rod";
  s.nodes = 51;
  s.base = BaseMode::free;
  s.drag = 4.0;
  s.rest.kind = RestShapeKind::straight;
  s.rest.length = kChainLength;
  s.base_position = Eigen::Vector3d(x_mid - 0.5 * kChainLength, 0.0, z);
  s.base_tangent = Eigen::Vector3d::UnitX();
  s.base_normal = Eigen::Vector3d::UnitZ();
  s.cross_section.radius = kChainBeadRadius;
  s.beads.enabled = true;
  s.beads.count = kChainBeads;
  s.beads.radius = kChainBeadRadius;
  w.segments.push_back(s);
  if (in_container)
    w.environment.meshes.push_back(as_container(closed_box({-0.5, -0.5, 0.0}, {0.5, 0.5, 0.5})));
  else
    w.environment.planes.push_back({"floor", Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ()});
  return sc;
}

std::vector<double> chain_nodes(const World& w) {
  std::vector<double> out;
  const auto p = w.node_positions();
  for (std::size_t k = 0; k < w.node_count(); ++k)
    for (int i = 0; i < 3; ++i) out.push_back(p.get(k)[i]);
  return out;
}

}  // namespace

TEST_CASE("a container keeps a dropped bead chain inside: it rests on the bottom at the penalty's equilibrium depth") {
  auto boxed = create_world(chain_scene(0.0, 0.05, true));
  auto floored = create_world(chain_scene(0.0, 0.05, false));
  for (int f = 0; f < 240; ++f) {
    boxed->step();
    floored->step();
  }
  // Resting: the contacts carry the rod's weight, each bead along the box's inward normal (+z here).
  const SegmentInfo& seg = boxed->segment(0);
  const double weight = seg.linear_density * seg.length * 9.81;
  double lifted = 0.0;
  std::size_t touching = 0;
  for (const Contact& c : boxed->contact_list()) {
    if (c.kind != ContactKind::mesh || c.depth <= 0.0) continue;
    ++touching;
    CHECK(c.other == 0);
    CHECK(c.direction.z() == doctest::Approx(1.0).epsilon(1e-9));
    CHECK(c.stiffness > 0.0);  // the Newton solve sees it, as any environment contact
    lifted += c.force.z();
  }
  CHECK(touching == static_cast<std::size_t>(kChainBeads));
  CHECK(lifted == doctest::Approx(weight).epsilon(0.01));
  // The reference: f = 50 E d² holding each bead's share of the weight, d = sqrt(W / (N · 50 E)).
  const double expected = std::sqrt(weight / (kChainBeads * 50.0 * 33.2e3));
  const std::size_t middle = kChainBeads / 2;
  const double depth = kChainBeadRadius - boxed->node_positions().get(boxed->bead_nodes()[middle]).z();
  test::measured("container: the middle bead's depth in the box's bottom over the penalty's equilibrium depth",
                 depth / expected, 2.0);
  CHECK(depth / expected > 0.5);
  CHECK(depth / expected < 2.0);
  // The bottom of a box is a floor: the same rest, to the rounding of the closest point.
  const std::vector<double> a = chain_nodes(*boxed), b = chain_nodes(*floored);
  double apart = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) apart = std::max(apart, std::abs(a[i] - b[i]));
  test::measured("container: largest distance of a node from where it rests on a floor", apart, 1e-9, "m");
  CHECK(apart < 1e-9);
}

TEST_CASE("a bead chain outside a container is pushed back in, however far out it is") {
  for (const double out : {0.02, 0.2, 1.0}) {
    // Over the box's lid z = 0.5, `out` beyond it, without gravity: only the container moves it.
    SceneDesc sc = chain_scene(0.0, 0.5 + out, true);
    sc.world.gravity = Eigen::Vector3d::Zero();
    auto w = create_world(sc);
    CAPTURE(out);
    for (std::size_t b = 0; b < w->bead_count(); ++b) REQUIRE(w->node_positions().get(w->bead_nodes()[b]).z() > 0.5);
    for (int f = 0; f < 120; ++f) w->step();
    double farthest = -1.0;  // beyond the lid, of any bead's centre
    for (std::size_t b = 0; b < w->bead_count(); ++b)
      farthest = std::max(farthest, w->node_positions().get(w->bead_nodes()[b]).z() - 0.5);
    MESSAGE("started " << out << " m outside; after 2 s the farthest bead centre is " << farthest
                       << " m past the wall");
    CHECK(farthest < -0.5 * kChainBeadRadius);  // inside, by at least half a radius
  }
  // Through the wall x = 0.5, half of it out: pushed back along its own axis.
  SceneDesc sc = chain_scene(0.5, 0.25, true);
  sc.world.gravity = Eigen::Vector3d::Zero();
  auto w = create_world(sc);
  for (int f = 0; f < 120; ++f) w->step();
  double farthest = -1.0;
  for (std::size_t b = 0; b < w->bead_count(); ++b)
    farthest = std::max(farthest, w->node_positions().get(w->bead_nodes()[b]).x() - 0.5);
  MESSAGE("half out through a wall; after 2 s the farthest bead centre is " << farthest << " m past it");
  CHECK(farthest < -0.5 * kChainBeadRadius);
}

TEST_CASE("a container wound inward holds beads as the same container wound outward") {
  SceneDesc outward = chain_scene(0.0, 0.05, true);
  SceneDesc inward = outward;
  for (auto& t : inward.world.environment.meshes[0].triangles) std::swap(t[1], t[2]);
  auto a = create_world(outward), b = create_world(inward);
  for (int f = 0; f < 60; ++f) {
    a->step();
    b->step();
  }
  CHECK(chain_nodes(*a) == chain_nodes(*b));
}

TEST_CASE("an open or inconsistently wound container is refused, naming its field and file") {
  SceneDesc open = chain_scene(0.0, 0.05, true);
  open.world.environment.meshes[0].triangles.pop_back();
  try {
    (void)create_world(open);
    FAIL("an open container was accepted");
  } catch (const FieldError& e) {
    CHECK(e.field() == "environment.mesh[0].container");
    CHECK(std::string(e.what()).find("box.obj is not closed") != std::string::npos);
  }
  SceneDesc twisted = chain_scene(0.0, 0.05, true);
  std::swap(twisted.world.environment.meshes[0].triangles[0][1], twisted.world.environment.meshes[0].triangles[0][2]);
  try {
    (void)create_world(twisted);
    FAIL("a container wound both ways was accepted");
  } catch (const FieldError& e) {
    CHECK(e.field() == "environment.mesh[0].container");
    CHECK(std::string(e.what()).find("not wound one way") != std::string::npos);
  }
  // The same open mesh as an obstacle is a two-sided sheet, as before.
  open.world.environment.meshes[0].container = false;
  CHECK_NOTHROW((void)create_world(open));
}

TEST_CASE("a scene's container: read from [[environment.mesh]] container = true, an open one refused at its line") {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "haustra-test-container";
  std::filesystem::create_directories(dir);
  TriangleMesh open = closed_box({-0.5, -0.5, 0.0}, {0.5, 0.5, 0.5});
  save_mesh(dir / "closed.obj", open);
  open.triangles.pop_back();
  save_mesh(dir / "open.obj", open);
  const std::string scene =
      "[[segment]]\nnodes = 21\n[segment.rest]\nshape = \"straight\"\nlength = 0.3\n[segment.beads]\ncount = 5\n"
      "[[environment.mesh]]\nfile = \"{}\"\ncontainer = true\n";
  auto with = [&](const std::string& file) {
    std::string text = scene;
    text.replace(text.find("{}"), 2, file);
    return parse_scene(text, dir / "s.toml");
  };
  const SceneDesc closed = with("closed.obj");
  REQUIRE(closed.world.environment.meshes.size() == 1);
  CHECK(closed.world.environment.meshes[0].container);
  CHECK_NOTHROW((void)create_world(closed));
  try {
    (void)create_world(with("open.obj"));
    FAIL("an open container was accepted");
  } catch (const FieldError& e) {
    CHECK(e.field() == "environment.mesh[0].container");
    const std::string what = e.what();
    CHECK(what.find("open.obj is not closed") != std::string::npos);
    CHECK(what.find("s.toml") != std::string::npos);  // the scene file, at the line that set it
  }
  std::string yes = scene;
  yes.replace(yes.find("{}"), 2, "closed.obj");
  yes.replace(yes.find("container = true"), 16, "container = \"yes\"");
  CHECK_THROWS_WITH_AS((void)parse_scene(yes, dir / "s.toml"),
                       doctest::Contains("environment.mesh[0].container: expected true or false"), FieldError);
  std::filesystem::remove_all(dir);
}
