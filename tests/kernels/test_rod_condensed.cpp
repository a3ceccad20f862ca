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

  explicit Problem(const Case& c)
      : cs(c), rod(c.n), residual(4 * c.n), tangent(4 * c.n), coupling(c.n), k(c.n), s(c.n) {
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
  RodLinearization linearization(double law_scale = 1.0) {
    RodLinearization lin;
    lin.law_scale = law_scale;
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
  // dense: the plain reference instead — the same blocks written into one dense matrix, solved by
  // Eigen's partially pivoted LU (nothing of the band's or the sweep's bookkeeping). law_scale:
  // the law's rows scaled as RodLinearization::law_scale scales them.
  Solved band(bool dense = false, double law_scale = 1.0) {
    const std::size_t n = cs.n;
    const int cols = columns();
    constexpr int B = kNewtonBlock;
    std::vector<NewtonBlock> lo(n), di(n), up(n), fill(n);
    std::vector<std::array<std::uint8_t, B>> swaps(n);
    std::vector<double> dfx(n), dfy(n), dfz(n), dmx(n), dmy(n), dmz(n);
    std::array<double, 4> scaled = a;
    for (double& x : scaled) x *= law_scale;
    std::vector<double> scaled_tangent = tangent, scaled_coupling = coupling;
    for (double& x : scaled_tangent) x *= law_scale;
    for (double& x : scaled_coupling) x *= law_scale;
    const NodalLawTangent law =
        cs.nodal ? NodalLawTangent{StrainView<const double>{scaled_tangent}, scaled_coupling} : NodalLawTangent{};
    const Eigen::Matrix<double, 6, 1> wrench =
        rod_newton_assemble(rod.poses(), rod.h, rod.force(), rod.moment(), scaled, stiffness(), cs.free_base,
                            {dfx, dfy, dfz}, {dmx, dmy, dmz}, {lo, di, up, fill, swaps}, law);
    Eigen::MatrixXd matrix;
    if (dense) {
      const auto size = static_cast<Eigen::Index>(n * B);
      matrix = Eigen::MatrixXd::Zero(size, size);
      for (std::size_t i = 0; i < n; ++i) {
        const auto row = static_cast<Eigen::Index>(i * B);
        if (i > 0) matrix.block<B, B>(row, row - B) = lo[i];
        matrix.block<B, B>(row, row) = di[i];
        if (i + 1 < n) matrix.block<B, B>(row, row + B) = up[i];
      }
    } else {
      block_tridiagonal_factor<B>({lo, di, up, fill, swaps});
    }
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
    if (dense) {
      const Eigen::PartialPivLU<Eigen::MatrixXd> lu(matrix);
      const auto size = static_cast<Eigen::Index>(n * B);
      for (int c = 0; c < cols; ++c) {
        Eigen::VectorXd b(size);
        for (std::size_t i = 0; i < n; ++i)
          for (int r = 0; r < B; ++r) b[static_cast<Eigen::Index>(i * B) + r] = entry(i, r, c);
        const Eigen::VectorXd z = lu.solve(b);
        for (std::size_t i = 0; i < n; ++i)
          for (int r = 0; r < B; ++r) entry(i, r, c) = z[static_cast<Eigen::Index>(i * B) + r];
      }
    } else {
      block_tridiagonal_solve<B>({lo, di, up, fill, swaps}, rhs, cols);
    }
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
    std::vector<double> responses;   // at `nodes`, 6 × columns each
    std::vector<double> gain, base;  // what the sweep wrote: the gains U_k and y_0 of every column
  };
  Condensed condensed(const std::vector<std::uint32_t>& nodes = {}, double law_scale = 1.0) {
    const std::size_t n = cs.n;
    const int cols = columns();
    std::vector<double> gain(condensed_gain_size(n, cols)), scratch(condensed_scratch_size(cols)),
        base(10 * static_cast<std::size_t>(cols));
    const CondensedSystem sys{gain, scratch, base, cols, {}};
    const RodLinearization lin = linearization(law_scale);
    Condensed out;
    out.report = rod_condense(lin, StrainView<const double>{residual}, loads, sys);
    out.gain = gain;
    out.base = base;
    std::vector<double> dq(4 * n), px(n), py(n), pz(n), rx(n), ry(n), rz(n);
    for (int c = 0; c < cols; ++c) {
      std::vector<double> weights(static_cast<std::size_t>(cols), 0.0);
      weights[static_cast<std::size_t>(c)] = 1.0;
      rod_condensed_step(lin, sys, weights, StrainView<double>{dq}, {px, py, pz}, {rx, ry, rz});
      std::vector<double> v(10 * n);
      for (std::size_t i = 0; i < n; ++i) {
        const double y[10] = {px[i], py[i],     pz[i],         rx[i],         ry[i],
                              rz[i], dq[4 * i], dq[4 * i + 1], dq[4 * i + 2], dq[4 * i + 3]};
        std::copy(y, y + 10, v.begin() + static_cast<std::ptrdiff_t>(10 * i));
      }
      out.solved.columns.push_back(std::move(v));
    }
    out.responses.resize(nodes.size() * 6 * static_cast<std::size_t>(cols));
    rod_condensed_responses(lin, sys, nodes, out.responses);
    return out;
  }
};

// The same solve split at node m: both parts condensed apart, joined, then back-substituted —
// every column's solution at every node (as `condensed`) and its responses at `nodes`.
// affine: the tip part's responses made before the join (from y_m = 0 and the ten unit starts) and
// folded with y_m after it (rod_condensed_tip_responses, rod_condensed_tip_fold; decision 0087).
Problem::Condensed split_solve(Problem& p, std::size_t m, const std::vector<std::uint32_t>& nodes,
                               bool affine = false) {
  const std::size_t n = p.cs.n;
  const int cols = p.columns();
  const auto C = static_cast<std::size_t>(cols);
  const RodLinearization lin = p.linearization();
  // The parts' loads and columns.
  std::vector<UnitLoad> base_loads(p.loads.size());
  std::vector<int> tip_column(C), base_column(C);
  const auto [tip_count, base_cols] = rod_condensed_split_loads(p.loads, cols, m, base_loads, tip_column, base_column);
  base_loads.resize(p.loads.size() - tip_count);
  const auto BC = static_cast<std::size_t>(base_cols);
  std::vector<double> tip_gain(condensed_gain_size(n - m, cols)), tip_scratch(condensed_scratch_size(cols)),
      tip_base(10 * C), interface(10 * static_cast<std::size_t>(condensed_width(cols)));
  std::vector<double> base_gain(condensed_gain_size(m, base_cols)), base_scratch(condensed_scratch_size(base_cols)),
      base_base(10 * BC);
  const CondensedSystem tip{tip_gain, tip_scratch, tip_base, cols, {}};
  const CondensedSystem base{base_gain, base_scratch, base_base, base_cols, {}};
  const std::span<const UnitLoad> tip_loads(p.loads.data(), tip_count);
  Problem::Condensed out;
  out.report =
      rod_condense_range(lin, StrainView<const double>{p.residual}, tip_loads, tip, {m, n - 1, false, interface});
  REQUIRE(out.report.ok);
  std::vector<std::uint32_t> tip_listed;
  for (std::uint32_t k : nodes)
    if (k > m) tip_listed.push_back(k);
  std::vector<double> tip_particular(tip_listed.size() * 6 * C), tip_unit(tip_listed.size() * 60);
  if (affine) rod_condensed_tip_responses(lin, tip, m, tip_listed, tip_particular, tip_unit);
  out.report = rod_condense_range(lin, StrainView<const double>{p.residual}, base_loads, base, {0, m, true, {}});
  REQUIRE(out.report.ok);
  // The base part back-substituted to the joint (raw responses at its nodes on the way), the join.
  std::vector<std::uint32_t> base_nodes, tip_nodes;
  for (std::uint32_t k : nodes) (k <= m ? base_nodes : tip_nodes).push_back(k);
  std::vector<double> raw(base_nodes.size() * 6 * BC), at_joint(10 * BC), lambda(10 * C), y_joint(10 * C);
  rod_condensed_responses_range(lin, base, 0, m, base_base, base_nodes, raw, at_joint);
  REQUIRE(rod_condensed_join(lin, m, {interface, cols, at_joint, base_cols, tip_column, base_column}, lambda, y_joint));
  // Responses: the base part's folded with λ, the tip part's from y_m.
  out.responses.resize(nodes.size() * 6 * C);
  rod_condensed_base_responses(raw, base_cols, base_column, lambda, base_nodes.size(), out.responses);
  if (affine)
    rod_condensed_tip_fold(tip_particular, tip_unit, y_joint, cols, tip_nodes.size(),
                           std::span<double>(out.responses).subspan(base_nodes.size() * 6 * C));
  else
    rod_condensed_responses_range(lin, tip, m, n - 1, y_joint, tip_nodes,
                                  std::span<double>(out.responses).subspan(base_nodes.size() * 6 * C), {});
  // Every column's step.
  std::vector<double> dq(4 * n), px(n), py(n), pz(n), rx(n), ry(n), rz(n), base_weights(BC);
  for (int c = 0; c < cols; ++c) {
    std::vector<double> weights(C, 0.0);
    weights[static_cast<std::size_t>(c)] = 1.0;
    double base_start[10], tip_start[10];
    rod_condensed_split_step(weights, lambda, y_joint, base_column, base_base, base_cols, base_start, base_weights,
                             tip_start);
    rod_condensed_step_range(lin, base, 0, m, base_start, base_weights, StrainView<double>{dq}, {px, py, pz},
                             {rx, ry, rz});
    rod_condensed_step_range(lin, tip, m, n - 1, tip_start, weights, StrainView<double>{dq}, {px, py, pz},
                             {rx, ry, rz});
    std::vector<double> v(10 * n);
    for (std::size_t i = 0; i < n; ++i) {
      const double y[10] = {px[i], py[i],     pz[i],         rx[i],         ry[i],
                            rz[i], dq[4 * i], dq[4 * i + 1], dq[4 * i + 2], dq[4 * i + 3]};
      std::copy(y, y + 10, v.begin() + static_cast<std::ptrdiff_t>(10 * i));
    }
    out.solved.columns.push_back(std::move(v));
  }
  return out;
}

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

// A rod of `n` nodes with stiffness, the base clamped or free, Hooke's or a nodal law, `loads` unit
// loads (the split tests' at 61 nodes, the chord replay's at 33).
namespace {
Case stiff_case(std::uint32_t seed, bool free_base, bool nodal, std::size_t loads, std::size_t n = 61) {
  Case c;
  c.n = n;
  c.free_base = free_base;
  c.stiffness = true;
  c.nodal = nodal;
  c.unit_loads = loads;
  c.seed = seed;
  return c;
}
}  // namespace

TEST_CASE("a rod split at a joint node, its parts condensed apart and joined, equals the whole rod's sweep") {
  double worst = 0.0, worst_responses = 0.0;
  int cases = 0;
  for (std::uint32_t seed : {4u, 5u})
    for (bool free_base : {false, true})
      for (bool nodal : {false, true})
        for (std::size_t loads : {std::size_t{0}, std::size_t{9}}) {
          Problem p(stiff_case(seed, free_base, nodal, loads));
          const std::vector<std::uint32_t> nodes = {0, 5, 23, 24, 25, 40, 60};
          const Problem::Condensed whole = p.condensed(nodes);
          for (std::size_t m : {std::size_t{1}, std::size_t{24}, std::size_t{59}}) {
            CAPTURE(seed);
            CAPTURE(free_base);
            CAPTURE(nodal);
            CAPTURE(loads);
            CAPTURE(m);
            const Problem::Condensed split = split_solve(p, m, nodes);
            const double err = worst_relative(split.solved, whole.solved);
            CHECK(err < 2e-12);  // measured: 2.0e-13
            worst = std::max(worst, err);
            double scale = 0.0, diff = 0.0;
            for (std::size_t i = 0; i < whole.responses.size(); ++i) {
              scale = std::max(scale, std::abs(whole.responses[i]));
              diff = std::max(diff, std::abs(split.responses[i] - whole.responses[i]));
            }
            CHECK(diff < 1e-13 * scale);  // measured: 5.7e-15
            worst_responses = std::max(worst_responses, diff / scale);
            ++cases;
          }
        }
  MESSAGE("split vs whole over " << cases << " cases: worst relative difference " << worst << ", responses "
                                 << worst_responses);
}

TEST_CASE("a split rod's tip responses made before the join and folded with y_m equal the back-substitution from y_m") {
  // The oracles: today's path (the tip part back-substituted from the joined y_m) and the whole
  // rod's unsplit sweep. Responses at nodes on both sides, the joint's neighbours and the tip.
  double worst_path = 0.0, worst_whole = 0.0;
  int cases = 0;
  for (std::uint32_t seed : {8u, 9u})
    for (bool free_base : {false, true})
      for (bool nodal : {false, true})
        for (std::size_t loads : {std::size_t{0}, std::size_t{9}, std::size_t{17}}) {
          Problem p(stiff_case(seed, free_base, nodal, loads));
          const std::vector<std::uint32_t> nodes = {0, 5, 23, 24, 25, 25, 40, 59, 60};
          const Problem::Condensed whole = p.condensed(nodes);
          for (std::size_t m : {std::size_t{1}, std::size_t{24}, std::size_t{30}, std::size_t{59}}) {
            CAPTURE(seed);
            CAPTURE(free_base);
            CAPTURE(nodal);
            CAPTURE(loads);
            CAPTURE(m);
            const Problem::Condensed path = split_solve(p, m, nodes);
            const Problem::Condensed affine = split_solve(p, m, nodes, true);
            double scale = 0.0, to_path = 0.0, to_whole = 0.0;
            for (std::size_t i = 0; i < whole.responses.size(); ++i) {
              scale = std::max(scale, std::abs(whole.responses[i]));
              to_path = std::max(to_path, std::abs(affine.responses[i] - path.responses[i]));
              to_whole = std::max(to_whole, std::abs(affine.responses[i] - whole.responses[i]));
            }
            CHECK(to_path < 5e-15 * scale);   // measured: 9.5e-16
            CHECK(to_whole < 1e-13 * scale);  // measured: 1.3e-14 (today's path: the same)
            worst_path = std::max(worst_path, to_path / scale);
            worst_whole = std::max(worst_whole, to_whole / scale);
            ++cases;
          }
        }
  MESSAGE("affine tip responses over " << cases << " cases: worst relative difference to today's path " << worst_path
                                       << ", to the whole rod " << worst_whole);
}

TEST_CASE("a chord iteration's replay solves the recorded Jacobian with a new residual") {
  double worst_same = 0.0, worst_new = 0.0;
  for (std::uint32_t seed : {6u, 7u})
    for (bool free_base : {false, true})
      for (std::size_t loads : {std::size_t{0}, std::size_t{5}}) {
        const Case c = stiff_case(seed, free_base, false, loads, 33);
        Problem p(c);
        const std::size_t n = c.n;
        const int cols = p.columns();
        std::vector<double> gain(condensed_gain_size(n, cols)), scratch(condensed_scratch_size(cols)),
            base(10 * static_cast<std::size_t>(cols)), record(condensed_record_size(n));
        CondensedSystem sys{gain, scratch, base, cols, record};
        const RodLinearization lin = p.linearization();
        REQUIRE(rod_condense(lin, StrainView<const double>{p.residual}, p.loads, sys).ok);
        auto column = [&](CondensedSystem& s, int col) {
          std::vector<double> dq(4 * n), px(n), py(n), pz(n), rx(n), ry(n), rz(n),
              w(static_cast<std::size_t>(cols), 0.0);
          w[static_cast<std::size_t>(col)] = 1.0;
          rod_condensed_step(lin, s, w, StrainView<double>{dq}, {px, py, pz}, {rx, ry, rz});
          std::vector<double> v(10 * n);
          for (std::size_t i = 0; i < n; ++i) {
            const double y[10] = {px[i], py[i],     pz[i],         rx[i],         ry[i],
                                  rz[i], dq[4 * i], dq[4 * i + 1], dq[4 * i + 2], dq[4 * i + 3]};
            std::copy(y, y + 10, v.begin() + static_cast<std::ptrdiff_t>(10 * i));
          }
          return v;
        };
        const std::vector<double> swept = column(sys, 0);
        std::vector<std::vector<double>> units;
        for (int col = 1; col < cols; ++col) units.push_back(column(sys, col));
        // The same residual again: the replay reproduces the sweep's column.
        rod_condensed_resweep(lin, StrainView<const double>{p.residual}, sys);
        const std::vector<double> replayed = column(sys, 0);
        double scale = 0.0, diff = 0.0;
        for (std::size_t i = 0; i < swept.size(); ++i) {
          scale = std::max(scale, std::abs(swept[i]));
          diff = std::max(diff, std::abs(replayed[i] - swept[i]));
        }
        worst_same = std::max(worst_same, diff / scale);
        // A new residual: the old Jacobian's solve of it (the band LU of the same assembly), and
        // the unit-load columns untouched.
        std::mt19937 rng(seed + 50);
        std::uniform_real_distribution<double> u(-1.0, 1.0);
        for (double& r : p.residual) r = u(rng);
        rod_condensed_resweep(lin, StrainView<const double>{p.residual}, sys);
        const std::vector<double> chord = column(sys, 0);
        const Solved ref = p.band();
        Solved got;
        got.columns.push_back(chord);
        Solved ref0;
        ref0.columns.push_back(ref.columns[0]);
        worst_new = std::max(worst_new, worst_relative(got, ref0));
        for (int col = 1; col < cols; ++col) CHECK(column(sys, col) == units[static_cast<std::size_t>(col - 1)]);
      }
  MESSAGE("replay against the sweep: " << worst_same << "; against the band LU with a new residual: " << worst_new);
  CHECK(worst_same == 0.0);    // the replay rounds as the sweep did: the same bits
  CHECK(worst_new < 2.5e-13);  // measured: 2.3e-14
}

TEST_CASE("four rods condensed in SIMD lanes equal the one-rod sweep, rod by rod") {
  // Four rods of one node count, each its own: clamped and free bases, linear and nonlinear laws,
  // their own poses, loads and residuals (the lanes share only the node count).
  double worst = 0.0;
  std::size_t differing = 0, compared = 0;
  for (bool stiffness : {true, false}) {
    std::vector<Problem> problems;
    for (std::uint32_t i = 0; i < 4; ++i) {
      Case c;
      c.n = 37;
      c.seed = 20 + i;
      c.stiffness = stiffness;
      c.free_base = stiffness && i % 2 == 1;
      c.nodal = i >= 2;
      problems.emplace_back(c);
    }
    std::array<std::vector<double>, 4> gain, scratch, base;
    std::array<const RodLinearization*, kCondensedLanes> rods{};
    std::array<StrainView<const double>, kCondensedLanes> residuals{};
    std::array<CondensedSystem, kCondensedLanes> systems{};
    std::array<RodLinearization, 4> lin;
    for (std::size_t i = 0; i < 4; ++i) {
      gain[i].assign(condensed_gain_size(37, 1), 0.0);
      scratch[i].assign(condensed_scratch_size(1), 0.0);
      base[i].assign(10, 0.0);
      lin[i] = problems[i].linearization();
      rods[i] = &lin[i];
      residuals[i] = StrainView<const double>{problems[i].residual};
      systems[i] = {gain[i], scratch[i], base[i], 1, {}};
    }
    std::array<CondenseReport, kCondensedLanes> reports{};
    rod_condense_lanes(rods, residuals, systems, reports);
    for (std::size_t i = 0; i < 4; ++i) {
      CAPTURE(i);
      REQUIRE(reports[i].ok);
      std::vector<double> g(condensed_gain_size(37, 1)), sc(condensed_scratch_size(1)), b(10);
      const CondenseReport one = rod_condense(lin[i], residuals[i], {}, {g, sc, b, 1, {}});
      REQUIRE(one.ok);
      CHECK(reports[i].smallest_pivot == doctest::Approx(one.smallest_pivot));
      double scale = 0.0;
      for (double v : g) scale = std::max(scale, std::abs(v));
      for (std::size_t e = 0; e < g.size(); ++e) {
        worst = std::max(worst, std::abs(gain[i][e] - g[e]) / scale);
        differing += gain[i][e] != g[e] ? 1 : 0;
        ++compared;
      }
      for (std::size_t e = 0; e < 10; ++e) {
        worst = std::max(worst, std::abs(base[i][e] - b[e]) / std::max(1e-300, std::abs(b[e])));
        differing += base[i][e] != b[e] ? 1 : 0;
        ++compared;
      }
    }
  }
  MESSAGE("lanes against one rod: " << differing << " of " << compared << " numbers differ, at most " << worst
                                    << " relative");
  // The same bits: both sweeps round every product and sum alike (contraction off, their fused
  // multiply-adds in the same places), so a rod's result cannot depend on its lane-mates.
  CHECK(differing == 0);
}

namespace {

// How far a sweep's own outputs are from the reference solution `ref` (every column at every node):
// y_0 of every column (sys.base), and each gain's action δq_{k+1} = U_k (y_k, 1) on the reference's
// y_k — each relative to its column's largest δφ, δr or δq.
struct GainError {
  double base = 0.0, gain = 0.0;
};
GainError sweep_against(const Solved& ref, std::span<const double> gain, std::span<const double> base, int cols) {
  GainError err;
  const std::size_t w = static_cast<std::size_t>(condensed_width(cols)), n = ref.columns[0].size() / 10;
  for (std::size_t c = 0; c < ref.columns.size(); ++c) {
    const std::vector<double>& y = ref.columns[c];
    double scale = 0.0, q_scale = 0.0;
    for (std::size_t i = 0; i < y.size(); ++i) {
      scale = std::max(scale, std::abs(y[i]));
      if (i % 10 >= 6) q_scale = std::max(q_scale, std::abs(y[i]));
    }
    for (std::size_t i = 0; i < 10; ++i) err.base = std::max(err.base, std::abs(base[10 * c + i] - y[i]) / scale);
    for (std::size_t k = 0; k + 1 < n; ++k)
      for (std::size_t r = 0; r < 4; ++r) {
        const double* u = gain.data() + (4 * k + r) * w;
        double v = u[static_cast<std::size_t>(kCondensedRhs) + c];
        for (std::size_t i = 0; i < 10; ++i) v += u[i] * y[10 * k + i];
        err.gain = std::max(err.gain, std::abs(v - y[10 * (k + 1) + 6 + r]) / q_scale);
      }
  }
  return err;
}

}  // namespace

TEST_CASE("the condensed sweep, one rod and four in lanes, against the plain reference: a dense LU of the system") {
  // One rod: clamped and free, with and without load stiffness, linear and nonlinear laws, the
  // residual alone (16-lane rows) and with unit loads (24-lane rows), the law's rows scaled.
  double worst = 0.0, worst_base = 0.0, worst_gain = 0.0;
  int cases = 0;
  for (std::uint32_t seed : {11u, 12u})
    for (bool free_base : {false, true})
      for (bool nodal : {false, true})
        for (std::size_t loads : {std::size_t{0}, std::size_t{7}})
          for (double law_scale : {1.0, 4.0}) {
            Case c;
            c.n = 18 + 4 * seed % 7;
            c.free_base = free_base;
            c.stiffness = free_base || seed == 12u;
            c.nodal = nodal;
            c.unit_loads = loads;
            c.seed = seed;
            Problem p(c);
            CAPTURE(seed);
            CAPTURE(free_base);
            CAPTURE(nodal);
            CAPTURE(loads);
            CAPTURE(law_scale);
            const Solved ref = p.band(true, law_scale);
            const Problem::Condensed got = p.condensed({}, law_scale);
            REQUIRE(got.report.ok);
            const double err = worst_relative(got.solved, ref);
            const GainError own = sweep_against(ref, got.gain, got.base, p.columns());
            CHECK(err < 4e-13);         // measured: 4.7e-14
            CHECK(own.base < 2.5e-13);  // measured: 2.5e-14
            CHECK(own.gain < 4e-13);    // measured: 4.2e-14
            worst = std::max(worst, err);
            worst_base = std::max(worst_base, own.base);
            worst_gain = std::max(worst_gain, own.gain);
            ++cases;
          }
  MESSAGE("one rod against the dense reference over " << cases << " cases: steps " << worst << ", y_0 " << worst_base
                                                      << ", gains " << worst_gain);

  // Four rods in lanes (the residual alone), each against its own dense reference.
  double worst_lanes = 0.0, worst_lanes_own = 0.0;
  for (bool stiffness : {true, false}) {
    std::vector<Problem> problems;
    for (std::uint32_t i = 0; i < 4; ++i) {
      Case c;
      c.n = 29;
      c.seed = 40 + i;
      c.stiffness = stiffness;
      c.free_base = stiffness && i % 2 == 0;
      c.nodal = i % 3 == 1;
      problems.emplace_back(c);
    }
    std::array<std::vector<double>, 4> gain, scratch, base;
    std::array<const RodLinearization*, kCondensedLanes> rods{};
    std::array<StrainView<const double>, kCondensedLanes> residuals{};
    std::array<CondensedSystem, kCondensedLanes> systems{};
    std::array<RodLinearization, 4> lin;
    for (std::size_t i = 0; i < 4; ++i) {
      gain[i].assign(condensed_gain_size(29, 1), 0.0);
      scratch[i].assign(condensed_scratch_size(1), 0.0);
      base[i].assign(10, 0.0);
      lin[i] = problems[i].linearization();
      rods[i] = &lin[i];
      residuals[i] = StrainView<const double>{problems[i].residual};
      systems[i] = {gain[i], scratch[i], base[i], 1, {}};
    }
    std::array<CondenseReport, kCondensedLanes> reports{};
    rod_condense_lanes(rods, residuals, systems, reports);
    for (std::size_t i = 0; i < 4; ++i) {
      CAPTURE(stiffness);
      CAPTURE(i);
      REQUIRE(reports[i].ok);
      const Solved ref = problems[i].band(true);
      std::vector<double> dq(4 * 29), px(29), py(29), pz(29), rx(29), ry(29), rz(29);
      const std::vector<double> one = {1.0};
      rod_condensed_step(lin[i], systems[i], one, StrainView<double>{dq}, {px, py, pz}, {rx, ry, rz});
      Solved got;
      got.columns.emplace_back(10 * 29);
      for (std::size_t k = 0; k < 29; ++k) {
        const double y[10] = {px[k], py[k],     pz[k],         rx[k],         ry[k],
                              rz[k], dq[4 * k], dq[4 * k + 1], dq[4 * k + 2], dq[4 * k + 3]};
        std::copy(y, y + 10, got.columns[0].begin() + static_cast<std::ptrdiff_t>(10 * k));
      }
      const double err = worst_relative(got, ref);
      const GainError own = sweep_against(ref, gain[i], base[i], 1);
      CHECK(err < 3e-13);                             // measured: 3.6e-14
      CHECK(std::max(own.base, own.gain) < 2.5e-13);  // measured: 2.5e-14
      worst_lanes = std::max(worst_lanes, err);
      worst_lanes_own = std::max(worst_lanes_own, std::max(own.base, own.gain));
    }
  }
  MESSAGE("four rods in lanes against the dense reference: steps " << worst_lanes << ", y_0 and gains "
                                                                   << worst_lanes_own);
}

TEST_CASE("the condensed sweep's compile-time row strides give the run-time stride's bits") {
  // rod_condense sweeps rows of 16 to 40 doubles with the stride fixed at compile time and wider
  // rows with a run-time stride. The same rod and loads with 27 more columns that carry no load
  // (zero columns: 44 doubles and more, the run-time form) must give the same bits in every gain
  // and y_0 of the real columns — each column's arithmetic is its own.
  int cases = 0;
  for (bool free_base : {false, true})
    for (std::size_t loads : {0, 3, 7, 11, 15, 19, 23}) {
      Case c;
      c.n = 29;
      c.free_base = free_base;
      c.stiffness = true;
      c.nodal = !free_base;
      c.unit_loads = loads;
      c.seed = 21;
      Problem p(c);
      const RodLinearization lin = p.linearization();
      const int cols = p.columns(), wide = cols + 27;
      const auto s = static_cast<std::size_t>(condensed_width(cols));
      const auto sw = static_cast<std::size_t>(condensed_width(wide));
      CAPTURE(free_base);
      CAPTURE(loads);
      REQUIRE(sw > 40);
      auto solve = [&](int columns) {
        std::vector<double> gain(condensed_gain_size(c.n, columns)), scratch(condensed_scratch_size(columns)),
            base(10 * static_cast<std::size_t>(columns));
        const CondenseReport r =
            rod_condense(lin, StrainView<const double>{p.residual}, p.loads, {gain, scratch, base, columns, {}});
        REQUIRE(r.ok);
        return std::pair{gain, base};
      };
      const auto [gain, base] = solve(cols);
      const auto [gain_wide, base_wide] = solve(wide);
      int differ = 0;
      for (std::size_t k = 0; k + 1 < c.n; ++k)
        for (std::size_t r = 0; r < 4; ++r)
          for (std::size_t lane = 0; lane < static_cast<std::size_t>(kCondensedRhs + cols); ++lane)
            differ += gain[(4 * k + r) * s + lane] != gain_wide[(4 * k + r) * sw + lane];
      for (std::size_t i = 0; i < 10 * static_cast<std::size_t>(cols); ++i) differ += base[i] != base_wide[i];
      CHECK(differ == 0);
      ++cases;
    }
  MESSAGE("compile-time strides against the run-time stride: " << cases << " cases, same bits");
}
