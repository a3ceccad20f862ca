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

// x ← L⁻¹ x with L the unit lower triangle of `l`; x: B rows × cols, column-major, leading
// dimension ld. Plain loops: Eigen's general triangular solver costs ~10⁴ instructions of set-up
// per call at this size, several times the arithmetic (measured with callgrind).
// The columns are interleaved inside the elimination step (j outer): one column's recurrence is a
// chain of store → load → multiply–add; interleaving several hides its latency.
template <int B>
void unit_lower_solve(const Eigen::Matrix<double, B, B>& l, double* x, int cols, Eigen::Index ld) {
  for (int j = 0; j < B; ++j)
    for (int c = 0; c < cols; ++c) {
      double* xc = x + c * ld;
      const double xj = xc[j];
      for (int i = j + 1; i < B; ++i) xc[i] -= l(i, j) * xj;
    }
}

// x ← U⁻¹ x with U the upper triangle of `u` (diagonal included); as unit_lower_solve.
template <int B>
void upper_solve(const Eigen::Matrix<double, B, B>& u, double* x, int cols, Eigen::Index ld) {
  for (int j = B; j-- > 0;) {
    const double inv = 1.0 / u(j, j);
    for (int c = 0; c < cols; ++c) {
      double* xc = x + c * ld;
      const double xj = xc[j] * inv;
      xc[j] = xj;
      for (int i = 0; i < j; ++i) xc[i] -= u(i, j) * xj;
    }
  }
}

// The panel (the first B columns of w, its first Rows rows) eliminated with partial pivoting,
// right-looking; whole rows of w swap. Rows is a template argument so the loops have fixed bounds.
template <int B, int Rows, class Work>
void eliminate_panel(Work& w, std::array<std::uint8_t, B>& swaps) {
  for (int j = 0; j < B; ++j) {
    int p = j;
    double best = std::abs(w(j, j));
    for (int i = j + 1; i < Rows; ++i)
      if (std::abs(w(i, j)) > best) {
        best = std::abs(w(i, j));
        p = i;
      }
    swaps[static_cast<std::size_t>(j)] = static_cast<std::uint8_t>(p);
    if (p != j) w.row(j).swap(w.row(p));
    const double inv = 1.0 / w(j, j);
    for (int i = j + 1; i < Rows; ++i) w(i, j) *= inv;
    for (int c = j + 1; c < B; ++c) {
      const double u = w(j, c);
      for (int i = j + 1; i < Rows; ++i) w(i, c) -= w(i, j) * u;
    }
  }
}

// Whether a step's swaps brought a row of the next block row up (its U then has a fill block).
template <int B>
[[nodiscard]] bool has_fill(const std::array<std::uint8_t, B>& swaps) {
  for (const std::uint8_t p : swaps)
    if (p >= B) return true;
  return false;
}

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
    if (last)
      eliminate_panel<B, B>(w, m.swaps[k]);
    else
      eliminate_panel<B, 2 * B>(w, m.swaps[k]);
    // The pivot rows in column blocks k+1 and k+2, and the Schur complement of the others. Column
    // block k+2 of the pivot rows is zero unless a row of block row k+1 moved up (usually none
    // does): then it needs neither the triangular solve nor the product.
    const bool fill = has_fill<B>(m.swaps[k]);
    m.diag[k] = w.template topLeftCorner<B, B>();
    unit_lower_solve<B>(m.diag[k], w.data() + w.outerStride() * B, fill ? 2 * B : B, w.outerStride());
    if (last) break;
    if (fill)
      w.template bottomRightCorner<B, 2 * B>().noalias() -=
          w.template bottomLeftCorner<B, B>() * w.template topRightCorner<B, 2 * B>();
    else
      w.template block<B, B>(B, B).noalias() -= w.template bottomLeftCorner<B, B>() * w.template block<B, B>(0, B);
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
    unit_lower_solve<B>(m.diag[k], v.data(), cols, v.outerStride());
    Rhs y = block(k);
    y = v.template topRows<B>();
    if (!last) v.template topRows<B>() = v.template bottomRows<B>() - m.lower[k] * y;
  }
  // Backward through the upper factor: its diagonal, first and second off-diagonal blocks.
  for (std::size_t k = n; k-- > 0;) {
    Rhs b = block(k);
    if (k + 1 < n) b.noalias() -= m.upper[k] * block(k + 1);
    if (k + 2 < n && has_fill<B>(m.swaps[k])) b.noalias() -= m.fill[k] * block(k + 2);
    upper_solve<B>(m.diag[k], b.data(), cols, B);
  }
}

}  // namespace haustra::kernels
