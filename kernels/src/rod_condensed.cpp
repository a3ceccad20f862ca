// The condensed Newton solve (rod_condensed.hpp): the tip → base sweep, the base system and the
// base → tip back-substitution.
#include "haustra/kernels/rod_condensed.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "condensed_rows.hpp"

namespace haustra::kernels {

CondenseReport rod_condense(const RodLinearization& rod, StrainView<const double> residual,
                            std::span<const UnitLoad> loads, CondensedSystem sys) {
  assert(std::is_sorted(loads.begin(), loads.end(), [](const UnitLoad& a, const UnitLoad& b) { return a.node > b.node; }));
  const int w = condensed_width(sys.columns);
  if (w == 16) return condensed::sweep<16>(rod, residual, loads, sys);
  return condensed::sweep<0>(rod, residual, loads, sys);
}

void rod_condensed_step(const RodLinearization& rod, CondensedSystem sys, std::span<const double> weights,
                        StrainView<double> dq, Vec3View<double> dphi, Vec3View<double> dr) {
  const std::size_t n = rod.poses.node_count();
  const auto w = static_cast<std::size_t>(condensed_width(sys.columns));
  const auto cols = static_cast<std::size_t>(sys.columns);
  double y[10] = {};
  for (std::size_t c = 0; c < cols; ++c)
    for (std::size_t i = 0; i < 10; ++i) y[i] += weights[c] * sys.base[10 * c + i];
  auto store = [&](std::size_t k) {
    dphi.set(k, {y[0], y[1], y[2]});
    dr.set(k, {y[3], y[4], y[5]});
    dq.set(k, {y[6], y[7], y[8], y[9]});
  };
  store(0);
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const double* u = sys.gain.data() + k * 4 * w;
    double next[4];
    for (std::size_t r = 0; r < 4; ++r) {
      const double* row = u + r * w;
      double v = 0.0;
      for (std::size_t c = 0; c < cols; ++c) v += weights[c] * row[kCondensedRhs + c];
      for (std::size_t i = 0; i < 10; ++i) v += row[i] * y[i];
      next[r] = v;
    }
    const condensed::SectionFrame g = condensed::section_frame(rod, k);
    condensed::advance_kinematics(g, y, next);
    store(k + 1);
  }
}

void rod_condensed_responses(const RodLinearization& rod, CondensedSystem sys, std::span<const std::uint32_t> nodes,
                             std::span<double> out) {
  if (nodes.empty()) return;
  const auto w = static_cast<std::size_t>(condensed_width(sys.columns));
  const auto cols = static_cast<std::size_t>(sys.columns);
  // y of every column, row-major (10 rows × cols): the columns vectorize.
  double* y = sys.scratch.data();
  double* next = y + 10 * cols;
  for (std::size_t c = 0; c < cols; ++c)
    for (std::size_t i = 0; i < 10; ++i) y[i * cols + c] = sys.base[10 * c + i];
  std::size_t listed = 0;
  auto emit = [&](std::size_t k) {
    while (listed < nodes.size() && nodes[listed] == k) {
      double* o = out.data() + listed * 6 * cols;
      for (std::size_t c = 0; c < cols; ++c)
        for (std::size_t i = 0; i < 6; ++i) o[6 * c + i] = y[i * cols + c];
      ++listed;
    }
  };
  emit(0);
  const std::size_t last = nodes.back();
  for (std::size_t k = 0; k < last; ++k) {
    const double* u = sys.gain.data() + k * 4 * w;
    for (std::size_t r = 0; r < 4; ++r) {
      const double* row = u + r * w;
      double* nr = next + r * cols;
      for (std::size_t c = 0; c < cols; ++c) nr[c] = row[kCondensedRhs + c];
      for (std::size_t i = 0; i < 10; ++i) {
        const double a = row[i];
        const double* yi = y + i * cols;
        for (std::size_t c = 0; c < cols; ++c) nr[c] += a * yi[c];
      }
    }
    const condensed::SectionFrame g = condensed::section_frame(rod, k);
    condensed::advance_kinematics_columns(g, y, next, cols);
    emit(k + 1);
  }
}

}  // namespace haustra::kernels
