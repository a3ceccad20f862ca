// The Newton system's Jacobian against finite differences of the residual it linearizes.
#include <doctest/doctest.h>

#include "haustra/kernels/block_tridiagonal.hpp"
#include "haustra/kernels/rod_backward_sweep.hpp"
#include "haustra/kernels/rod_newton.hpp"
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

}  // namespace

TEST_CASE("Newton Jacobian matches finite differences of the residual") {
  for (std::uint32_t seed : {1u, 2u, 3u}) {
    const std::size_t n = 12;
    test::RodBuffers rod(n);
    rod.randomize(seed);
    const std::array<double, 4> a = {0.7, 0.9, 0.5, 30.0};
    const std::vector<double> rho0 = residual_of(rod, a);

    std::vector<NewtonBlock> lo(n), di(n), up(n);
    std::vector<Eigen::PartialPivLU<NewtonBlock>> piv(n);
    std::vector<double> dfx(n), dfy(n), dfz(n), dmx(n), dmy(n), dmz(n);
    rod.sweep();
    rod_newton_assemble(rod.poses(), rod.h, rod.force(), rod.moment(), a, {}, false, {dfx, dfy, dfz},
                        {dmx, dmy, dmz}, {lo, di, up, piv});

    // Dense Jacobian of the mixed system, and its Schur complement onto the strains: the reduced
    // Jacobian ∂ρ/∂q that finite differences measure.
    const int b = kNewtonBlock;
    const int dim = static_cast<int>(n) * b;
    Eigen::MatrixXd big = Eigen::MatrixXd::Zero(dim, dim);
    for (std::size_t k = 0; k < n; ++k) {
      const int r0 = static_cast<int>(k) * b;
      big.block(r0, r0, b, b) = di[k];
      if (k > 0) big.block(r0, r0 - b, b, b) = lo[k];
      if (k + 1 < n) big.block(r0, r0 + b, b, b) = up[k];
    }
    std::vector<int> qi, oi;
    for (int i = 0; i < dim; ++i) (i % b < 4 ? qi : oi).push_back(i);
    auto sub = [&](const std::vector<int>& r, const std::vector<int>& c) {
      Eigen::MatrixXd m(r.size(), c.size());
      for (std::size_t i = 0; i < r.size(); ++i)
        for (std::size_t j = 0; j < c.size(); ++j) m(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = big(r[i], c[j]);
      return m;
    };
    const Eigen::MatrixXd jqq = sub(qi, qi), jqo = sub(qi, oi), joq = sub(oi, qi), joo = sub(oi, oi);
    const Eigen::MatrixXd reduced = jqq - jqo * joo.fullPivLu().solve(joq);

    // Central differences, column by column.
    const double eps = 1e-6;
    Eigen::MatrixXd fd(4 * n, 4 * n);
    for (std::size_t j = 0; j < 4 * n; ++j) {
      const double q0 = rod.strain[j];
      rod.strain[j] = q0 + eps;
      const std::vector<double> rp = residual_of(rod, a);
      rod.strain[j] = q0 - eps;
      const std::vector<double> rm = residual_of(rod, a);
      rod.strain[j] = q0;
      for (std::size_t i = 0; i < 4 * n; ++i)
        fd(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = (rp[i] - rm[i]) / (2 * eps);
    }
    const double scale = fd.cwiseAbs().maxCoeff();
    const double err = (reduced - fd).cwiseAbs().maxCoeff();
    INFO("seed " << seed << " max |J − FD| = " << err << " of max |FD| " << scale);
    // The mixed form drops only the O(h²) terms of each half-section's own rotation.
    CHECK(err < 0.02 * scale);
  }
}
