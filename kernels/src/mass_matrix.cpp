// The rod's linear-element mass matrix: its factor, solve and product, and a dense reference.
#include "haustra/kernels/mass_matrix.hpp"

#include <Eigen/Dense>

namespace haustra::kernels {

void mass_matrix_factor(std::span<const double> section_length, std::span<double> inv_pivot, std::span<double> lower) {
  const std::size_t n = section_length.size() + 1;
  assert(inv_pivot.size() == n && lower.size() == n);
  auto h = [&](std::size_t k) { return k < section_length.size() ? section_length[k] : 0.0; };
  double prev_pivot = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const double diag = ((k > 0 ? h(k - 1) : 0.0) + h(k)) / 3.0;
    double pivot = diag;
    if (k > 0) {
      const double off = h(k - 1) / 6.0;
      lower[k] = off / prev_pivot;
      pivot -= lower[k] * off;
    } else {
      lower[k] = 0.0;
    }
    inv_pivot[k] = 1.0 / pivot;
    prev_pivot = pivot;
  }
}

void mass_matrix_solve(MassMatrixFactorView factor, StrainView<double> x) {
  const std::size_t n = x.size();
  double* d = x.data.data();
  // Forward: L z = b.
  for (std::size_t k = 1; k < n; ++k) {
    const double l = factor.lower[k];
    for (std::size_t c = 0; c < kStrainComponents; ++c) d[4 * k + c] -= l * d[4 * (k - 1) + c];
  }
  // Diagonal and backward: Lᵀ x = D⁻¹ z.
  for (std::size_t c = 0; c < kStrainComponents; ++c) d[4 * (n - 1) + c] *= factor.inv_pivot[n - 1];
  for (std::size_t k = n - 1; k-- > 0;) {
    const double l = factor.lower[k + 1];
    const double inv = factor.inv_pivot[k];
    for (std::size_t c = 0; c < kStrainComponents; ++c) d[4 * k + c] = d[4 * k + c] * inv - l * d[4 * (k + 1) + c];
  }
}

void mass_matrix_multiply(std::span<const double> section_length, StrainView<const double> x, StrainView<double> y) {
  const std::size_t n = x.size();
  for (std::size_t k = 0; k < n; ++k) {
    const double h_prev = k > 0 ? section_length[k - 1] : 0.0;
    const double h_next = k + 1 < n ? section_length[k] : 0.0;
    Eigen::Vector4d v = (h_prev + h_next) / 3.0 * x.get(k);
    if (k > 0) v += h_prev / 6.0 * x.get(k - 1);
    if (k + 1 < n) v += h_next / 6.0 * x.get(k + 1);
    y.set(k, v);
  }
}

void mass_matrix_solve_reference(std::span<const double> section_length, StrainView<double> x) {
  const auto n = static_cast<Eigen::Index>(x.size());
  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(n, n);
  for (Eigen::Index k = 0; k + 1 < n; ++k) {
    const double h = section_length[static_cast<std::size_t>(k)];
    m(k, k) += h / 3.0;
    m(k + 1, k + 1) += h / 3.0;
    m(k, k + 1) += h / 6.0;
    m(k + 1, k) += h / 6.0;
  }
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(m);
  for (std::size_t c = 0; c < kStrainComponents; ++c) {
    Eigen::VectorXd b(n);
    for (Eigen::Index k = 0; k < n; ++k) b[k] = x.at(static_cast<std::size_t>(k), c);
    const Eigen::VectorXd sol = ldlt.solve(b);
    for (Eigen::Index k = 0; k < n; ++k) x.at(static_cast<std::size_t>(k), c) = sol[k];
  }
}

}  // namespace haustra::kernels
