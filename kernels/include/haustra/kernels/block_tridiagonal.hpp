#pragma once
// Block-tridiagonal linear systems L_k z_{k−1} + D_k z_k + U_k z_{k+1} = b_k: Gaussian elimination
// with partial pivoting over the band. Each step eliminates one column block choosing pivots from
// two block rows (the rows carried from the step before and the next block row), so rows may move
// down by a block and the upper factor gains a second off-diagonal block (fill). Pivoting only
// inside each diagonal block (the block Thomas algorithm) is not enough for a rod's mixed system:
// under a tension large against the bending stiffness (F h²/B ≳ 0.5 per section) it amplifies
// rounding by orders of magnitude per solve, and Newton diverges from an exact equilibrium.
// Factor once, then solve any number of right-hand sides.
#include <Eigen/Dense>
#include <array>
#include <cstdint>
#include <span>

namespace haustra::kernels {

template <int B>
struct BlockTridiagonalView {
  using Block = Eigen::Matrix<double, B, B>;
  std::span<Block> lower;  // in: L_k (L_0 unused); factored: step k's multipliers of the lower rows
  std::span<Block> diag;   // in: D_k; factored: step k's pivot block, unit-lower L and upper U packed
  std::span<Block> upper;  // in: U_k (U_{n−1} unused); factored: step k's U in column block k+1
  std::span<Block> fill;   // factored: step k's U in column block k+2 (rows swapped up)
  std::span<std::array<std::uint8_t, B>> swaps;  // factored: step k's row swaps, 0..2B−1
};

template <int B>
void block_tridiagonal_factor(BlockTridiagonalView<B> m) {
  using Block = Eigen::Matrix<double, B, B>;
  const std::size_t n = m.diag.size();
  // Rows [0, B): those carried from the last step (block row k after its elimination so far);
  // rows [B, 2B): block row k+1. Columns: blocks k, k+1, k+2.
  Eigen::Matrix<double, 2 * B, 3 * B> w;
  Block carried = m.diag[0];
  Block carried_next = n > 1 ? m.upper[0] : Block::Zero();
  for (std::size_t k = 0; k < n; ++k) {
    const bool last = k + 1 == n;
    const int rows = last ? B : 2 * B;
    w.template block<B, B>(0, 0) = carried;
    w.template block<B, B>(0, B) = carried_next;
    w.template block<B, B>(0, 2 * B).setZero();
    if (!last) {
      w.template block<B, B>(B, 0) = m.lower[k + 1];
      w.template block<B, B>(B, B) = m.diag[k + 1];
      if (k + 2 < n)
        w.template block<B, B>(B, 2 * B) = m.upper[k + 1];
      else
        w.template block<B, B>(B, 2 * B).setZero();
    }
    // The panel (column block k), right-looking; whole rows swap.
    for (int j = 0; j < B; ++j) {
      int p = j;
      double best = std::abs(w(j, j));
      for (int i = j + 1; i < rows; ++i)
        if (std::abs(w(i, j)) > best) {
          best = std::abs(w(i, j));
          p = i;
        }
      m.swaps[k][static_cast<std::size_t>(j)] = static_cast<std::uint8_t>(p);
      if (p != j) w.row(j).swap(w.row(p));
      const double inv = 1.0 / w(j, j);
      for (int i = j + 1; i < rows; ++i) w(i, j) *= inv;
      for (int c = j + 1; c < B; ++c) {
        const double u = w(j, c);
        for (int i = j + 1; i < rows; ++i) w(i, c) -= w(i, j) * u;
      }
    }
    // The pivot rows in column blocks k+1 and k+2, and the Schur complement of the others.
    w.template topLeftCorner<B, B>().template triangularView<Eigen::UnitLower>().solveInPlace(
        w.template topRightCorner<B, 2 * B>());
    m.diag[k] = w.template topLeftCorner<B, B>();
    if (last) break;
    w.template bottomRightCorner<B, 2 * B>().noalias() -=
        w.template bottomLeftCorner<B, B>() * w.template topRightCorner<B, 2 * B>();
    m.lower[k] = w.template bottomLeftCorner<B, B>();
    m.upper[k] = w.template block<B, B>(0, B);
    m.fill[k] = w.template block<B, B>(0, 2 * B);
    carried = w.template block<B, B>(B, B);
    carried_next = w.template block<B, B>(B, 2 * B);
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
  // Forward: the same swaps and multipliers as the factorization; block k becomes step k's y.
  Eigen::Matrix<double, 2 * B, Eigen::Dynamic, 0, 2 * B, kMaxRhsColumns> v(2 * B, cols);
  v.template topRows<B>() = block(0);
  for (std::size_t k = 0; k < n; ++k) {
    const bool last = k + 1 == n;
    if (!last) v.template bottomRows<B>() = block(k + 1);
    for (int j = 0; j < B; ++j) {
      const int p = m.swaps[k][static_cast<std::size_t>(j)];
      if (p != j) v.row(j).swap(v.row(p));
    }
    m.diag[k].template triangularView<Eigen::UnitLower>().solveInPlace(v.template topRows<B>());
    Rhs y = block(k);
    y = v.template topRows<B>();
    if (!last) v.template topRows<B>() = v.template bottomRows<B>() - m.lower[k] * y;
  }
  // Backward through the upper factor: its diagonal, first and second off-diagonal blocks.
  for (std::size_t k = n; k-- > 0;) {
    Rhs b = block(k);
    if (k + 1 < n) b.noalias() -= m.upper[k] * block(k + 1);
    if (k + 2 < n) b.noalias() -= m.fill[k] * block(k + 2);
    m.diag[k].template triangularView<Eigen::Upper>().solveInPlace(b);
  }
}

}  // namespace haustra::kernels
