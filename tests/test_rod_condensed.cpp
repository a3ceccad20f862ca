// The condensed Newton solve against the banded LU of the assembled 16×16 block system (the
// oracle): every node's δq, δφ, δr for the residual and for unit loads, clamped and free, with and
// without load stiffness, with a linear law and with a nonlinear law's tangent.
#include <doctest/doctest.h>

#include <algorithm>
#include <random>

#include "haustra/kernels/block_tridiagonal.hpp"
#include "haustra/kernels/rod_backward_sweep.hpp"
#include "haustra/kernels/rod_condensed.hpp"
#include "haustra/kernels/rod_newton.hpp"
#include "rod_fixture.hpp"

using namespace haustra;
using namespace haustra::kernels;

namespace {

struct Case {
  std::size_t n = 20;
  bool free_base = false;
  bool stiffness = false;
  bool nodal = false;
  std::size_t unit_loads = 0;
  std::uint32_t seed = 1;
  double load = 1.0;
};

struct Solved {
  // Per column: 10 numbers per node (δφ, δr, δq).
  std::vector<std::vector<double>> columns;
};

struct Problem {
  Case cs;
  test::RodBuffers rod;
  std::array<double, 4> a = {0.7, 0.9, 0.5, 30.0};
  std::vector<double> residual, tangent, coupling;
  std::vector<Eigen::Matrix3d> k;
  std::vector<double> s;
  std::vector<UnitLoad> loads;  // one per column ≥ 1, sorted by node descending

  explicit Problem(const Case& c) : cs(c), rod(c.n), residual(4 * c.n), tangent(4 * c.n), coupling(c.n), k(c.n), s(c.n) {
    rod.randomize(c.seed, 1.0, 3.0, c.load);
    rod.sweep(Pose{rotation_exp(Eigen::Vector3d(0.3, -0.2, 0.1)), Eigen::Vector3d(0.1, 0.2, 0.3)});
    std::mt19937 rng(c.seed + 100);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (double& r : residual) r = u(rng);
    for (std::size_t i = 0; i < c.n; ++i) {
      for (std::size_t comp = 0; comp < 4; ++comp) tangent[4 * i + comp] = a[comp] * (1.0 + 0.5 * u(rng));
      coupling[i] = 0.2 * u(rng);
      const Eigen::Matrix3d m = Eigen::Matrix3d::Random();
      k[i] = 2.0 * Eigen::Matrix3d::Identity() + 0.5 * m * m.transpose();
      s[i] = 0.05 * (1.5 + u(rng));
    }
    for (std::size_t j = 0; j < c.unit_loads; ++j) {
      UnitLoad l;
      l.node = static_cast<std::uint32_t>(std::uniform_int_distribution<std::size_t>(0, c.n - 1)(rng));
      l.column = static_cast<std::uint32_t>(1 + j);
      l.is_moment = j % 3 == 2;
      l.load = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
      loads.push_back(l);
    }
    std::stable_sort(loads.begin(), loads.end(), [](const UnitLoad& x, const UnitLoad& y) { return x.node > y.node; });
    // Columns numbered in the order the sweep meets them (rod_condense's contract).
    for (std::size_t j = 0; j < loads.size(); ++j) loads[j].column = static_cast<std::uint32_t>(1 + j);
  }

  NewtonLoadStiffness stiffness() const {
    if (!cs.stiffness) return {};
    return {k, s};
  }
  NodalLawTangent nodal() const {
    if (!cs.nodal) return {};
    return {StrainView<const double>{tangent}, coupling};
  }
  RodLinearization linearization() {
    RodLinearization lin;
    lin.poses = rod.poses();
    lin.section_length = rod.h;
    lin.node_force = rod.force();
    lin.node_moment = rod.moment();
    lin.law_total = a;
    lin.nodal = nodal();
    lin.stiffness = stiffness();
    lin.free_base = cs.free_base;
    return lin;
  }
  [[nodiscard]] int columns() const { return 1 + static_cast<int>(cs.unit_loads); }

  // The oracle: the assembled block system, banded LU, unit loads as generalized-force columns
  // of the strain rows (and their wrench in the free base's rows), as the engine did before.
  Solved band() {
    const std::size_t n = cs.n;
    const int cols = columns();
    constexpr int B = kNewtonBlock;
    std::vector<NewtonBlock> lo(n), di(n), up(n), fill(n);
    std::vector<std::array<std::uint8_t, B>> swaps(n);
    std::vector<double> dfx(n), dfy(n), dfz(n), dmx(n), dmy(n), dmz(n);
    const Eigen::Matrix<double, 6, 1> wrench =
        rod_newton_assemble(rod.poses(), rod.h, rod.force(), rod.moment(), a, stiffness(), cs.free_base,
                            {dfx, dfy, dfz}, {dmx, dmy, dmz}, {lo, di, up, fill, swaps}, nodal());
    block_tridiagonal_factor<B>({lo, di, up, fill, swaps});
    std::vector<double> rhs(n * B * static_cast<std::size_t>(cols), 0.0);
    auto entry = [&](std::size_t node, int row, int col) -> double& {
      return rhs[node * B * static_cast<std::size_t>(cols) + static_cast<std::size_t>(col * B + row)];
    };
    for (std::size_t i = 0; i < n; ++i)
      for (int c = 0; c < 4; ++c) entry(i, c, 0) = -residual[4 * i + static_cast<std::size_t>(c)];
    if (cs.free_base)
      for (int i = 0; i < 6; ++i) entry(0, kNewtonRotation + i, 0) = -wrench[i];
    std::vector<double> g(4 * n);
    for (const UnitLoad& l : loads) {
      const auto col = static_cast<int>(l.column);
      rod_unit_load_generalized_force(rod.poses(), rod.h, l.node, l.load, l.is_moment, StrainView<double>{g});
      for (std::size_t i = 0; i < n; ++i)
        for (int c = 0; c < 4; ++c) entry(i, c, col) -= g[4 * i + static_cast<std::size_t>(c)];
      if (cs.free_base) {
        const Eigen::Vector3d lever = rod.poses().node_position.get(l.node) - rod.poses().node_position.get(0);
        const Eigen::Vector3d m = l.is_moment ? l.load : Eigen::Vector3d(lever.cross(l.load));
        const Eigen::Vector3d f = l.is_moment ? Eigen::Vector3d::Zero() : l.load;
        for (int i = 0; i < 3; ++i) {
          entry(0, kNewtonRotation + i, col) -= m[i];
          entry(0, kNewtonPosition + i, col) -= f[i];
        }
      }
    }
    block_tridiagonal_solve<B>({lo, di, up, fill, swaps}, rhs, cols);
    Solved out;
    for (int c = 0; c < cols; ++c) {
      std::vector<double> v(10 * n);
      for (std::size_t i = 0; i < n; ++i) {
        for (int j = 0; j < 6; ++j) v[10 * i + static_cast<std::size_t>(j)] = entry(i, kNewtonRotation + j, c);
        for (int j = 0; j < 4; ++j) v[10 * i + 6 + static_cast<std::size_t>(j)] = entry(i, j, c);
      }
      out.columns.push_back(std::move(v));
    }
    return out;
  }

  struct Condensed {
    Solved solved;
    CondenseReport report;
    std::vector<double> responses;  // at `nodes`, 6 × columns each
  };
  Condensed condensed(const std::vector<std::uint32_t>& nodes = {}) {
    const std::size_t n = cs.n;
    const int cols = columns();
    std::vector<double> gain(condensed_gain_size(n, cols)), scratch(condensed_scratch_size(cols)),
        base(10 * static_cast<std::size_t>(cols));
    const CondensedSystem sys{gain, scratch, base, cols};
    const RodLinearization lin = linearization();
    Condensed out;
    out.report = rod_condense(lin, StrainView<const double>{residual}, loads, sys);
    std::vector<double> dq(4 * n), px(n), py(n), pz(n), rx(n), ry(n), rz(n);
    for (int c = 0; c < cols; ++c) {
      std::vector<double> weights(static_cast<std::size_t>(cols), 0.0);
      weights[static_cast<std::size_t>(c)] = 1.0;
      rod_condensed_step(lin, sys, weights, StrainView<double>{dq}, {px, py, pz}, {rx, ry, rz});
      std::vector<double> v(10 * n);
      for (std::size_t i = 0; i < n; ++i) {
        const double y[10] = {px[i], py[i], pz[i], rx[i], ry[i], rz[i], dq[4 * i], dq[4 * i + 1], dq[4 * i + 2], dq[4 * i + 3]};
        std::copy(y, y + 10, v.begin() + static_cast<std::ptrdiff_t>(10 * i));
      }
      out.solved.columns.push_back(std::move(v));
    }
    out.responses.resize(nodes.size() * 6 * static_cast<std::size_t>(cols));
    rod_condensed_responses(lin, sys, nodes, out.responses);
    return out;
  }
};

// Largest difference relative to the column's largest entry, per unknown group (each against its own scale).
double worst_relative(const Solved& x, const Solved& ref) {
  double worst = 0.0;
  for (std::size_t c = 0; c < ref.columns.size(); ++c)
    for (std::size_t group = 0; group < 3; ++group) {  // δφ, δr, δq
      const std::size_t first = group == 0 ? 0 : (group == 1 ? 3 : 6), count = group == 2 ? 4 : 3;
      double scale = 0.0, diff = 0.0;
      for (std::size_t i = 0; i < ref.columns[c].size() / 10; ++i)
        for (std::size_t j = first; j < first + count; ++j) {
          scale = std::max(scale, std::abs(ref.columns[c][10 * i + j]));
          diff = std::max(diff, std::abs(x.columns[c][10 * i + j] - ref.columns[c][10 * i + j]));
        }
      if (scale > 0.0) worst = std::max(worst, diff / scale);
    }
  return worst;
}

}  // namespace

TEST_CASE("condensed Newton solve equals the banded LU of the assembled system") {
  double worst = 0.0;
  int cases = 0;
  for (std::uint32_t seed : {1u, 2u, 3u})
    for (bool free_base : {false, true})
      for (bool stiffness : {false, true})
        for (bool nodal : {false, true})
          for (std::size_t loads : {std::size_t{0}, std::size_t{7}}) {
            if (free_base && !stiffness) continue;  // a free base needs the medium's drag
            Case c;
            c.n = 25 + 5 * seed;
            c.free_base = free_base;
            c.stiffness = stiffness;
            c.nodal = nodal;
            c.unit_loads = loads;
            c.seed = seed;
            Problem p(c);
            const Solved ref = p.band();
            const Problem::Condensed got = p.condensed();
            CAPTURE(seed);
            CAPTURE(free_base);
            CAPTURE(stiffness);
            CAPTURE(nodal);
            CAPTURE(loads);
            REQUIRE(got.report.ok);
            const double err = worst_relative(got.solved, ref);
            CHECK(err < 3e-12);  // measured: 2.8e-13 worst
            worst = std::max(worst, err);
            ++cases;
          }
  MESSAGE("condensed vs band LU over " << cases << " cases: worst relative difference " << worst);
}

TEST_CASE("condensed responses at chosen nodes equal the full back-substitution of every column") {
  Case c;
  c.n = 40;
  c.free_base = true;
  c.stiffness = true;
  c.unit_loads = 9;
  Problem p(c);
  const std::vector<std::uint32_t> nodes = {0, 3, 3, 17, 39};
  const Problem::Condensed got = p.condensed(nodes);
  const auto cols = static_cast<std::size_t>(p.columns());
  double worst = 0.0;
  for (std::size_t i = 0; i < nodes.size(); ++i)
    for (std::size_t col = 0; col < cols; ++col)
      for (std::size_t j = 0; j < 6; ++j) {
        const double a = got.responses[i * 6 * cols + 6 * col + j];
        const double b = got.solved.columns[col][10 * nodes[i] + j];
        worst = std::max(worst, std::abs(a - b) / std::max(1.0, std::abs(b)));
      }
  CHECK(worst < 1e-13);
}
