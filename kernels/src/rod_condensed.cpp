// The condensed Newton solve (rod_condensed.hpp): the tip → base sweep, the base system and the
// base → tip back-substitution.
#include "haustra/kernels/rod_condensed.hpp"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>

#include "condensed_rows.hpp"

namespace haustra::kernels {

CondenseReport rod_condense_range(const RodLinearization& rod, StrainView<const double> residual,
                                  std::span<const UnitLoad> loads, CondensedSystem sys, const CondensedRange& range) {
  assert(
      std::is_sorted(loads.begin(), loads.end(), [](const UnitLoad& a, const UnitLoad& b) { return a.node > b.node; }));
  assert(!range.joint || sys.columns > kJointColumns);
  std::array<CondenseReport, 1> report;
  const condensed::Rods<double> rods{{&rod}, {residual}};
  // A compile-time row stride for the common widths (the residual alone: 16; a pin's or a few
  // contacts' unit loads: up to 40): every row is then a constant offset from the scratch. A
  // run-time stride spills the row pointers (≈ 300 stack reloads per node; the gate counts them).
  using Sweep =
      void (*)(const condensed::Rods<double>&, std::span<const UnitLoad>, const std::array<CondensedSystem, 1>&,
               const CondensedRange&, double*, std::array<CondenseReport, 1>&);
  static constexpr Sweep kByWidth[] = {condensed::sweep<double, 16>, condensed::sweep<double, 20>,
                                       condensed::sweep<double, 24>, condensed::sweep<double, 28>,
                                       condensed::sweep<double, 32>, condensed::sweep<double, 36>,
                                       condensed::sweep<double, 40>};
  const auto slot = static_cast<std::size_t>((condensed_width(sys.columns) - 16) / 4);
  const Sweep sweep = slot < std::size(kByWidth) ? kByWidth[slot] : condensed::sweep<double, 0>;
  sweep(rods, loads, {sys}, range, sys.scratch.data(), report);
  return report[0];
}

CondenseReport rod_condense(const RodLinearization& rod, StrainView<const double> residual,
                            std::span<const UnitLoad> loads, CondensedSystem sys) {
  return rod_condense_range(rod, residual, loads, sys, {0, rod.poses.node_count() - 1, false, {}});
}

void rod_condensed_resweep(const RodLinearization& rod, StrainView<const double> residual, CondensedSystem sys) {
  using V3 = condensed::V3<double>;
  const std::size_t n = rod.poses.node_count(), last = n - 1;
  const auto S = static_cast<std::size_t>(condensed_width(sys.columns));
  // The interface's residual column (10 numbers), from the tip: no wrench, node N's residual.
  double p[10] = {};
  for (std::size_t c = 0; c < 4; ++c) p[6 + c] = residual.at(last, c);
  condensed::SectionFrame<double> g;
  double a[10][4];
  condensed::Elimination el;
  // The current loads' distal wrench, summed as the sweep sums it (for a free base's balance).
  V3 force{}, moment{};
  for (std::size_t k = last; k-- > 0;) {
    condensed::read_step(sys.record.data() + k * kCondensedRecordPerStep, g, a, el);
    force = force + condensed::load(rod.node_force, k + 1);
    moment =
        moment + condensed::load(rod.node_moment, k + 1) +
        cross(condensed::load(rod.poses.node_position, k + 1) - condensed::load(rod.poses.node_position, k), force);
    // The sweep's step on its residual lane alone (the same operations: the same bits).
    double rho[4], u[4];
    for (std::size_t c = 0; c < 4; ++c) rho[c] = residual.at(k, c);
    condensed::replay_step(g, a, el, p, u, rho);
    double* gain = sys.gain.data() + k * 4 * S;
    for (std::size_t r = 0; r < 4; ++r) gain[r * S + kCondensedRhs] = u[r];
  }
  // The base system, as eliminated: a free base balances the current loads' total wrench.
  const double* rb = sys.record.data() + last * kCondensedRecordPerStep;
  const int unknowns = static_cast<int>(rb[0]);
  const int first = unknowns == 10 ? 0 : kCondensedStrain;
  const int equations = unknowns == 10 ? 0 : 6;
  if (unknowns == 10) {
    force = force + condensed::load(rod.node_force, 0);
    moment = moment + condensed::load(rod.node_moment, 0);
    for (int i = 0; i < 3; ++i) {
      p[i] += moment[i];
      p[3 + i] += force[i];
    }
  }
  double e[10];
  for (int i = 0; i < unknowns; ++i) e[i] = p[equations + i];
  for (int step = 0; step < unknowns; ++step) {
    const int pr = static_cast<int>(rb[1 + step]);
    e[pr] *= rb[11 + step];
    for (int r = 0; r < unknowns; ++r) e[r] = condensed::fmadd(-rb[21 + 10 * step + r], e[pr], e[r]);
  }
  double* y = sys.base.data();
  for (int i = 0; i < 10; ++i) y[i] = 0.0;
  for (int i = 0; i < unknowns; ++i) y[first + i] = -e[static_cast<int>(rb[1 + i])];
}

void rod_condensed_step_range(const RodLinearization& rod, CondensedSystem sys, std::size_t first, std::size_t last,
                              const double* start, std::span<const double> weights, StrainView<double> dq,
                              Vec3View<double> dphi, Vec3View<double> dr) {
  using condensed::chunks;
  using condensed::v4;
  const auto w = static_cast<std::size_t>(condensed_width(sys.columns));
  const auto cols = static_cast<std::size_t>(sys.columns);
  double y[10];
  for (std::size_t i = 0; i < 10; ++i) y[i] = start[i];
  auto store = [&](std::size_t k) {
    dphi.set(k, {y[0], y[1], y[2]});
    dr.set(k, {y[3], y[4], y[5]});
    dq.set(k, {y[6], y[7], y[8], y[9]});
  };
  store(first);
  // The weights at the gain rows' right-hand-side positions from lane 12 on (whole chunks; lanes
  // 12 and 13 are zero in a gain).
  const std::size_t nc = (w - 12) / 4;
  double* placed = sys.scratch.data();
  for (std::size_t i = 0; i < w - 12; ++i) placed[i] = 0.0;
  for (std::size_t c = 0; c < cols; ++c) placed[kCondensedRhs - 12 + c] = weights[c];
  const v4* wv = chunks(placed);
  for (std::size_t k = first; k < last; ++k) {
    const double* u = sys.gain.data() + (k - first) * 4 * w;
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
    const condensed::SectionFrame<double> g = condensed::section_frame(rod, k);
    condensed::advance_kinematics(g, y, next);
    store(k + 1);
  }
}

void rod_condensed_step(const RodLinearization& rod, CondensedSystem sys, std::span<const double> weights,
                        StrainView<double> dq, Vec3View<double> dphi, Vec3View<double> dr) {
  double y[10] = {};
  for (std::size_t c = 0; c < static_cast<std::size_t>(sys.columns); ++c)
    for (std::size_t i = 0; i < 10; ++i) y[i] += weights[c] * sys.base[10 * c + i];
  rod_condensed_step_range(rod, sys, 0, rod.poses.node_count() - 1, y, weights, dq, dphi, dr);
}

namespace {

// One step of the back-substitution base → tip over chunks [0, nc) of columns, in registers:
// δq_{k+1} = U_k y_k + u_k (the gains u, rows w apart; right-hand sides rhs in the chunks below
// rhs_chunks, none beyond), then node k+1's δφ, δr (condensed::advance_kinematics). Inlined so
// that where every chunk has a right-hand side the per-chunk test folds away (the gate counts it).
[[gnu::always_inline]] inline void back_substitute_node(const condensed::SectionFrame<double>& g, const double* u,
                                                        std::size_t w, const condensed::v4* const (&rhs)[4],
                                                        std::size_t rhs_chunks, std::size_t nc,
                                                        condensed::v4* const (&yv)[10]) {
  using condensed::broadcast;
  using condensed::fmadd;
  using condensed::v4;
  const double half = 0.5 * g.h;
  const condensed::V3<double> d0 = half * g.d[0], d1 = half * g.d[1], d2 = half * g.d[2];
  const condensed::V3<double> ch = g.chord, lv = g.lever;
  for (std::size_t c = 0; c < nc; ++c) {
    v4 yc[10];
    for (std::size_t i = 0; i < 10; ++i) yc[i] = yv[i][c];
    v4 nx[4];
    for (std::size_t r = 0; r < 4; ++r) {
      const double* row = u + r * w;
      v4 acc = c < rhs_chunks ? rhs[r][c] : v4{};
      for (std::size_t i = 0; i < 10; ++i) acc = fmadd(broadcast<v4>(row[i]), yc[i], acc);
      nx[r] = acc;
    }
    const v4 s0 = yc[6] + nx[0], s1 = yc[7] + nx[1], s2 = yc[8] + nx[2], se = yc[9] + nx[3];
    const v4 t0 = d0.x * s0 + d1.x * s1 + d2.x * s2;
    const v4 t1 = d0.y * s0 + d1.y * s1 + d2.y * s2;
    const v4 t2 = d0.z * s0 + d1.z * s1 + d2.z * s2;
    const v4 p0 = yc[0], p1 = yc[1], p2 = yc[2];
    yv[3][c] = yc[3] + ((p1 * ch.z - p2 * ch.y) + (t1 * lv.z - t2 * lv.y) + se * d2.x);
    yv[4][c] = yc[4] + ((p2 * ch.x - p0 * ch.z) + (t2 * lv.x - t0 * lv.z) + se * d2.y);
    yv[5][c] = yc[5] + ((p0 * ch.y - p1 * ch.x) + (t0 * lv.y - t1 * lv.x) + se * d2.z);
    yv[0][c] = p0 + t0;
    yv[1][c] = p1 + t1;
    yv[2][c] = p2 + t2;
    for (std::size_t r = 0; r < 4; ++r) yv[6 + r][c] = nx[r];
  }
}

}  // namespace

void rod_condensed_responses_range(const RodLinearization& rod, CondensedSystem sys, std::size_t first,
                                   std::size_t last, std::span<const double> start,
                                   std::span<const std::uint32_t> nodes, std::span<double> out,
                                   std::span<double> at_last, int column_first, int column_end) {
  using condensed::chunks;
  using condensed::v4;
  const auto w = static_cast<std::size_t>(condensed_width(sys.columns));
  const auto cols = static_cast<std::size_t>(sys.columns);
  const auto c0 = static_cast<std::size_t>(column_first);
  const std::size_t c1 = column_end > 0 ? static_cast<std::size_t>(column_end) : cols;
  if (c1 <= c0) return;
  // y of the columns, row-major, column c at position c − base: the gain rows' right-hand sides
  // from lane `lane` (a chunk's first, at or before column c0's) on are then whole chunks in the
  // same places (lanes before c0's are other columns' or, at lanes 12–13, a gain's zeros: unused).
  const std::size_t lane = (kCondensedRhs + c0) & ~std::size_t{3};
  const std::size_t lead = kCondensedRhs + c0 - lane;  // position of column c0
  const std::size_t cp = (lead + (c1 - c0) + 3) & ~std::size_t{3}, nc = cp / 4;
  double* y = sys.scratch.data();
  for (std::size_t i = 0; i < 10 * cp; ++i) y[i] = 0.0;
  for (std::size_t c = c0; c < c1; ++c)
    for (std::size_t i = 0; i < 10; ++i) y[i * cp + lead + c - c0] = start[10 * c + i];
  std::size_t listed = 0;
  auto emit = [&](std::size_t k) {
    while (listed < nodes.size() && nodes[listed] == k) {
      double* o = out.data() + listed * 6 * cols;
      for (std::size_t c = c0; c < c1; ++c)
        for (std::size_t i = 0; i < 6; ++i) o[6 * c + i] = y[i * cp + lead + c - c0];
      ++listed;
    }
  };
  emit(first);
  v4* yv[10];
  for (std::size_t i = 0; i < 10; ++i) yv[i] = chunks(y + i * cp);
  const std::size_t end = at_last.empty() ? (nodes.empty() ? first : std::size_t{nodes.back()}) : last;
  for (std::size_t k = first; k < end; ++k) {
    const double* u = sys.gain.data() + (k - first) * 4 * w;
    const v4* rhs[4];
    for (std::size_t r = 0; r < 4; ++r) rhs[r] = chunks(u + r * w + lane);
    back_substitute_node(condensed::section_frame(rod, k), u, w, rhs, nc, nc, yv);
    emit(k + 1);
  }
  if (!at_last.empty())
    for (std::size_t c = c0; c < c1; ++c)
      for (std::size_t i = 0; i < 10; ++i) at_last[10 * c + i] = y[i * cp + lead + c - c0];
}

void rod_condensed_tip_responses(const RodLinearization& rod, CondensedSystem sys, std::size_t first,
                                 std::span<const std::uint32_t> nodes, std::span<double> particular,
                                 std::span<double> unit) {
  using condensed::chunks;
  using condensed::v4;
  if (nodes.empty()) return;
  const auto w = static_cast<std::size_t>(condensed_width(sys.columns));
  const auto cols = static_cast<std::size_t>(sys.columns);
  // y's rows: the columns as the gain rows hold their right-hand sides from lane 12 on (column c at
  // position 2 + c; positions 0–1 face a gain's zero lanes 12–13) in chunks [0, np), then the ten
  // unit starts in chunks [np, np + 3), with no right-hand side.
  constexpr std::size_t lane = 12, lead = kCondensedRhs - lane;
  const std::size_t pw = w - lane, np = pw / 4, nc = np + 3, cp = 4 * nc;
  double* y = sys.scratch.data();
  for (std::size_t i = 0; i < 10 * cp; ++i) y[i] = 0.0;
  for (std::size_t j = 0; j < 10; ++j) y[j * cp + pw + j] = 1.0;
  std::size_t listed = 0;
  auto emit = [&](std::size_t k) {
    while (listed < nodes.size() && nodes[listed] == k) {
      double* o = particular.data() + listed * 6 * cols;
      for (std::size_t c = 0; c < cols; ++c)
        for (std::size_t i = 0; i < 6; ++i) o[6 * c + i] = y[i * cp + lead + c];
      double* e = unit.data() + listed * 60;
      for (std::size_t j = 0; j < 10; ++j)
        for (std::size_t i = 0; i < 6; ++i) e[6 * j + i] = y[i * cp + pw + j];
      ++listed;
    }
  };
  emit(first);
  v4* yv[10];
  for (std::size_t i = 0; i < 10; ++i) yv[i] = chunks(y + i * cp);
  for (std::size_t k = first; k < nodes.back(); ++k) {
    const double* u = sys.gain.data() + (k - first) * 4 * w;
    const v4* rhs[4];
    for (std::size_t r = 0; r < 4; ++r) rhs[r] = chunks(u + r * w + lane);
    back_substitute_node(condensed::section_frame(rod, k), u, w, rhs, np, nc, yv);
    emit(k + 1);
  }
}

void rod_condensed_tip_fold(std::span<const double> particular, std::span<const double> unit,
                            std::span<const double> y_joint, int columns, std::size_t nodes, std::span<double> out,
                            int column_first, int column_end) {
  const auto cols = static_cast<std::size_t>(columns);
  const auto c0 = static_cast<std::size_t>(column_first);
  const std::size_t c1 = column_end > 0 ? static_cast<std::size_t>(column_end) : cols;
  for (std::size_t k = 0; k < nodes; ++k) {
    const double* p = particular.data() + k * 6 * cols;
    const double* e = unit.data() + k * 60;
    double* o = out.data() + k * 6 * cols;
    for (std::size_t c = c0; c < c1; ++c) {
      const double* ym = y_joint.data() + 10 * c;
      double v[6];
      for (std::size_t i = 0; i < 6; ++i) v[i] = p[6 * c + i];
      for (std::size_t j = 0; j < 10; ++j)
        for (std::size_t i = 0; i < 6; ++i) v[i] = std::fma(e[6 * j + i], ym[j], v[i]);
      for (std::size_t i = 0; i < 6; ++i) o[6 * c + i] = v[i];
    }
  }
}

void rod_condensed_responses(const RodLinearization& rod, CondensedSystem sys, std::span<const std::uint32_t> nodes,
                             std::span<double> out) {
  if (nodes.empty()) return;
  rod_condensed_responses_range(rod, sys, 0, nodes.back(), sys.base, nodes, out, {});
}

bool rod_condensed_join(const RodLinearization& rod, std::size_t m, const CondensedJoin& join, std::span<double> lambda,
                        std::span<double> y_joint) {
  using Matrix10 = Eigen::Matrix<double, 10, 10>;
  using Vector10 = Eigen::Matrix<double, 10, 1>;
  const auto tw = static_cast<std::size_t>(condensed_width(join.tip_columns));
  // Π' = Π_m with A_mm added back to the c rows (the base part kept −A_mm δq_m in its rows).
  Matrix10 pi;
  for (int r = 0; r < 10; ++r)
    for (int i = 0; i < 10; ++i) pi(r, i) = join.tip[static_cast<std::size_t>(r) * tw + static_cast<std::size_t>(i)];
  const condensed::Tangent<double> t = condensed::tangent_of(rod, m);
  const double mass = (rod.section_length[m - 1] + rod.section_length[m]) / 3.0;
  for (int c = 0; c < 4; ++c)
    for (int j = 0; j < 4; ++j) pi(6 + c, kCondensedStrain + j) += mass * t.at(c, j);
  auto base_y = [&](int column) {
    Vector10 y;
    for (int i = 0; i < 10; ++i) y[i] = join.base_at_joint[static_cast<std::size_t>(10 * column + i)];
    return y;
  };
  Matrix10 ylambda;
  for (int i = 0; i < kJointColumns; ++i) ylambda.col(i) = base_y(1 + i);
  const Eigen::FullPivLU<Matrix10> lu(Matrix10::Identity() - pi * ylambda);
  if (!lu.isInvertible()) return false;
  const std::size_t columns = join.tip_column.size();
  for (std::size_t g = 0; g < columns; ++g) {
    const Vector10 y = join.base_column[g] >= 0 ? base_y(join.base_column[g]) : Vector10::Zero();
    Vector10 tip_rhs = Vector10::Zero();
    if (join.tip_column[g] >= 0)
      for (int r = 0; r < 10; ++r)
        tip_rhs[r] =
            join.tip[static_cast<std::size_t>(r) * tw + kCondensedRhs + static_cast<std::size_t>(join.tip_column[g])];
    const Vector10 l = lu.solve(pi * y + tip_rhs);
    const Vector10 ym = y + ylambda * l;
    for (int i = 0; i < 10; ++i) {
      lambda[10 * g + static_cast<std::size_t>(i)] = l[i];
      y_joint[10 * g + static_cast<std::size_t>(i)] = ym[i];
      if (!std::isfinite(l[i]) || !std::isfinite(ym[i])) return false;
    }
  }
  return true;
}

std::pair<std::size_t, int> rod_condensed_split_loads(std::span<const UnitLoad> loads, int columns, std::size_t m,
                                                      std::span<UnitLoad> base_loads, std::span<int> tip_column,
                                                      std::span<int> base_column) {
  std::size_t tip = 0;
  while (tip < loads.size() && loads[tip].node > m) ++tip;
  for (int g = 0; g < columns; ++g) {
    tip_column[static_cast<std::size_t>(g)] = g;
    base_column[static_cast<std::size_t>(g)] = g == 0 ? 0 : -1;
  }
  int next = 1 + kJointColumns;
  for (std::size_t i = tip; i < loads.size(); ++i) {
    UnitLoad l = loads[i];
    int& b = base_column[l.column];
    if (b < 0) b = next++;
    l.column = static_cast<std::uint32_t>(b);
    base_loads[i - tip] = l;
  }
  return {tip, next};
}

void rod_condensed_base_responses(std::span<const double> raw, int base_columns, std::span<const int> base_column,
                                  std::span<const double> lambda, std::size_t nodes, std::span<double> out) {
  const std::size_t columns = base_column.size();
  const auto bc = static_cast<std::size_t>(base_columns);
  for (std::size_t k = 0; k < nodes; ++k) {
    const double* r = raw.data() + k * 6 * bc;
    double* o = out.data() + k * 6 * columns;
    for (std::size_t g = 0; g < columns; ++g) {
      double v[6] = {};
      if (base_column[g] >= 0)
        for (std::size_t i = 0; i < 6; ++i) v[i] = r[6 * static_cast<std::size_t>(base_column[g]) + i];
      for (std::size_t j = 0; j < kJointColumns; ++j) {
        const double l = lambda[10 * g + j];
        for (std::size_t i = 0; i < 6; ++i) v[i] += l * r[6 * (1 + j) + i];
      }
      for (std::size_t i = 0; i < 6; ++i) o[6 * g + i] = v[i];
    }
  }
}

void rod_condensed_split_step(std::span<const double> weights, std::span<const double> lambda,
                              std::span<const double> y_joint, std::span<const int> base_column,
                              std::span<const double> base_solution, int base_columns, double* base_start,
                              std::span<double> base_weights, double* tip_start) {
  const std::size_t columns = base_column.size();
  std::fill(base_weights.begin(), base_weights.begin() + base_columns, 0.0);
  for (std::size_t i = 0; i < 10; ++i) tip_start[i] = 0.0;
  for (std::size_t g = 0; g < columns; ++g) {
    const double wg = weights[g];
    if (wg == 0.0) continue;
    if (base_column[g] >= 0) base_weights[static_cast<std::size_t>(base_column[g])] += wg;
    for (std::size_t j = 0; j < kJointColumns; ++j) base_weights[1 + j] += wg * lambda[10 * g + j];
    for (std::size_t i = 0; i < 10; ++i) tip_start[i] += wg * y_joint[10 * g + i];
  }
  for (std::size_t i = 0; i < 10; ++i) base_start[i] = 0.0;
  for (std::size_t c = 0; c < static_cast<std::size_t>(base_columns); ++c)
    for (std::size_t i = 0; i < 10; ++i) base_start[i] += base_weights[c] * base_solution[10 * c + i];
}

}  // namespace haustra::kernels
