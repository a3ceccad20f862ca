// Each kernel against its plain reference or a closed form.
#include <doctest/doctest.h>

#include <array>
#include <random>
#include <string>
#include <unsupported/Eigen/MatrixFunctions>
#include <utility>

#include "haustra/kernels/block_tridiagonal.hpp"
#include "haustra/kernels/inertia_filter.hpp"
#include "haustra/kernels/mass_matrix.hpp"
#include "haustra/kernels/rod_backward_sweep.hpp"
#include "haustra/kernels/rod_loads.hpp"
#include "haustra/kernels/strain_update.hpp"
#include "measured.hpp"
#include "rod_fixture.hpp"

using namespace haustra;
using namespace haustra::kernels;

namespace {

double rotation_distance(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return std::min((a.coeffs() - b.coeffs()).norm(), (a.coeffs() + b.coeffs()).norm());  // q and −q agree
}

}  // namespace

TEST_CASE("section_exp equals the 4x4 matrix exponential, across the series threshold") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (double angle : {0.0, 1e-9, 1e-4, 0.0499, 0.0501, 0.3, 1.0, 3.0, 6.0}) {
    for (int trial = 0; trial < 5; ++trial) {
      Eigen::Vector3d axis(u(rng), u(rng), u(rng));
      axis.normalize();
      const double length = 0.1 + std::abs(u(rng));
      const double eps = 0.5 * u(rng);
      const Eigen::Vector3d curv = axis * (angle / length);
      const Pose p = section_exp(curv, eps, length);
      Eigen::Matrix4d x = Eigen::Matrix4d::Zero();
      const Eigen::Vector3d w = curv * length;
      x.topLeftCorner<3, 3>() << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
      x(2, 3) = (1.0 + eps) * length;
      const Eigen::Matrix4d g = x.exp();
      INFO("angle " << angle);
      CHECK((p.position - g.topRightCorner<3, 1>()).norm() < 1e-14 * std::max(1.0, length));
      CHECK((p.rotation.toRotationMatrix() - g.topLeftCorner<3, 3>()).norm() < 1e-14);
      CHECK(std::abs(p.rotation.norm() - 1.0) < 1e-15);
    }
  }
}

TEST_CASE("rotation_log inverts rotation_exp, up to angles near pi") {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (double angle : {0.0, 1e-12, 1e-6, 0.5, 2.0, 3.1, 3.14159}) {
    Eigen::Vector3d axis(u(rng), u(rng), u(rng));
    axis.normalize();
    const Eigen::Vector3d v = angle * axis;
    CHECK((rotation_log(rotation_exp(v)) - v).norm() < 1e-12);
    CHECK((rotation_log(Eigen::Quaterniond(-rotation_exp(v).coeffs())) - v).norm() < 1e-12);  // −q: same rotation
  }
}

namespace {

// The largest difference of the sweep's node and midpoint poses from its matrix-exponential
// reference: positions (m) and rotations (quaternion distance).
std::pair<double, double> sweep_vs_reference(test::RodBuffers& fast, test::RodBuffers& ref) {
  const Pose base{rotation_exp(Eigen::Vector3d(0.3, -0.2, 1.0)), Eigen::Vector3d(1, 2, 3)};
  rod_forward_sweep(base, fast.h, StrainView<const double>{fast.strain}, fast.poses());
  rod_forward_sweep_reference(base, ref.h, StrainView<const double>{ref.strain}, ref.poses());
  double pos = 0.0, rot = 0.0;
  for (std::size_t k = 0; k < fast.n; ++k) {
    pos = std::max(pos, (fast.poses().node_position.get(k) - ref.poses().node_position.get(k)).norm());
    rot = std::max(rot, rotation_distance(fast.poses().node_rotation.get(k), ref.poses().node_rotation.get(k)));
  }
  for (std::size_t k = 0; k + 1 < fast.n; ++k) {
    pos = std::max(pos, (fast.poses().mid_position.get(k) - ref.poses().mid_position.get(k)).norm());
    rot = std::max(rot, rotation_distance(fast.poses().mid_rotation.get(k), ref.poses().mid_rotation.get(k)));
  }
  return {pos, rot};
}

}  // namespace

TEST_CASE("forward sweep equals its matrix-exponential reference") {
  for (std::uint32_t seed : {1u, 2u}) {
    test::RodBuffers fast(60), ref(60);
    fast.randomize(seed);
    ref.randomize(seed);
    const auto [pos, rot] = sweep_vs_reference(fast, ref);
    CHECK(pos < 1e-12);
    CHECK(rot < 1e-12);
  }
}

// The sweep's half-section exponentials are Taylor series up to a half-section turn of 0.5 rad and
// section_exp's closed forms (libm) beyond, chosen per block of 64 sections: a rope's turns (every
// block by the series), one block turning past the range between two series blocks, and every
// block past it. Measured: positions 2.8e-15–4.0e-15 m, rotations 1.5e-15–3.0e-15 on a 1.66 m rod.
TEST_CASE("forward sweep: series and closed-form blocks both equal the reference") {
  struct Case {
    const char* name;
    double curvature;                    // of every node (1/m, per component)
    std::size_t sharp_first, sharp_end;  // nodes turning at up to 150/m per component
    std::array<bool, 3> past;            // which blocks of 64 sections turn past the series' range
  };
  for (const Case& c : {Case{"rope-like", 10.0, 0, 0, {false, false, false}},
                        Case{"one block past the series", 3.0, 70, 80, {false, true, false}},
                        Case{"all past the series", 150.0, 0, 0, {true, true, true}}}) {
    INFO(std::string(c.name));
    test::RodBuffers fast(167), ref(167);
    for (auto* rod : {&fast, &ref}) {
      rod->randomize(11, 1.66, c.curvature);
      std::mt19937 rng(5);
      std::uniform_real_distribution<double> u(-1.0, 1.0);
      for (std::size_t k = c.sharp_first; k < c.sharp_end; ++k)
        for (std::size_t comp = 0; comp < 3; ++comp) rod->strain[4 * k + comp] = 150.0 * u(rng);
    }
    std::array<double, 3> turn{};  // each block's largest half-section turn
    const StrainView<const double> q{fast.strain};
    for (std::size_t k = 0; k + 1 < fast.n; ++k)
      turn[k / 64] = std::max(turn[k / 64], 0.5 * fast.h[k] * (0.5 * (q.get(k) + q.get(k + 1))).head<3>().norm());
    for (std::size_t b = 0; b < 3; ++b) CHECK((turn[b] > 0.5) == c.past[b]);
    const auto [pos, rot] = sweep_vs_reference(fast, ref);
    CHECK(pos < 3e-14);
    CHECK(rot < 2e-14);
  }
}

TEST_CASE("backward sweep equals the direct O(N^2) sum") {
  for (std::uint32_t seed : {4u, 5u}) {
    test::RodBuffers rod(40);
    rod.randomize(seed);
    rod.sweep();
    std::vector<double> fast(4 * rod.n), ref(4 * rod.n);
    const Wrench wf = rod_backward_sweep(rod.poses(), rod.h, rod.force(), rod.moment(), StrainView<double>{fast});
    const Wrench wr =
        rod_backward_sweep_reference(rod.poses(), rod.h, rod.force(), rod.moment(), StrainView<double>{ref});
    double scale = 0.0, err = 0.0;
    for (std::size_t i = 0; i < fast.size(); ++i) {
      scale = std::max(scale, std::abs(ref[i]));
      err = std::max(err, std::abs(fast[i] - ref[i]));
    }
    CHECK(err < 1e-13 * scale);
    CHECK((wf.force - wr.force).norm() < 1e-13 * wr.force.norm());
    CHECK((wf.moment - wr.moment).norm() < 1e-13 * wr.moment.norm());
  }
}

TEST_CASE("unit-load generalized force equals a backward sweep with that one load") {
  test::RodBuffers rod(25);
  rod.randomize(9);
  rod.sweep();
  const Eigen::Vector3d dir = Eigen::Vector3d(0.3, -0.5, 0.8).normalized();
  for (bool is_moment : {false, true}) {
    for (std::size_t node : {std::size_t{0}, std::size_t{1}, std::size_t{12}, std::size_t{24}}) {
      rod.clear_loads();
      (is_moment ? rod.moment() : rod.force()).set(node, dir);
      std::vector<double> unit(4 * rod.n), full(4 * rod.n);
      rod_unit_load_generalized_force(rod.poses(), rod.h, node, dir, is_moment, StrainView<double>{unit});
      rod_backward_sweep(rod.poses(), rod.h, rod.force(), rod.moment(), StrainView<double>{full});
      for (std::size_t i = 0; i < unit.size(); ++i) CHECK(unit[i] == doctest::Approx(full[i]).epsilon(1e-12));
    }
  }
}

TEST_CASE("mass-matrix solve equals a dense LDLT, and inverts the multiply") {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.2, 1.8);
  const std::size_t n = 30;
  std::vector<double> h(n - 1), inv(n), low(n), b(4 * n), x(4 * n), y(4 * n), ref(4 * n);
  for (auto& v : h) v = 0.01 * u(rng);
  for (auto& v : b) v = u(rng) - 1.0;
  mass_matrix_factor(h, inv, low);
  x = b;
  mass_matrix_solve({inv, low}, StrainView<double>{x});
  ref = b;
  mass_matrix_solve_reference(h, StrainView<double>{ref});
  for (std::size_t i = 0; i < x.size(); ++i) CHECK(x[i] == doctest::Approx(ref[i]).epsilon(1e-11));
  mass_matrix_multiply(h, StrainView<const double>{x}, StrainView<double>{y});
  for (std::size_t i = 0; i < y.size(); ++i) CHECK(y[i] == doctest::Approx(b[i]).epsilon(1e-11));
  // Row sums of M are the hat functions' integrals: M·1 = (h_{k−1} + h_k)/2.
  std::vector<double> ones(4 * n, 1.0);
  mass_matrix_multiply(h, StrainView<const double>{ones}, StrainView<double>{y});
  CHECK(y[4 * 5] == doctest::Approx(0.5 * (h[4] + h[5])).epsilon(1e-14));
  CHECK(y[0] == doctest::Approx(0.5 * h[0]).epsilon(1e-14));
}

TEST_CASE("strain law: elastic fixed point, viscous rate, Kelvin-Voigt blend") {
  // One node, M⁻¹R = y: elastic q = q̂ + y/k; viscous q = q_start + y Δt/η; KV in between.
  std::vector<double> y = {2, 2, 2, 2}, rest = {1, 1, 1, 1}, start = {5, 5, 5, 5}, q = {0, 0, 0, 0};
  StrainLawCoefficients law;
  law.stiffness = {4.0, 0.0, 4.0, 4.0};
  law.rate = {0.0, 8.0, 8.0, 0.0};
  const Eigen::Vector4d change =
      strain_update(StrainView<const double>{y}, StrainView<const double>{rest}, StrainView<const double>{start}, law,
                    {1.0, 1.0, 1.0, 0.5}, StrainView<double>{q});
  CHECK(q[0] == doctest::Approx(1.0 + 2.0 / 4.0));
  CHECK(q[1] == doctest::Approx(5.0 + 2.0 / 8.0));
  CHECK(q[2] == doctest::Approx((2.0 + 4.0 * 1.0 + 8.0 * 5.0) / 12.0));
  CHECK(q[3] == doctest::Approx(0.5 * 1.5));  // relaxation ω = 0.5 from 0 towards 1.5
  CHECK(change[3] == doctest::Approx(0.75));
}

TEST_CASE("inertia filter: the paper's blend per node, exempt nodes and midpoints") {
  std::vector<double> px = {0, 1, 2}, py = {0, 0, 0}, pz = {0, 0, 0};      // previous
  std::vector<double> ex = {0, 1, 2}, ey = {0, 0.5, 1.0}, ez = {0, 0, 0};  // estimated
  std::vector<double> mx = {0.5, 1.5}, my = {0.25, 0.75}, mz = {0, 0};
  const std::vector<double> mass = {1.0, 2.0, 3.0};
  const std::vector<std::uint8_t> exempt = {1, 0, 0};
  const double zeta = 0.01, dt = 0.1;
  const double dr = inertia_filter({px, py, pz}, mass, exempt, zeta, dt, {ex, ey, ez}, {mx, my, mz});
  CHECK(dr == doctest::Approx(1.0));
  const double a1 = std::exp(-zeta * 2.0 * 1.0 / (dt * dt));
  const double a2 = std::exp(-zeta * 3.0 * 1.0 / (dt * dt));
  CHECK(ey[0] == 0.0);
  CHECK(ey[1] == doctest::Approx(a1 * 0.5));
  CHECK(ey[2] == doctest::Approx(a2 * 1.0));
  CHECK(my[0] == doctest::Approx(0.25 + 0.5 * (ey[1] - 0.5)));
  CHECK(my[1] == doctest::Approx(0.75 + 0.5 * ((ey[1] - 0.5) + (ey[2] - 1.0))));
}

TEST_CASE("rigid drag: symmetric positive definite, translation drag is minus c v") {
  test::RodBuffers rod(20);
  rod.randomize(2);
  rod.sweep();
  std::vector<double> c(rod.n), s(rod.n);
  for (std::size_t k = 0; k < rod.n; ++k) {
    c[k] = 0.5 + 0.01 * static_cast<double>(k);
    s[k] = 1e-4;
  }
  const Eigen::Vector3d origin = rod.poses().node_position.get(0);
  const Matrix6d cm = rigid_drag_resistance(rod.poses().node_position, c, s, origin);
  CHECK((cm - cm.transpose()).norm() < 1e-12 * cm.norm());
  CHECK(Eigen::SelfAdjointEigenSolver<Matrix6d>(cm).eigenvalues().minCoeff() > 0.0);
  Vector6d twist = Vector6d::Zero();
  twist.tail<3>() = Eigen::Vector3d(0, 0, -2.0);
  rod.clear_loads();
  add_rigid_drag_loads(rod.poses().node_position, c, s, origin, twist, rod.force(), rod.moment());
  for (std::size_t k = 0; k < rod.n; ++k) CHECK(rod.fz[k] == doctest::Approx(2.0 * c[k]));
  // The drag wrench of any twist is −C twist.
  const Vector6d w = total_wrench(rod.poses().node_position, rod.force(), rod.moment(), origin);
  CHECK((w + cm * twist).norm() < 1e-12 * (cm * twist).norm());
}

namespace {

// A random block-tridiagonal system of n blocks of 5, factored and solved by the banded kernel and
// by a dense LU. `dominant`: diagonal blocks weighted so no row ever swaps; otherwise the diagonal
// blocks are small next to the sub-diagonal ones and partial pivoting swaps rows within the
// panel and across into the next block row (decision 0034). Returns the worst relative difference
// and counts the swaps that crossed blocks.
struct BandRun {
  double worst = 0.0;
  int swaps = 0, crossing = 0;
};
BandRun band_against_dense(bool dominant, unsigned seed) {
  constexpr int B = 5;
  const std::size_t n = 9;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  using Block = Eigen::Matrix<double, B, B>;
  std::vector<Block> lo(n), di(n), up(n);
  std::vector<Block> fill(n);
  std::vector<std::array<std::uint8_t, B>> swaps(n);
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(B * n, B * n);
  for (std::size_t k = 0; k < n; ++k) {
    for (int i = 0; i < B; ++i)
      for (int j = 0; j < B; ++j) {
        lo[k](i, j) = dominant ? u(rng) : 10.0 * u(rng);
        up[k](i, j) = u(rng);
        di[k](i, j) = dominant ? u(rng) + (i == j ? 4.0 : 0.0) : 0.1 * u(rng);
      }
    const auto r = static_cast<Eigen::Index>(k * B);
    dense.block(r, r, B, B) = di[k];
    if (k > 0) dense.block(r, r - B, B, B) = lo[k];
    if (k + 1 < n) dense.block(r, r + B, B, B) = up[k];
  }
  const int cols = 3;
  std::vector<double> rhs(n * B * cols);
  for (auto& v : rhs) v = u(rng);
  Eigen::MatrixXd b(B * n, cols);
  for (std::size_t k = 0; k < n; ++k)
    for (int c = 0; c < cols; ++c)
      for (int i = 0; i < B; ++i)
        b(static_cast<Eigen::Index>(k * B + i), c) = rhs[k * B * cols + static_cast<std::size_t>(c * B + i)];
  const Eigen::MatrixXd x = dense.fullPivLu().solve(b);
  BlockTridiagonalView<B> view{lo, di, up, fill, swaps};
  block_tridiagonal_factor(view);
  block_tridiagonal_solve(view, rhs, cols);
  BandRun run;
  for (std::size_t k = 0; k < n; ++k)
    for (int j = 0; j < B; ++j) {
      run.swaps += swaps[k][static_cast<std::size_t>(j)] != j ? 1 : 0;
      run.crossing += swaps[k][static_cast<std::size_t>(j)] >= B ? 1 : 0;
    }
  const double scale = x.cwiseAbs().maxCoeff();
  for (std::size_t k = 0; k < n; ++k)
    for (int c = 0; c < cols; ++c)
      for (int i = 0; i < B; ++i)
        run.worst = std::max(run.worst, std::abs(rhs[k * B * cols + static_cast<std::size_t>(c * B + i)] -
                                                 x(static_cast<Eigen::Index>(k * B + i), c)) /
                                            scale);
  return run;
}

}  // namespace

TEST_CASE("block-tridiagonal solve equals a dense LU") {
  const BandRun run = band_against_dense(true, 13);
  MESSAGE("diagonally dominant: worst " << run.worst << ", " << run.swaps << " swaps");
  CHECK(run.swaps == 0);
  CHECK(run.worst < 1e-14);
}

TEST_CASE(
    "block-tridiagonal solve pivots: rows swap within a block and across into the next, and it still equals a dense "
    "LU") {
  for (unsigned seed : {13u, 14u, 15u}) {
    const BandRun run = band_against_dense(false, seed);
    MESSAGE("seed " << seed << ": worst " << run.worst << ", " << run.swaps << " swaps, " << run.crossing
                    << " across blocks");
    CHECK(run.swaps > 10);
    CHECK(run.crossing > 5);
    test::measured("banded LU with pivoting across blocks vs a dense LU, seed " + std::to_string(seed), run.worst,
                   1e-12);
  }
}

TEST_CASE("rotation_angle_squared equals |rotation_log|² across the series' switch and beyond") {
  double worst = 0.0;
  for (double angle : {0.0, 1e-9, 1e-4, 0.01, 0.05, 0.0632, 0.0633, 0.07, 0.5, 2.0, 3.1}) {
    const Eigen::Quaterniond q = rotation_exp(angle * Eigen::Vector3d(0.3, -0.5, 0.8).normalized());
    const double reference = rotation_log(q).squaredNorm();
    const double got = rotation_angle_squared(q);
    worst = std::max(worst, std::abs(got - reference) / std::max(reference, 1e-300));
    CHECK(got == doctest::Approx(angle * angle).epsilon(1e-12));
  }
  CHECK(worst < 1e-14);  // measured: a few ulps
}
