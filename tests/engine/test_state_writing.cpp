// Writing state from arrays (decision 0102) through the C++ API, each setter checked against geometry
// it must reproduce: arcs, rigid motions, the lumping of a load per metre, a refusal that writes nothing.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include "haustra/error.hpp"
#include "haustra/world.hpp"
#include "scene_fixtures.hpp"

namespace haustra {

namespace {

// The circumcentre of three points (the circle through them).
Eigen::Vector3d circumcentre(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, n = ab.cross(ac);
  return a + (n.cross(ab) * ac.squaredNorm() + ac.cross(n) * ab.squaredNorm()) / (2.0 * n.squaredNorm());
}

}  // namespace

TEST_CASE("set_strains: the strains read back bit for bit, and a constant bend puts every node on one circle") {
  auto w = test::scene_world("cantilever");
  const std::size_t n = w->node_count();
  const double kappa = 2.0;  // 1/m: a 0.5 m circle
  std::vector<double> strains(4 * n, 0.0);
  for (std::size_t k = 0; k < n; ++k) strains[4 * k] = kappa;
  w->set_strains(strains);
  const auto back = w->strains();
  REQUIRE(back.data.size() == strains.size());
  CHECK(std::memcmp(back.data.data(), strains.data(), strains.size() * sizeof(double)) == 0);
  const auto x = w->node_positions();
  const Eigen::Vector3d c = circumcentre(x.get(0), x.get(n / 2), x.get(n - 1));
  double worst = 0.0;
  for (std::size_t k = 0; k < n; ++k) worst = std::max(worst, std::abs((x.get(k) - c).norm() - 1.0 / kappa));
  MESSAGE("largest distance of a node from the 0.5 m circle: " << worst << " m");
  CHECK(worst < 1e-14);  // measured 1.1e-15: an arc per section is the rod's own shape
}

TEST_CASE("set_node_positions: points on an arc of the rod's own length give its curvature and no stretch") {
  auto w = test::scene_world("cantilever");
  const std::size_t n = w->node_count();
  const auto h = w->section_lengths();
  const auto x0 = w->node_positions();
  const Eigen::Vector3d base = x0.get(0), along = (x0.get(n - 1) - base).normalized();
  const Eigen::Vector3d side = along.unitOrthogonal();
  const double R = 0.8;  // m
  std::vector<double> px(n), py(n), pz(n);
  double s = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Vector3d p = base + R * std::sin(s / R) * along + R * (1.0 - std::cos(s / R)) * side;
    px[k] = p.x(), py[k] = p.y(), pz[k] = p.z();
    if (k + 1 < n) s += h[k];
  }
  w->set_node_positions({px, py, pz});
  const auto x = w->node_positions();
  const auto strain = w->strains();
  double position = 0.0, bend = 0.0, twist = 0.0, stretch = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    position = std::max(position, (x.get(k) - Eigen::Vector3d(px[k], py[k], pz[k])).norm());
    bend = std::max(bend, std::abs(std::hypot(strain.data[4 * k], strain.data[4 * k + 1]) - 1.0 / R));
    twist = std::max(twist, std::abs(strain.data[4 * k + 2]));
    stretch = std::max(stretch, std::abs(strain.data[4 * k + 3]));
  }
  MESSAGE("positions " << position << " m, curvature " << bend << " 1/m, torsion " << twist << ", stretch " << stretch);
  CHECK(position < 5e-15);  // measured 6.1e-16
  CHECK(bend < 5e-9);       // 8.3e-10
  CHECK(twist < 2e-12);     // 1.8e-13
  CHECK(stretch < 3e-12);   // 3.5e-13
}

TEST_CASE("set_base_pose moves the rod rigidly: node 0 to the new base, every distance between nodes kept") {
  auto w = test::scene_world("cantilever");
  const std::size_t n = w->node_count();
  std::vector<double> strains(4 * n, 0.0);
  for (std::size_t k = 0; k < n; ++k) strains[4 * k + 1] = 1.5, strains[4 * k + 2] = 0.7;  // a helix
  w->set_strains(strains);
  const auto before = w->node_positions();
  std::vector<Eigen::Vector3d> was(n);
  for (std::size_t k = 0; k < n; ++k) was[k] = before.get(k);
  kernels::Pose moved;
  moved.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(1.1, Eigen::Vector3d(1.0, 2.0, -0.5).normalized()));
  moved.position = {0.3, -0.2, 0.9};
  w->set_base_pose(0, moved);
  const auto x = w->node_positions();
  double base = (x.get(0) - moved.position).norm(), distances = 0.0;
  for (std::size_t a = 0; a < n; a += 7)
    for (std::size_t b = a + 1; b < n; b += 5)
      distances = std::max(distances, std::abs((x.get(a) - x.get(b)).norm() - (was[a] - was[b]).norm()));
  MESSAGE("base " << base << " m, distances " << distances << " m");
  CHECK(base < 1e-15);       // measured 0
  CHECK(distances < 5e-15);  // 6.7e-16
}

TEST_CASE("set_distributed_load lumps a load per metre onto each node by half of the sections beside it") {
  auto w = test::scene_world("cantilever");
  const std::size_t n = w->segment(0).nodes.count;
  const auto h = w->section_lengths();
  std::vector<double> q(3 * n, 0.0);
  for (std::size_t k = 0; k < n; ++k) q[3 * k + 2] = -3.0 - 0.01 * static_cast<double>(k);  // N/m, varying
  w->set_distributed_load(0, q, {}, false);
  double worst = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const double share = 0.5 * ((k > 0 ? h[k - 1] : 0.0) + (k + 1 < n ? h[k] : 0.0));
    worst = std::max(worst, std::abs(w->external_load(k).first.z() - q[3 * k + 2] * share));
  }
  MESSAGE("largest difference from q × half the sections beside the node: " << worst << " N");
  CHECK(worst < 3e-17);  // measured 3.4e-18
}

TEST_CASE("a refused write leaves the world as it was, byte for byte, and names what it refused") {
  auto w = test::scene_world("cantilever");
  for (int f = 0; f < 5; ++f) w->step();
  const std::vector<std::byte> before = w->save_checkpoint();
  std::vector<double> strains(4 * w->node_count(), 0.1);
  strains[4 * 7 + 2] = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_AS(w->set_strains(strains), Error);
  std::vector<double> short_strains(3, 0.0);
  CHECK_THROWS_AS(w->set_strains(short_strains), Error);
  CHECK(w->save_checkpoint() == before);
}

}  // namespace haustra
