// Broad phase and contact geometry against brute force and sampling.
#include <doctest/doctest.h>

#include <random>

#include "haustra/kernels/broad_phase.hpp"
#include "haustra/kernels/contact_geometry.hpp"

using namespace haustra::kernels;

namespace {

struct Spheres {
  std::vector<double> x, y, z, r;
  [[nodiscard]] SphereSet set() const { return {x, y, z, r}; }
  void add(double px, double py, double pz, double pr) {
    x.push_back(px);
    y.push_back(py);
    z.push_back(pz);
    r.push_back(pr);
  }
};

std::vector<SpherePair> brute(const Spheres& s, double margin) {
  std::vector<SpherePair> out(s.x.size() * s.x.size());
  out.resize(broad_phase_brute(s.set(), margin, out));
  return out;
}

// The grid queried in several uneven ranges, concatenated: what a threaded caller does.
std::vector<SpherePair> grid(const Spheres& s, double margin, double cell = 0.0) {
  SphereGrid g;
  g.build(s.set(), margin, cell);
  std::vector<SpherePair> all;
  const std::size_t n = s.x.size();
  const std::size_t cuts[] = {0, n / 7, n / 3, n / 2, n};
  for (int i = 0; i + 1 < 5; ++i) {
    std::vector<SpherePair> part(4);
    std::size_t c = g.query(s.set(), cuts[i], cuts[i + 1], part);
    if (c > part.size()) {
      part.resize(c);
      c = g.query(s.set(), cuts[i], cuts[i + 1], part);
    }
    all.insert(all.end(), part.begin(), part.begin() + static_cast<std::ptrdiff_t>(c));
  }
  return all;
}

void check_all_agree(const Spheres& s, double margin, const std::string& what) {
  const auto ref = brute(s, margin);
  INFO(what << ": " << ref.size() << " pairs by brute force");
  CHECK(grid(s, margin) == ref);
  CHECK(grid(s, margin, 1e-3) == ref);  // a grid far finer than the spheres
  CHECK(grid(s, margin, 10.0) == ref);  // and far coarser
}

}  // namespace

TEST_CASE("the grid returns exactly the brute-force pairs") {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  SUBCASE("random") {
    Spheres s;
    for (int i = 0; i < 400; ++i) s.add(u(rng), u(rng), u(rng), 0.01 + 0.04 * u(rng));
    check_all_agree(s, 0.0, "random");
    check_all_agree(s, 0.02, "random with margin");
  }
  SUBCASE("all coincident") {
    Spheres s;
    for (int i = 0; i < 60; ++i) s.add(0.3, 0.3, 0.3, 0.01);
    check_all_agree(s, 0.0, "coincident");
    CHECK(brute(s, 0.0).size() == 60 * 59 / 2);
  }
  SUBCASE("all on a line, touching exactly and not quite") {
    Spheres s;
    for (int i = 0; i < 100; ++i) s.add(0.02 * i, 0.0, 0.0, i % 2 == 0 ? 0.01 : 0.0099999);
    check_all_agree(s, 0.0, "line");
  }
  SUBCASE("huge and tiny radii") {
    Spheres s;
    for (int i = 0; i < 300; ++i) s.add(u(rng), u(rng), u(rng), 1e-5 + 1e-4 * u(rng));
    s.add(0.5, 0.5, 0.5, 0.4);
    s.add(-3.0, 0.5, 0.5, 3.2);
    s.add(0.1, 0.9, 0.2, 1e-9);
    check_all_agree(s, 0.0, "huge and tiny");
    check_all_agree(s, 1e-3, "huge and tiny with margin");
  }
  SUBCASE("clustered far apart") {
    Spheres s;
    for (int c = 0; c < 3; ++c)
      for (int i = 0; i < 50; ++i) s.add(1000.0 * c + u(rng) * 0.1, u(rng) * 0.1, u(rng) * 0.1, 0.02);
    check_all_agree(s, 0.0, "clusters");
  }
  SUBCASE("dense cells and hashed cells") {
    // Packed beads index the cells directly; the same beads with one far away hash them.
    Spheres s;
    for (int i = 0; i < 500; ++i) s.add(0.3 * u(rng), 0.3 * u(rng), 0.3 * u(rng), 0.01 + 0.005 * u(rng));
    SphereGrid g;
    g.build(s.set(), 0.0);
    CHECK(g.dense());
    check_all_agree(s, 0.0, "dense");
    s.add(500.0, 0.0, 0.0, 0.01);
    g.build(s.set(), 0.0);
    CHECK_FALSE(g.dense());
    check_all_agree(s, 0.0, "hashed");
    check_all_agree(s, 0.004, "hashed with margin");
  }
  SUBCASE("a radius profile: no outliers, every sphere in the grid, pairs at exactly touching distance") {
    Spheres s;
    for (int i = 0; i < 200; ++i) {
      const double r = 0.01 + 0.01 * i / 199.0;  // 1 to 2 cm along a rod
      s.add(0.0125 * i, 0.001 * (i % 3), 0.0, r);
    }
    for (int i = 0; i + 1 < 200; i += 7) {  // copies shifted to touch exactly along y
      s.add(s.x[i], s.y[i] + 2.0 * s.r[i], 0.0, s.r[i]);
    }
    check_all_agree(s, 0.0, "profile");
    check_all_agree(s, 0.003, "profile with margin");
  }
  SUBCASE("empty and single") {
    Spheres s;
    check_all_agree(s, 0.0, "empty");
    s.add(0, 0, 0, 1);
    check_all_agree(s, 0.0, "single");
  }
}

TEST_CASE("closest point on a triangle equals the best of dense sampling") {
  std::mt19937 rng(8);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int t = 0; t < 50; ++t) {
    const Eigen::Vector3d a(g(rng), g(rng), g(rng)), b(g(rng), g(rng), g(rng)), c(g(rng), g(rng), g(rng));
    const Eigen::Vector3d p = 2.0 * Eigen::Vector3d(g(rng), g(rng), g(rng));
    const Eigen::Vector3d q = closest_point_on_triangle(p, a, b, c);
    double best = 1e300;
    const int steps = 300;
    for (int i = 0; i <= steps; ++i)
      for (int j = 0; i + j <= steps; ++j) {
        const double u = double(i) / steps, v = double(j) / steps;
        best = std::min(best, (p - (a + u * (b - a) + v * (c - a))).norm());
      }
    CHECK((p - q).norm() <= best + 1e-12);
    CHECK((p - q).norm() >= best - 0.02 * (b - a).norm());  // within the sampling's resolution
  }
}

TEST_CASE("sphere contacts: depth and normal of plane, sphere and capsule") {
  const SphereContact pl = sphere_plane({0, 0, 0.01}, 0.02, {0, 0, 0}, {0, 0, 1});
  CHECK(pl.depth == doctest::Approx(0.01));
  CHECK(pl.normal.z() == 1.0);
  const SphereContact sp = sphere_sphere({0.03, 0, 0}, 0.02, {0, 0, 0}, 0.02);
  CHECK(sp.depth == doctest::Approx(0.01));
  CHECK(sp.normal.x() == doctest::Approx(1.0));
  const SphereContact same = sphere_sphere({0, 0, 0}, 0.02, {0, 0, 0}, 0.02);
  CHECK(same.depth == doctest::Approx(0.04));
  const SphereContact cap = sphere_capsule({0.5, 0.015, 0}, 0.01, {0, 0, 0}, {1, 0, 0}, 0.01);
  CHECK(cap.depth == doctest::Approx(0.005));
  CHECK(cap.normal.y() == doctest::Approx(1.0));
  const SphereContact end = sphere_capsule({1.015, 0, 0}, 0.01, {0, 0, 0}, {1, 0, 0}, 0.01);
  CHECK(end.depth == doctest::Approx(0.005));
  CHECK(end.normal.x() == doctest::Approx(1.0));
}

TEST_CASE("penalty: the paper's 50 E d^2 and its derivative") {
  const double e = 33.2e3;
  const Penalty p = contact_penalty(0.002, 50.0 * e, 2.0);
  CHECK(p.force == doctest::Approx(50.0 * e * 0.002 * 0.002));
  const double h = 1e-8;
  CHECK(p.stiffness == doctest::Approx((contact_penalty(0.002 + h, 50.0 * e, 2.0).force -
                                        contact_penalty(0.002 - h, 50.0 * e, 2.0).force) /
                                       (2 * h))
                           .epsilon(1e-6));
  CHECK(contact_penalty(-0.001, 50.0 * e, 2.0).force == 0.0);
  CHECK(contact_penalty(0.0, 50.0 * e, 1.5).stiffness == 0.0);
}
