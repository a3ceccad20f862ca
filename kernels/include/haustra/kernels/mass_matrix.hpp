#pragma once
// The 1D linear-element mass matrix M of a rod (hat-function Gram matrix): (h_{k−1}+h_k)/3 on the
// diagonal, h_k/6 beside it. With hat-function strains, ∫ Δq² ds = Δqᵀ M Δq, so the stiffness
// of every strain component is a scalar times M. M is constant: it is factored once (LDLᵀ) and the
// one factorization serves all four components, solved together as a 4-column right-hand side.
#include <span>

#include "haustra/kernels/spans.hpp"

namespace haustra::kernels {

struct MassMatrixFactorView {
  std::span<const double> inv_pivot;  // 1/D_k, N+1 values
  std::span<const double> lower;      // L_{k,k−1}, N+1 values (lower[0] unused, 0)
};

// Factor M = L D Lᵀ for section lengths h (N values). Outputs have N+1 values.
void mass_matrix_factor(std::span<const double> section_length, std::span<double> inv_pivot, std::span<double> lower);

// Solve M x = b in place for all four strain components at once.
void mass_matrix_solve(MassMatrixFactorView factor, StrainView<double> rhs_to_solution);

// y = M x for all four components (used to form right-hand sides and in tests).
void mass_matrix_multiply(std::span<const double> section_length, StrainView<const double> x, StrainView<double> y);

// Reference: assemble M densely and solve with Eigen's LDLT, column by column.
void mass_matrix_solve_reference(std::span<const double> section_length, StrainView<double> rhs_to_solution);

}  // namespace haustra::kernels
