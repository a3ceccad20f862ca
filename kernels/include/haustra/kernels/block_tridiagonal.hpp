#pragma once
// Block-tridiagonal linear systems (block Thomas algorithm): L_k z_{k−1} + D_k z_k + U_k z_{k+1} = b_k.
// Factor once, then solve any number of right-hand sides. Pivoting happens inside each diagonal
// block (partial pivoting); the systems this engine builds have well-conditioned Schur complements
// (identity-dominated kinematic and equilibrium rows), which the tests check against a dense LU.
#include <Eigen/Dense>
#include <span>

namespace haustra::kernels {

template <int B>
struct BlockTridiagonalView {
  using Block = Eigen::Matrix<double, B, B>;
  std::span<Block> lower;  // L_k (L_0 unused)
  std::span<Block> diag;   // D_k; after factoring, unused
  std::span<Block> upper;  // U_k (U_{n−1} unused); after factoring, D'_k⁻¹ U_k
  std::span<Eigen::PartialPivLU<Block>> pivots;  // LU of the Schur complements D'_k
};

template <int B>
void block_tridiagonal_factor(BlockTridiagonalView<B> m) {
  const std::size_t n = m.diag.size();
  for (std::size_t k = 0; k < n; ++k) {
    if (k > 0) m.diag[k].noalias() -= m.lower[k] * m.upper[k - 1];
    m.pivots[k].compute(m.diag[k]);
    if (k + 1 < n) m.upper[k] = m.pivots[k].solve(m.upper[k]);
  }
}

inline constexpr int kMaxRhsColumns = 72;

// rhs: n blocks of B rows × cols columns (cols ≤ kMaxRhsColumns), column-major within a block
// (block k starts at k·B·cols). Overwritten by the solution.
template <int B>
void block_tridiagonal_solve(BlockTridiagonalView<B> m, std::span<double> rhs, int cols) {
  using Rhs = Eigen::Map<Eigen::Matrix<double, B, Eigen::Dynamic, 0, B, kMaxRhsColumns>>;
  const std::size_t n = m.diag.size();
  const std::size_t stride = static_cast<std::size_t>(B) * static_cast<std::size_t>(cols);
  auto block = [&](std::size_t k) { return Rhs(rhs.data() + k * stride, B, cols); };
  for (std::size_t k = 0; k < n; ++k) {
    Rhs b = block(k);
    if (k > 0) b.noalias() -= m.lower[k] * block(k - 1);
    b = m.pivots[k].solve(b);
  }
  for (std::size_t k = n - 1; k-- > 0;) {
    Rhs b = block(k);
    b.noalias() -= m.upper[k] * block(k + 1);
  }
}

}  // namespace haustra::kernels
