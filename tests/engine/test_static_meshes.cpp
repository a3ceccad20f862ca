// Static meshes through Embree's point query against brute force over every triangle, and the
// inside/outside decision against the generalized winding number.
#include <doctest/doctest.h>

#include "cage_fixtures.hpp"

#include <numbers>
#include <random>

#include "haustra/kernels/contact_geometry.hpp"
#include "haustra/mesh_io.hpp"
#include "model/static_meshes.hpp"

using namespace haustra;

namespace {

double brute_force_distance(const TriangleMesh& m, const Eigen::Vector3d& p) {
  double best = 1e300;
  for (const auto& t : m.triangles)
    best = std::min(
        best, (p - kernels::closest_point_on_triangle(p, m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]])).norm());
  return best;
}

double winding_number(const TriangleMesh& m, const Eigen::Vector3d& p) {
  return test::winding_number(m.vertices, m.triangles, p);
}

detail::StaticMeshes build(const TriangleMesh& m) {
  return detail::StaticMeshes(std::vector<MeshObstacleDesc>{{"mesh", "test", m.vertices, m.triangles}});
}

// A bumpy open sheet over the unit square: two-sided, no inside.
TriangleMesh sheet(int n) {
  TriangleMesh m;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const double x = static_cast<double>(i) / n, y = static_cast<double>(j) / n;
      m.vertices.emplace_back(x, y, 0.05 * std::sin(7.0 * x) * std::cos(5.0 * y));
    }
  const auto id = [n](int i, int j) { return static_cast<std::uint32_t>(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      m.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return m;
}

}  // namespace

TEST_CASE("the closest point on a static mesh is the brute-force closest, inside decided as the winding number says") {
  const TriangleMesh bolster = load_mesh(std::string(HAUSTRA_SOURCE_DIR) + "/scenes/assets/bolster.obj");
  REQUIRE(is_closed(bolster));
  const detail::StaticMeshes meshes = build(bolster);
  REQUIRE(meshes.closed(0));
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int inside = 0, outside = 0, missed = 0;
  const double radius = 0.05;
  for (int i = 0; i < 3000; ++i) {
    // Around the bolster (r = 6 cm, |y| ≤ 40 cm), inside and out, many near its caps and rims.
    const Eigen::Vector3d p(0.09 * u(rng), 0.45 * u(rng), 0.09 * u(rng));
    const double reference = brute_force_distance(bolster, p);
    const detail::StaticMeshes::Hit hit = meshes.closest(p, radius);
    INFO("point " << p.transpose() << ", brute-force distance " << reference);
    if (reference > radius * (1.0 + 1e-6)) {
      CHECK_FALSE(hit.found);
      ++missed;
      continue;
    }
    if (reference < radius * (1.0 - 1e-6)) REQUIRE(hit.found);
    if (!hit.found) continue;  // within float rounding of the query radius
    CHECK(std::abs(std::abs(hit.signed_distance) - reference) < 1e-12);
    CHECK(std::abs((p - hit.point).norm() - reference) < 1e-12);
    const double w = winding_number(bolster, p);
    REQUIRE((std::abs(w) < 1e-6 || std::abs(w - 1.0) < 1e-6));
    const bool is_inside = w > 0.5;
    if (reference > 1e-9) CHECK((hit.signed_distance < 0.0) == is_inside);
    (is_inside ? inside : outside) += 1;
    // Moving along `push` by the depth and a little more takes the point out.
    const Eigen::Vector3d out = p + (std::max(0.0, -hit.signed_distance) + 1e-4) * hit.push;
    CHECK(winding_number(bolster, out) < 1e-6);
  }
  CHECK(inside > 300);
  CHECK(outside > 300);
  CHECK(missed > 100);
}

TEST_CASE("an open mesh is a two-sided sheet: distances agree with brute force, never inside") {
  const TriangleMesh m = sheet(24);
  REQUIRE_FALSE(is_closed(m));
  const detail::StaticMeshes meshes = build(m);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d p(1.2 * u(rng) - 0.1, 1.2 * u(rng) - 0.1, 0.3 * u(rng) - 0.15);
    const double reference = brute_force_distance(m, p);
    const detail::StaticMeshes::Hit hit = meshes.closest(p, 0.1);
    if (reference > 0.1 * (1.0 + 1e-6)) {
      CHECK_FALSE(hit.found);
      continue;
    }
    if (reference < 0.1 * (1.0 - 1e-6)) REQUIRE(hit.found);
    if (!hit.found) continue;
    CHECK(hit.signed_distance >= 0.0);
    CHECK(std::abs(hit.signed_distance - reference) < 1e-12);
    if (reference > 1e-9) CHECK((p - hit.point).normalized().dot(hit.push) > 1.0 - 1e-12);
  }
}

TEST_CASE("a container's contact is found where brute force says the point is near its wall or outside it") {
  // The bolster as a container: a point within `reach` of its wall from inside, or anywhere out, has
  // a contact whose push points inward; a deeper point has none (the depth grid's shortcut included).
  const TriangleMesh bolster = load_mesh(std::string(HAUSTRA_SOURCE_DIR) + "/scenes/assets/bolster.obj");
  MeshObstacleDesc d{"bolster", "test", bolster.vertices, bolster.triangles};
  d.container = true;
  const detail::StaticMeshes meshes(std::vector<MeshObstacleDesc>{d});
  REQUIRE(meshes.container_count() == 1);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double reach = 0.01;
  int near = 0, deep = 0, out = 0;
  for (int i = 0; i < 4000; ++i) {
    const Eigen::Vector3d p(0.12 * u(rng), 0.5 * u(rng), 0.12 * u(rng));
    const double distance = brute_force_distance(bolster, p);
    const bool inside = winding_number(bolster, p) > 0.5;
    const detail::StaticMeshes::Hit hit = meshes.container_contact(0, p, reach);
    INFO("point " << p.transpose() << ", brute-force distance " << distance << (inside ? " inside" : " outside"));
    if (inside && distance > reach * (1.0 + 1e-6)) {
      CHECK_FALSE(hit.found);
      ++deep;
      continue;
    }
    if (inside && distance > reach * (1.0 - 1e-6)) continue;  // within rounding of the reach
    REQUIRE(hit.found);
    CHECK(std::abs(std::abs(hit.signed_distance) - distance) < 1e-12);
    CHECK((hit.signed_distance > 0.0) == inside);
    // Moving along `push` by the distance outside and a little more takes the point in.
    const Eigen::Vector3d in = p + (std::max(0.0, -hit.signed_distance) + 1e-4) * hit.push;
    CHECK(winding_number(bolster, in) > 0.5);
    (inside ? near : out) += 1;
  }
  CHECK(deep > 100);
  CHECK(near > 100);
  CHECK(out > 1000);
}
