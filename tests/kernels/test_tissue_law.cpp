// The EXP2 tissue law (paper eq. 1): its resultants over the thin-walled tube against direct
// quadrature over the wall, its tangents against finite differences, and rods that stretch and
// bend to the analytic equilibria of the nonlinear law.
#include <doctest/doctest.h>

#include <cmath>
#include <numbers>

#include "haustra/error.hpp"
#include "haustra/kernels/tissue_law.hpp"
#include "haustra/world.hpp"

using namespace haustra;
using namespace haustra::kernels;

namespace {

const Exp2Tissue kTissue{8.0, 6.7e3, 20.0e3};  // the scene defaults (paper Fig. 2, illustrative)
const TubeSection kTube{0.02, 0.003};

// σ straight from eq. 1, odd in ε: written here, not taken from the kernel.
double sigma(double e) {
  const double s = kTissue.beta * (std::exp(kTissue.alpha * e * e) - 1.0);
  return (e < 0 ? -s : s) + kTissue.gamma * e;
}

// Composite Simpson over [a, b] with `intervals` (even) intervals.
template <class F>
double simpson(F f, double a, double b, int intervals) {
  const double h = (b - a) / intervals;
  double sum = f(a) + f(b);
  for (int i = 1; i < intervals; ++i) sum += (i % 2 == 1 ? 4.0 : 2.0) * f(a + i * h);
  return sum * h / 3.0;
}

// M(κ) = ∮ σ(κ R sin θ) R sin θ · R h_w dθ: the moment of the fibres round the wall.
double moment_by_quadrature(double kappa) {
  const double r = kTube.radius;
  return simpson([&](double t) { return sigma(kappa * r * std::sin(t)) * r * std::sin(t) * r * kTube.wall; }, 0.0,
                 2.0 * std::numbers::pi, 20000);
}

// Bisection for the x in [0, hi] with f(x) = target, f increasing.
template <class F>
double invert(F f, double target, double hi) {
  double lo = 0.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (f(mid) < target ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

TEST_CASE("EXP2: stress, axial force and bending moment against eq. 1 and quadrature over the tube wall") {
  const double area = 2.0 * std::numbers::pi * kTube.radius * kTube.wall;
  for (double e : {-0.4, -0.05, 0.0, 1e-4, 0.1, 0.25, 0.5}) {
    CHECK(exp2_stress(kTissue, e).value == doctest::Approx(sigma(e)).epsilon(1e-13));
    CHECK(exp2_tube_axial_force(kTissue, kTube, e).value == doctest::Approx(area * sigma(e)).epsilon(1e-13));
  }
  // κR from 2e-5 to 0.9: both of the kernel's branches (series below a = ακ²R² = 1, erf above).
  for (double kappa : {1e-3, 0.5, 5.0, 17.0, 30.0, 45.0}) {
    INFO("kappa " << kappa);
    const double oracle = moment_by_quadrature(kappa);
    CHECK(exp2_tube_bending_moment(kTissue, kTube, kappa).value == doctest::Approx(oracle).epsilon(1e-10));
  }
}

TEST_CASE("EXP2: slopes match finite differences, energies the integrals of force and moment") {
  for (double x : {0.01, 0.2, 0.45}) {
    const double h = 1e-6;
    const auto f = [&](double e) { return exp2_tube_axial_force(kTissue, kTube, e).value; };
    CHECK(exp2_tube_axial_force(kTissue, kTube, x).slope ==
          doctest::Approx((f(x + h) - f(x - h)) / (2 * h)).epsilon(1e-7));
    const double k = x / kTube.radius;  // the same outer-fibre strain
    const auto m = [&](double c) { return exp2_tube_bending_moment(kTissue, kTube, c).value; };
    CHECK(exp2_tube_bending_moment(kTissue, kTube, k).slope ==
          doctest::Approx((m(k + h) - m(k - h)) / (2 * h)).epsilon(1e-6));
    CHECK(exp2_tube_axial_energy(kTissue, kTube, x) == doctest::Approx(simpson(f, 0.0, x, 2000)).epsilon(1e-9));
    CHECK(exp2_tube_bending_energy(kTissue, kTube, k) == doctest::Approx(simpson(m, 0.0, k, 2000)).epsilon(1e-9));
  }
}

TEST_CASE("EXP2 with beta = 0 is Hooke's law with E = gamma: EA eps and EI kappa") {
  const Exp2Tissue linear{8.0, 0.0, 33.2e3};
  const double ea = linear.gamma * 2.0 * std::numbers::pi * kTube.radius * kTube.wall;
  const double ei = linear.gamma * std::numbers::pi * std::pow(kTube.radius, 3) * kTube.wall;
  for (double x : {0.01, 0.3, 2.0}) {
    CHECK(exp2_tube_axial_force(linear, kTube, x).value == doctest::Approx(ea * x).epsilon(1e-14));
    CHECK(exp2_tube_bending_moment(linear, kTube, 10 * x).value == doctest::Approx(ei * 10 * x).epsilon(1e-14));
    CHECK(exp2_tube_bending_moment(linear, kTube, 10 * x).slope == doctest::Approx(ei).epsilon(1e-14));
  }
}

TEST_CASE("EXP2 nodal law: the tangent and the kappa1-kappa2 coupling match finite differences of the stress") {
  NodalLaw law;
  law.stiffness = {1.0, 1.0, 0.7, 2.0};
  law.rate = {0.5, 0.5, 0.2, 0.0};
  law.exp2 = true;
  law.tissue = kTissue;
  law.tube = kTube;
  const std::vector<double> q = {12.0, -7.0, 3.0, 0.3, -20.0, 4.0, 1.0, -0.2, 0.0, 0.0, 0.0, 0.0};
  const std::vector<double> rest = {1.0, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  const std::vector<double> start = {10.0, -6.0, 2.0, 0.2, -19.0, 3.0, 0.0, -0.1, 0.1, 0.0, 0.0, 0.0};
  auto eval = [&](const std::vector<double>& x, std::vector<double>& s, std::vector<double>& t,
                  std::vector<double>& c) {
    s.assign(12, 0.0);
    t.assign(12, 0.0);
    c.assign(3, 0.0);
    nodal_law_evaluate(StrainView<const double>{x}, StrainView<const double>{rest}, StrainView<const double>{start},
                       law, StrainView<double>{s}, StrainView<double>{t}, c);
  };
  std::vector<double> s, t, c, sp, sm, tt, cc;
  eval(q, s, t, c);
  for (std::size_t k = 0; k < 3; ++k)
    for (std::size_t j = 0; j < 4; ++j) {
      std::vector<double> x = q;
      // At q = 0 the odd extension has a kink in its second derivative: a smaller step there.
      const double h = q[4 * k + j] == 0.0 ? 1e-9 : 1e-6 * std::max(1.0, std::abs(q[4 * k + j]));
      x[4 * k + j] += h;
      eval(x, sp, tt, cc);
      x[4 * k + j] -= 2 * h;
      eval(x, sm, tt, cc);
      for (std::size_t i = 0; i < 4; ++i) {
        const double fd = (sp[4 * k + i] - sm[4 * k + i]) / (2 * h);
        const double analytic = i == j ? t[4 * k + i] : ((i == 0 && j == 1) || (i == 1 && j == 0) ? c[k] : 0.0);
        INFO("node " << k << " d s_" << i << " / d q_" << j);
        CHECK(analytic == doctest::Approx(fd).epsilon(1e-6).scale(1e-6));
      }
    }
  // At zero bend the tangent is the initial slope EI (E = γ) plus the rate, uncoupled.
  const double ei = kTissue.gamma * std::numbers::pi * std::pow(kTube.radius, 3) * kTube.wall;
  CHECK(t[8] == doctest::Approx(ei + 0.5).epsilon(1e-12));
  CHECK(c[2] == 0.0);
}

namespace {

// A straight elastic rod along x, clamped at the origin, no gravity, one load at the tip.
WorldDesc loaded_rod(TissueResponse response, double length, const Eigen::Vector3d& force,
                     const Eigen::Vector3d& moment) {
  WorldDesc d;
  d.threads = 1;
  d.gravity = Eigen::Vector3d::Zero();
  d.solver.max_iterations = 50;
  SegmentDesc s;
  s.nodes = 21;
  s.rest.length = length;
  s.law = {StrainLaw::elastic, StrainLaw::elastic, StrainLaw::elastic, StrainLaw::elastic};
  s.cross_section = {kTube.radius, kTube.wall};
  s.material.response = response;
  s.material.exp2_alpha = kTissue.alpha;
  s.material.exp2_beta = kTissue.beta;
  s.material.exp2_gamma = kTissue.gamma;
  s.loads.push_back({-1, force, moment});
  d.segments.push_back(s);
  return d;
}

}  // namespace

TEST_CASE("an EXP2 rod pulled at its tip stretches to A sigma(eps) = F, a Hooke rod to EA eps = F") {
  const double area = 2.0 * std::numbers::pi * kTube.radius * kTube.wall;
  for (double target_strain : {0.1, 0.3, 0.5}) {
    const double force = area * sigma(target_strain);
    const double eps = invert([&](double e) { return area * sigma(e); }, force, 2.0);
    auto w = World::create(loaded_rod(TissueResponse::exp2, 0.2, {force, 0.0, 0.0}, {0, 0, 0}));
    for (int f = 0; f < 20; ++f) w->step();
    const double tip = w->node_positions().x[20];
    INFO("strain " << target_strain << ": tip " << tip);
    CHECK(tip == doctest::Approx(0.2 * (1.0 + eps)).epsilon(1e-9));
    auto hooke = World::create(loaded_rod(TissueResponse::hooke, 0.2, {force, 0.0, 0.0}, {0, 0, 0}));
    for (int f = 0; f < 20; ++f) hooke->step();
    CHECK(hooke->node_positions().x[20] ==
          doctest::Approx(0.2 * (1.0 + force / hooke->segment(0).axial_stiffness)).epsilon(1e-9));
  }
}

TEST_CASE("an EXP2 rod under an end moment bends into an arc of M(kappa) = M0 by quadrature over the wall") {
  for (double outer_strain : {0.05, 0.25, 0.4}) {
    const double kappa_expected = outer_strain / kTube.radius;
    const double m0 = moment_by_quadrature(kappa_expected);
    const double kappa = invert(moment_by_quadrature, m0, 100.0);
    const double length = 0.1;
    // A moment about −y bends a rod along x upwards (towards +z) in the x–z plane.
    auto w = World::create(loaded_rod(TissueResponse::exp2, length, {0, 0, 0}, {0.0, -m0, 0.0}));
    for (int f = 0; f < 30; ++f) w->step();
    const Eigen::Vector3d tip(w->node_positions().x[20], w->node_positions().y[20], w->node_positions().z[20]);
    // An arc of curvature κ from the origin along x: tip at (sin κL, 0, 1 − cos κL)/κ.
    const Eigen::Vector3d arc(std::sin(kappa * length) / kappa, 0.0, (1.0 - std::cos(kappa * length)) / kappa);
    INFO("outer-fibre strain " << outer_strain << ": tip " << tip.transpose() << ", arc " << arc.transpose());
    CHECK((tip - arc).norm() < 1e-7 * length);
  }
}

TEST_CASE("EXP2 needs the Newton solver and sane parameters: refused with the field named") {
  WorldDesc d = loaded_rod(TissueResponse::exp2, 0.2, {1, 0, 0}, {0, 0, 0});
  d.solver.mode = SolverMode::lagged;
  CHECK_THROWS_WITH_AS(World::create(d), doctest::Contains("segment[0].tissue.response"), Error);
  d.solver.mode = SolverMode::newton;
  d.segments[0].material.exp2_gamma = 0.0;
  CHECK_THROWS_WITH_AS(World::create(d), doctest::Contains("segment[0].tissue.gamma"), Error);
  d.segments[0].material.exp2_gamma = 1e4;
  d.segments[0].material.exp2_alpha = -1.0;
  CHECK_THROWS_WITH_AS(World::create(d), doctest::Contains("segment[0].tissue.alpha"), Error);
}
