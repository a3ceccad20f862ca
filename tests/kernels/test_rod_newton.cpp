// The Newton system's Jacobian against finite differences of the residual it linearizes.
#include <doctest/doctest.h>

#include "haustra/kernels/block_tridiagonal.hpp"
#include "haustra/kernels/rod_backward_sweep.hpp"
#include "haustra/kernels/rod_newton.hpp"
#include "haustra/kernels/tissue_law.hpp"
#include "measured.hpp"

#include <cmath>
#include "rod_fixture.hpp"

using namespace haustra;
using namespace haustra::kernels;

namespace {

// ρ(q) for the fixture's loads and the law a (q* = 0).
std::vector<double> residual_of(test::RodBuffers& rod, const std::array<double, 4>& a) {
  rod.sweep();
  std::vector<double> r(4 * rod.n), target(4 * rod.n, 0.0), out(4 * rod.n);
  rod_backward_sweep(rod.poses(), rod.h, rod.force(), rod.moment(), StrainView<double>{r});
  rod_strain_residual(StrainView<const double>{r}, StrainView<const double>{rod.strain},
                      StrainView<const double>{target}, rod.h, a, StrainView<double>{out});
  return out;
}

// The mixed system as one dense matrix.
Eigen::MatrixXd dense_system(const std::vector<NewtonBlock>& lo, const std::vector<NewtonBlock>& di,
                             const std::vector<NewtonBlock>& up) {
  const int b = kNewtonBlock;
  const auto n = static_cast<int>(di.size());
  Eigen::MatrixXd big = Eigen::MatrixXd::Zero(n * b, n * b);
  for (int k = 0; k < n; ++k) {
    const auto uk = static_cast<std::size_t>(k);
    big.block(k * b, k * b, b, b) = di[uk];
    if (k > 0) big.block(k * b, (k - 1) * b, b, b) = lo[uk];
    if (k + 1 < n) big.block(k * b, (k + 1) * b, b, b) = up[uk];
  }
  return big;
}

// The Schur complement of the dense system onto the kept rows and columns: the Jacobian of the
// kept equations in the kept unknowns once the others are eliminated.
Eigen::MatrixXd reduce(const Eigen::MatrixXd& big, const std::vector<int>& keep, const std::vector<int>& other) {
  auto sub = [&](const std::vector<int>& r, const std::vector<int>& c) {
    Eigen::MatrixXd m(r.size(), c.size());
    for (std::size_t i = 0; i < r.size(); ++i)
      for (std::size_t j = 0; j < c.size(); ++j)
        m(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = big(r[i], c[j]);
    return m;
  };
  return sub(keep, keep) - sub(keep, other) * sub(other, other).fullPivLu().solve(sub(other, keep));
}

// ∂residual/∂q by central differences, column by column (q restored after each).
template <class Residual>
Eigen::MatrixXd central_differences(std::vector<double>& q, Residual residual, double eps = 1e-6) {
  const auto m = static_cast<Eigen::Index>(q.size());
  Eigen::MatrixXd fd(m, m);
  for (std::size_t j = 0; j < q.size(); ++j) {
    const double q0 = q[j];
    q[j] = q0 + eps;
    const std::vector<double> rp = residual();
    q[j] = q0 - eps;
    const std::vector<double> rm = residual();
    q[j] = q0;
    for (std::size_t i = 0; i < q.size(); ++i)
      fd(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = (rp[i] - rm[i]) / (2 * eps);
  }
  return fd;
}

// The worst 4×4 node block of |J − FD|, each block against its own largest entry (floored at 1e-7
// of the whole matrix's, where finite differences have no digits left): a global scale would not
// see an error in a block whose entries are small.
double worst_block_error(const Eigen::MatrixXd& j, const Eigen::MatrixXd& fd) {
  const double floor = 1e-7 * fd.cwiseAbs().maxCoeff();
  double worst = 0.0;
  for (Eigen::Index r = 0; r < j.rows(); r += 4)
    for (Eigen::Index c = 0; c < j.cols(); c += 4) {
      const Eigen::Index rows = std::min<Eigen::Index>(4, j.rows() - r), cols = std::min<Eigen::Index>(4, j.cols() - c);
      const double scale = std::max(fd.block(r, c, rows, cols).cwiseAbs().maxCoeff(), floor);
      worst = std::max(worst, (j.block(r, c, rows, cols) - fd.block(r, c, rows, cols)).cwiseAbs().maxCoeff() / scale);
    }
  return worst;
}

}  // namespace

TEST_CASE("Newton Jacobian matches finite differences of the residual") {
  for (std::uint32_t seed : {1u, 2u, 3u}) {
    const std::size_t n = 12;
    test::RodBuffers rod(n);
    rod.randomize(seed);
    const std::array<double, 4> a = {0.7, 0.9, 0.5, 30.0};
    const std::vector<double> rho0 = residual_of(rod, a);

    std::vector<NewtonBlock> lo(n), di(n), up(n);
    std::vector<NewtonBlock> fill(n);
    std::vector<std::array<std::uint8_t, kNewtonBlock>> swaps(n);
    std::vector<double> dfx(n), dfy(n), dfz(n), dmx(n), dmy(n), dmz(n);
    rod.sweep();
    rod_newton_assemble(rod.poses(), rod.h, rod.force(), rod.moment(), a, {}, false, {dfx, dfy, dfz}, {dmx, dmy, dmz},
                        {lo, di, up, fill, swaps});

    // The reduced Jacobian ∂ρ/∂q that finite differences measure: eliminate all but the strains.
    const Eigen::MatrixXd big = dense_system(lo, di, up);
    std::vector<int> qi, oi;
    for (int i = 0; i < big.rows(); ++i) (i % kNewtonBlock < 4 ? qi : oi).push_back(i);
    const Eigen::MatrixXd reduced = reduce(big, qi, oi);

    const Eigen::MatrixXd fd = central_differences(rod.strain, [&] { return residual_of(rod, a); });
    const double err = worst_block_error(reduced, fd);
    // The mixed form drops only the O(h²) terms of each half-section's own rotation.
    test::measured(
        "Newton Jacobian vs finite differences, worst 4×4 block over its own scale, seed " + std::to_string(seed), err,
        0.02);
  }
}

namespace {

// The free-base residual: node residuals ρ (drag of the medium included) and the rod's total
// wrench about node 0, as functions of the strains and the base pose.
struct FreeRod {
  test::RodBuffers rod;
  std::vector<double> f0x, f0y, f0z, m0x, m0y, m0z;  // dead loads
  std::vector<double> rx, ry, rz;                    // positions at the substep start
  std::vector<Eigen::Quaterniond> r0;
  std::vector<double> c, s;  // drag rates c/Δt, s/Δt
  Pose base;

  explicit FreeRod(std::size_t n) : rod(n) {}

  std::vector<double> residual(const std::array<double, 4>& a) {
    rod.sweep(base);
    const auto pos = rod.poses().node_position;
    for (std::size_t k = 0; k < rod.n; ++k) {
      const Eigen::Vector3d v = pos.get(k) - Eigen::Vector3d(rx[k], ry[k], rz[k]);
      rod.force().set(k, Eigen::Vector3d(f0x[k], f0y[k], f0z[k]) - c[k] * v);
      const Eigen::Vector3d turn = rotation_log(rod.poses().node_rotation.get(k) * r0[k].conjugate());
      rod.moment().set(k, Eigen::Vector3d(m0x[k], m0y[k], m0z[k]) - s[k] * turn);
    }
    std::vector<double> r(4 * rod.n), target(4 * rod.n, 0.0), out(4 * rod.n);
    const Wrench w = rod_backward_sweep(rod.poses(), rod.h, rod.force(), rod.moment(), StrainView<double>{r});
    rod_strain_residual(StrainView<const double>{r}, StrainView<const double>{rod.strain},
                        StrainView<const double>{target}, rod.h, a, StrainView<double>{out});
    for (int i = 0; i < 3; ++i) out.push_back(w.moment[i]);
    for (int i = 0; i < 3; ++i) out.push_back(w.force[i]);
    return out;
  }
};

}  // namespace

TEST_CASE("Newton Jacobian with the medium's drag and a free base matches finite differences") {
  const std::size_t n = 10;
  FreeRod fr(n);
  fr.rod.randomize(21);
  fr.f0x = fr.rod.fx, fr.f0y = fr.rod.fy, fr.f0z = fr.rod.fz;
  fr.m0x = fr.rod.tx, fr.m0y = fr.rod.ty, fr.m0z = fr.rod.tz;
  fr.base = {rotation_exp(Eigen::Vector3d(0.2, 0.1, -0.3)), Eigen::Vector3d(0.1, 0.2, 0.3)};
  // Start positions: the rod somewhat elsewhere, so the drag loads are not zero.
  fr.rod.sweep(Pose{rotation_exp(Eigen::Vector3d(0.25, 0.05, -0.3)), Eigen::Vector3d(0.12, 0.18, 0.31)});
  fr.rx = fr.rod.px, fr.ry = fr.rod.py, fr.rz = fr.rod.pz;
  for (std::size_t k = 0; k < n; ++k) fr.r0.push_back(fr.rod.poses().node_rotation.get(k));
  fr.c.assign(n, 3.0);
  fr.s.assign(n, 0.02);
  const std::array<double, 4> a = {0.7, 0.9, 0.5, 30.0};
  const std::vector<double> rho0 = fr.residual(a);

  std::vector<NewtonBlock> lo(n), di(n), up(n);
  std::vector<NewtonBlock> fill(n);
  std::vector<std::array<std::uint8_t, kNewtonBlock>> swaps(n);
  std::vector<double> dfx(n), dfy(n), dfz(n), dmx(n), dmy(n), dmz(n);
  std::vector<Eigen::Matrix3d> k(n);
  for (std::size_t i = 0; i < n; ++i) k[i] = fr.c[i] * Eigen::Matrix3d::Identity();
  const Eigen::Matrix<double, 6, 1> total =
      rod_newton_assemble(fr.rod.poses(), fr.rod.h, fr.rod.force(), fr.rod.moment(), a, {k, fr.s}, true,
                          {dfx, dfy, dfz}, {dmx, dmy, dmz}, {lo, di, up, fill, swaps});
  for (int i = 0; i < 6; ++i)
    CHECK(total[i] == doctest::Approx(rho0[4 * n + static_cast<std::size_t>(i)]).epsilon(1e-12));

  // Reduce onto (strains, base rotation, base position): every node residual and the base rows.
  const int b = kNewtonBlock;
  const Eigen::MatrixXd big = dense_system(lo, di, up);
  std::vector<int> keep, other;
  for (int i = 0; i < big.rows(); ++i)
    (i % b < 4 || (i < b && i >= kNewtonRotation && i < kNewtonMoment) ? keep : other).push_back(i);
  const Eigen::MatrixXd reduced = reduce(big, keep, other);

  // Finite differences in the same unknowns and equation order.
  const double eps = 1e-6;
  const auto cols = static_cast<Eigen::Index>(keep.size());
  Eigen::MatrixXd fd(cols, cols);
  auto residual_in_order = [&]() {
    const std::vector<double> r = fr.residual(a);
    Eigen::VectorXd out(cols);
    Eigen::Index row = 0;
    for (int i : keep) {
      const int node = i / b, local = i % b;
      out[row++] = local < 4 ? r[4 * static_cast<std::size_t>(node) + static_cast<std::size_t>(local)]
                             : r[4 * n + static_cast<std::size_t>(local - kNewtonRotation)];
    }
    return out;
  };
  Eigen::Index col = 0;
  for (int i : keep) {
    const int node = i / b, local = i % b;
    auto perturb = [&](double d) {
      if (local < 4) {
        fr.rod.strain[4 * static_cast<std::size_t>(node) + static_cast<std::size_t>(local)] += d;
      } else if (local < kNewtonPosition) {
        fr.base.rotation = rotation_exp(d * Eigen::Vector3d::Unit(local - kNewtonRotation)) * fr.base.rotation;
      } else {
        fr.base.position[local - kNewtonPosition] += d;
      }
    };
    const FreeRod saved = fr;
    perturb(eps);
    const Eigen::VectorXd rp = residual_in_order();
    fr = saved;
    perturb(-eps);
    const Eigen::VectorXd rm = residual_in_order();
    fr = saved;
    fd.col(col++) = (rp - rm) / (2 * eps);
  }
  const double err = worst_block_error(reduced, fd);
  test::measured("Newton Jacobian with drag and a free base vs finite differences, worst block over its own scale", err,
                 0.02);
}

namespace {

// ρ(q) = R − M s(q) for an EXP2 tube (kernels/tissue_law), and s's tangent.
struct Exp2Rod {
  test::RodBuffers rod;
  NodalLaw law;
  std::vector<double> rest, start, stress, tangent, coupling;
  explicit Exp2Rod(std::size_t n)
      : rod(n), rest(4 * n, 0.0), start(4 * n, 0.0), stress(4 * n), tangent(4 * n), coupling(n) {
    law.stiffness = {0.85, 0.85, 0.6, 19.0};  // torsion Hooke's; the others replaced by EXP2
    law.rate = {0.3, 0.3, 0.0, 0.0};          // a Kelvin–Voigt bend
    law.exp2 = true;
    law.tissue = {8.0, 50.0, 100.0};
    law.tube = {0.3, 0.1};
    for (std::size_t i = 0; i < 4 * n; ++i) rest[i] = 0.2 * std::sin(static_cast<double>(i));
  }
  std::vector<double> residual() {
    rod.sweep();
    nodal_law_evaluate(StrainView<const double>{rod.strain}, StrainView<const double>{rest},
                       StrainView<const double>{start}, law, StrainView<double>{stress}, StrainView<double>{tangent},
                       coupling);
    std::vector<double> r(4 * rod.n), out(4 * rod.n);
    rod_backward_sweep(rod.poses(), rod.h, rod.force(), rod.moment(), StrainView<double>{r});
    rod_stress_residual(StrainView<const double>{r}, StrainView<const double>{stress}, rod.h, StrainView<double>{out});
    return out;
  }
};

}  // namespace

TEST_CASE("Newton Jacobian with the EXP2 law's nodal tangent matches finite differences of the residual") {
  for (std::uint32_t seed : {4u, 5u}) {
    const std::size_t n = 10;
    Exp2Rod er(n);
    er.rod.randomize(seed);
    (void)er.residual();  // the tangent at this iterate
    std::vector<NewtonBlock> lo(n), di(n), up(n);
    std::vector<NewtonBlock> fill(n);
    std::vector<std::array<std::uint8_t, kNewtonBlock>> swaps(n);
    std::vector<double> dfx(n), dfy(n), dfz(n), dmx(n), dmy(n), dmz(n);
    rod_newton_assemble(er.rod.poses(), er.rod.h, er.rod.force(), er.rod.moment(), {1.0, 1.0, 1.0, 1.0}, {}, false,
                        {dfx, dfy, dfz}, {dmx, dmy, dmz}, {lo, di, up, fill, swaps},
                        {StrainView<const double>{er.tangent}, er.coupling});
    const Eigen::MatrixXd big = dense_system(lo, di, up);
    std::vector<int> qi, oi;
    for (int i = 0; i < big.rows(); ++i) (i % kNewtonBlock < 4 ? qi : oi).push_back(i);
    const Eigen::MatrixXd reduced = reduce(big, qi, oi);

    Eigen::MatrixXd fd = central_differences(er.rod.strain, [&] { return er.residual(); });
    // Each 4×4 block against its own scale, as for the linear law (a global scale, the law's stiff
    // rows, would not see an error in the loads' small blocks: it measured 1.5e-7 to 3.5e-7 of it).
    test::measured(
        "Newton Jacobian with the EXP2 law vs finite differences, worst 4×4 block over its own scale, seed " +
            std::to_string(seed),
        worst_block_error(reduced, fd), 0.02);  // measured 0.0026, 0.0076
    // With the loads removed the residual is −M s(q) alone: its Jacobian −M T must match to FD accuracy.
    er.rod.clear_loads();
    (void)er.residual();
    rod_newton_assemble(er.rod.poses(), er.rod.h, er.rod.force(), er.rod.moment(), {1.0, 1.0, 1.0, 1.0}, {}, false,
                        {dfx, dfy, dfz}, {dmx, dmy, dmz}, {lo, di, up, fill, swaps},
                        {StrainView<const double>{er.tangent}, er.coupling});
    const Eigen::MatrixXd law_only = reduce(dense_system(lo, di, up), qi, oi);
    fd = central_differences(er.rod.strain, [&] { return er.residual(); });
    const double law_err = (law_only - fd).cwiseAbs().maxCoeff();
    INFO("law alone: max |J − FD| = " << law_err << " of max |FD| " << fd.cwiseAbs().maxCoeff());
    CHECK(law_err < 2e-9 * fd.cwiseAbs().maxCoeff());  // measured 1.3e-10, 2.5e-10: central differences
  }
}
