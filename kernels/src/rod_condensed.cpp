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
  // The weights at the gain rows' right-hand-side positions from lane 12 on (whole chunks; lanes
  // 12 and 13 are zero in a gain).
  using condensed::v4;
  using condensed::chunks;
  const std::size_t nc = (w - 12) / 4;
  double* placed = sys.scratch.data();
  for (std::size_t i = 0; i < w - 12; ++i) placed[i] = 0.0;
  for (std::size_t c = 0; c < cols; ++c) placed[kCondensedRhs - 12 + c] = weights[c];
  const v4* wv = chunks(placed);
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const double* u = sys.gain.data() + k * 4 * w;
    double next[4];
    for (std::size_t r = 0; r < 4; ++r) {
      const double* row = u + r * w;
      const v4* rhs = chunks(row + 12);
      v4 acc = wv[0] * rhs[0];
      for (std::size_t c = 1; c < nc; ++c) acc += wv[c] * rhs[c];
      double v = (acc[0] + acc[1]) + (acc[2] + acc[3]);
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
  using condensed::v4;
  using condensed::chunks;
  if (nodes.empty()) return;
  const auto w = static_cast<std::size_t>(condensed_width(sys.columns));
  const auto cols = static_cast<std::size_t>(sys.columns);
  // y of every column, row-major, column c at position c + 2: a gain row's right-hand sides from
  // lane 12 on (lanes 12 and 13, δq_{k+1}'s last two, are zero in a gain) are then whole chunks
  // in the same places. cp = w − 12 positions, nc chunks.
  const std::size_t cp = w - 12, nc = cp / 4, lead = kCondensedRhs - 12;
  double* y = sys.scratch.data();
  double* next = y + 10 * cp;
  for (std::size_t i = 0; i < 14 * cp; ++i) y[i] = 0.0;
  for (std::size_t c = 0; c < cols; ++c)
    for (std::size_t i = 0; i < 10; ++i) y[i * cp + lead + c] = sys.base[10 * c + i];
  std::size_t listed = 0;
  auto emit = [&](std::size_t k) {
    while (listed < nodes.size() && nodes[listed] == k) {
      double* o = out.data() + listed * 6 * cols;
      for (std::size_t c = 0; c < cols; ++c)
        for (std::size_t i = 0; i < 6; ++i) o[6 * c + i] = y[i * cp + lead + c];
      ++listed;
    }
  };
  emit(0);
  const std::size_t last = nodes.back();
  v4* yv[10];
  for (std::size_t i = 0; i < 10; ++i) yv[i] = chunks(y + i * cp);
  v4* nv[4];
  for (std::size_t r = 0; r < 4; ++r) nv[r] = chunks(next + r * cp);
  for (std::size_t k = 0; k < last; ++k) {
    const double* u = sys.gain.data() + k * 4 * w;
    // δq_{k+1} = U_k y_k + u_k for every column.
    for (std::size_t r = 0; r < 4; ++r) {
      const double* row = u + r * w;
      const v4* rhs = chunks(row + 12);
      for (std::size_t c = 0; c < nc; ++c) nv[r][c] = rhs[c];
      for (std::size_t i = 0; i < 10; ++i) {
        const double a = row[i];
        if (a == 0.0) continue;
        for (std::size_t c = 0; c < nc; ++c) nv[r][c] += a * yv[i][c];
      }
    }
    // Node k+1's δφ, δr (condensed::advance_kinematics, for every column).
    const condensed::SectionFrame g = condensed::section_frame(rod, k);
    const double half = 0.5 * g.h;
    const condensed::V3 d0 = half * g.d[0], d1 = half * g.d[1], d2 = half * g.d[2];
    const condensed::V3 ch = g.chord, lv = g.lever;
    for (std::size_t c = 0; c < nc; ++c) {
      const v4 s0 = yv[6][c] + nv[0][c], s1 = yv[7][c] + nv[1][c], s2 = yv[8][c] + nv[2][c], se = yv[9][c] + nv[3][c];
      const v4 t0 = d0.x * s0 + d1.x * s1 + d2.x * s2;
      const v4 t1 = d0.y * s0 + d1.y * s1 + d2.y * s2;
      const v4 t2 = d0.z * s0 + d1.z * s1 + d2.z * s2;
      const v4 p0 = yv[0][c], p1 = yv[1][c], p2 = yv[2][c];
      yv[3][c] += (p1 * ch.z - p2 * ch.y) + (t1 * lv.z - t2 * lv.y) + se * d2.x;
      yv[4][c] += (p2 * ch.x - p0 * ch.z) + (t2 * lv.x - t0 * lv.z) + se * d2.y;
      yv[5][c] += (p0 * ch.y - p1 * ch.x) + (t0 * lv.y - t1 * lv.x) + se * d2.z;
      yv[0][c] = p0 + t0;
      yv[1][c] = p1 + t1;
      yv[2][c] = p2 + t2;
      yv[6][c] = nv[0][c];
      yv[7][c] = nv[1][c];
      yv[8][c] = nv[2][c];
      yv[9][c] = nv[3][c];
    }
    emit(k + 1);
  }
}

}  // namespace haustra::kernels
