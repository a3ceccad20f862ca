#pragma once
// The condensed sweep's inner workings (rod_condensed.hpp): a section's frame, the row operations
// over (δφ_k, δr_k, δq_k, δq_{k+1}, right-hand sides), and the tip → base sweep itself. Rows are
// `w` contiguous doubles; W = 16 (the residual alone) is a compile-time width, W = 0 a run-time one.
#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#if defined(__AVX__)
#include <immintrin.h>
#endif

#include "haustra/kernels/rod_condensed.hpp"

namespace haustra::kernels::condensed {

constexpr int PHI = kCondensedRotation;
constexpr int POS = kCondensedPosition;
constexpr int QK = kCondensedStrain;
constexpr int QN = kCondensedNextStrain;
constexpr int RHS = kCondensedRhs;
constexpr int kZ = 16;  // lanes that can hold anything but right-hand sides

struct V3 {
  double x = 0, y = 0, z = 0;
  double operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
};
inline V3 operator+(V3 a, V3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline V3 operator-(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline V3 operator*(double s, V3 a) { return {s * a.x, s * a.y, s * a.z}; }
inline V3 cross(V3 a, V3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline double dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline V3 load(Vec3View<const double> v, std::size_t i) { return {v.x[i], v.y[i], v.z[i]}; }

// Section k: its midpoint frame and the lever arms the kinematics need.
struct SectionFrame {
  V3 d[3];   // material axes d1 d2 d3 (world)
  double h;  // length
  V3 chord;  // r_{k+1} − r_k
  V3 lever;  // r_{k+1} − p_k (midpoint to the distal node)
  V3 mid;    // p_k − r_k
};

inline SectionFrame section_frame(const RodLinearization& rod, std::size_t k) {
  SectionFrame g;
  const RotationView<const double>& q = rod.poses.mid_rotation;
  const double w = q.w[k], x = q.x[k], y = q.y[k], z = q.z[k];
  // The columns of the rotation matrix of a unit quaternion.
  g.d[0] = {1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y)};
  g.d[1] = {2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x)};
  g.d[2] = {2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)};
  g.h = rod.section_length[k];
  const V3 rk = load(rod.poses.node_position, k), rn = load(rod.poses.node_position, k + 1);
  const V3 p = load(rod.poses.mid_position, k);
  g.chord = rn - rk;
  g.lever = rn - p;
  g.mid = p - rk;
  return g;
}

// Node k+1's δφ, δr from node k's and both strains: the rows 4–9 of rod_newton.hpp.
// θ = ½h R (δu_k + δu_{k+1}); δφ_{k+1} = δφ_k + θ; δr_{k+1} = δr_k + δφ_k × chord + θ × lever
// + ½h d3 (δε_k + δε_{k+1}). y: 10 numbers (δφ, δr, δq) of node k, becomes node k+1's.
inline void advance_kinematics(const SectionFrame& g, double* y, const double* next) {
  const double half = 0.5 * g.h;
  const V3 su{y[6] + next[0], y[7] + next[1], y[8] + next[2]};
  const double se = y[9] + next[3];
  const V3 theta = half * (su.x * g.d[0] + su.y * g.d[1] + su.z * g.d[2]);
  const V3 phi{y[0], y[1], y[2]};
  const V3 r = V3{y[3], y[4], y[5]} + cross(phi, g.chord) + cross(theta, g.lever) + (half * se) * g.d[2];
  y[0] += theta.x;
  y[1] += theta.y;
  y[2] += theta.z;
  y[3] = r.x;
  y[4] = r.y;
  y[5] = r.z;
  for (int i = 0; i < 4; ++i) y[6 + i] = next[i];
}

// A node's law tangent: ∂s/∂q, diagonal plus the κ1–κ2 coupling of a nonlinear law.
struct Tangent {
  double diag[4];
  double bend = 0.0;
  [[nodiscard]] double at(int r, int c) const {
    if (r == c) return diag[r];
    return (r + c == 1) ? bend : 0.0;
  }
};

inline Tangent tangent_of(const RodLinearization& rod, std::size_t k) {
  Tangent t{};
  const double scale = rod.law_scale;
  if (rod.nodal.tangent.data.empty()) {
    for (int c = 0; c < 4; ++c) t.diag[c] = scale * rod.law_total[static_cast<std::size_t>(c)];
  } else {
    for (std::size_t c = 0; c < 4; ++c) t.diag[c] = scale * rod.nodal.tangent.at(k, c);
    t.bend = scale * rod.nodal.bend_coupling[k];
  }
  return t;
}

// ---- Row operations: rows `stride` doubles apart, `w` live lanes, in chunks of 4 doubles ----
// Explicit 4-double vectors (one AVX2 register): the rows share one scratch buffer, so a compiler
// cannot prove they do not alias and would not vectorize plain loops over them.

using v4 = double __attribute__((vector_size(32), aligned(8), may_alias));

inline v4* chunks(double* p) { return reinterpret_cast<v4*>(p); }
inline const v4* chunks(const double* p) { return reinterpret_cast<const v4*>(p); }

// a·b + c rounded once. The condensed sweeps (one rod, and four rods in lanes) are compiled with
// floating-point contraction off so that each rounds every product and sum alike; where a fused
// multiply-add is wanted, both say so here, in the same places.
template <class T>
inline T fmadd(T a, T b, T c) {
#if defined(__FMA__)
  return std::bit_cast<T>(
      _mm256_fmadd_pd(std::bit_cast<__m256d>(a), std::bit_cast<__m256d>(b), std::bit_cast<__m256d>(c)));
#else
  return a * b + c;
#endif
}
// s in every lane. Not `T{} + s`: with signed zeros kept that is an addition the compiler must
// perform (0 + (−0) = +0), one more instruction for every broadcast of the sweep.
template <class T>
inline T broadcast(double s) {
  return T{s, s, s, s};
}

// y += a x over `nc` chunks.
inline void axpy(double a, const double* x, double* y, int nc) {
  const v4* xv = chunks(x);
  v4* yv = chunks(y);
  const v4 av = broadcast<v4>(a);
  for (int c = 0; c < nc; ++c) yv[c] = fmadd(av, xv[c], yv[c]);
}

// Gauss–Jordan with scaled partial pivoting on `count` rows over lanes [first, first + count),
// rows `stride` apart with `w` live lanes. No row moves: afterwards row order[i] has 1 at lane
// first + i and 0 at the other eliminated lanes. Returns the smallest pivot relative to its row's
// scale (0 when a row is all zero or a pivot is not finite).
// What an elimination did, to replay on more lanes: step j scales row order[j] by inv[j], then
// subtracts factor[j][r] times it from row r (0 for the pivot row).
struct Elimination {
  int order[10];
  double inv[10];
  double factor[10][10];
};

// Count and W, where not 0, fix count and w at compile time (the sweep's 4 × 4 over 16 lanes: its
// loops unrolled, the same operations).
template <bool Record = true, int Count = 0, int W = 0>
inline double gauss_jordan(double* rows, int count_, int first, int stride, int w_, Elimination& e) {
  const int count = Count > 0 ? Count : count_;
  const int w = W > 0 ? W : w_;
  int* order = e.order;
  const int nc = w / 4;
  double inv_scale[10];  // 1 / each row's largest entry in the eliminated lanes (0: an empty row)
  for (int r = 0; r < count; ++r) {
    double s = 0.0;
    for (int j = 0; j < count; ++j) s = std::max(s, std::abs(rows[r * stride + first + j]));
    inv_scale[r] = s > 0.0 ? 1.0 / s : 0.0;
    order[r] = r;
  }
  double smallest = std::numeric_limits<double>::infinity();
  for (int j = 0; j < count; ++j) {
    int p = j;
    double best = -1.0;
    for (int r = j; r < count; ++r) {
      const int o = order[r];
      const double v = std::abs(rows[o * stride + first + j]) * inv_scale[o];
      if (v > best) {
        best = v;
        p = r;
      }
    }
    std::swap(order[p], order[j]);
    smallest = std::min(smallest, best);
    double* pr = rows + order[j] * stride;
    const double pivot = pr[first + j];
    if (!(best > 0.0) || !std::isfinite(pivot)) return 0.0;
    const double inv = 1.0 / pivot;
    e.inv[j] = inv;
    v4* pv = chunks(pr);
    for (int c = 0; c < nc; ++c) pv[c] *= inv;
    pr[first + j] = 1.0;
    for (int r = 0; r < count; ++r) {
      double* rr = rows + order[r] * stride;
      const double f = r == j ? 0.0 : rr[first + j];
      if constexpr (Record) e.factor[j][order[r]] = f;
      if (f == 0.0) continue;
      axpy(-f, pr, rr, nc);
      rr[first + j] = 0.0;
    }
  }
  return smallest;
}

// ---- A sweep's record, for a chord iteration's replay ----

inline void record_step(double* r, const SectionFrame& g, const double (&a)[10][4], const Elimination& el) {
  r[0] = g.h;
  for (int i = 0; i < 3; ++i) {
    r[1 + i] = g.chord[i];
    r[4 + i] = g.mid[i];
    for (int j = 0; j < 3; ++j) r[7 + 3 * i + j] = g.d[i][j];
  }
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 4; ++j) r[16 + 4 * i + j] = a[i][j];
  for (int j = 0; j < 4; ++j) {
    r[56 + j] = static_cast<double>(el.order[j]);
    r[60 + j] = el.inv[j];
    for (int i = 0; i < 4; ++i) r[64 + 4 * j + i] = el.factor[j][i];
  }
}

inline void read_step(const double* r, SectionFrame& g, double (&a)[10][4], Elimination& el) {
  g.h = r[0];
  g.chord = {r[1], r[2], r[3]};
  g.mid = {r[4], r[5], r[6]};
  for (int i = 0; i < 3; ++i) g.d[i] = {r[7 + 3 * i], r[8 + 3 * i], r[9 + 3 * i]};
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 4; ++j) a[i][j] = r[16 + 4 * i + j];
  for (int j = 0; j < 4; ++j) {
    el.order[j] = static_cast<int>(r[56 + j]);
    el.inv[j] = r[60 + j];
    for (int i = 0; i < 4; ++i) el.factor[j][i] = r[64 + 4 * j + i];
  }
}

inline void record_base(double* r, const Elimination& el, int unknowns) {
  r[0] = unknowns;
  for (int j = 0; j < unknowns; ++j) {
    r[1 + j] = static_cast<double>(el.order[j]);
    r[11 + j] = el.inv[j];
    for (int i = 0; i < unknowns; ++i) r[21 + 10 * j + i] = el.factor[j][i];
  }
}

// The base system: Π_0's rows (clamped: the strain rows alone; free: with the rod's total wrench
// balanced, δM_0 − s_0 δφ_0 + M = 0, δF_0 − K_0 δr_0 + F = 0, node 0's unit loads included)
// eliminated for y_0 of every column. loads: those at node 0. force, moment: every load's total
// about node 0.
inline CondenseReport solve_base(const RodLinearization& rod, std::span<const UnitLoad> loads, double* base, int S,
                                 int w, V3 force, V3 moment, CondensedSystem sys, CondenseReport report) {
  const bool has_stiffness = !rod.stiffness.force.empty();
  int unknowns_first = QK, unknowns = 4, equations_first = 6;
  if (rod.free_base) {
    unknowns_first = PHI;
    unknowns = 10;
    equations_first = 0;
    if (has_stiffness) {
      for (int i = 0; i < 3; ++i) {
        if (!rod.stiffness.moment.empty()) base[i * S + PHI + i] -= rod.stiffness.moment[0];
        for (int j = 0; j < 3; ++j) base[(3 + i) * S + POS + j] -= rod.stiffness.force[0](i, j);
      }
    }
    for (int i = 0; i < 3; ++i) {
      base[i * S + RHS] += moment[i];
      base[(3 + i) * S + RHS] += force[i];
    }
    for (const UnitLoad& u : loads) {
      if (u.node != 0) break;
      double* rows = base + (u.is_moment ? 0 : 3) * S;
      for (int i = 0; i < 3; ++i) rows[i * S + RHS + static_cast<int>(u.column)] += u.load[i];
    }
  }
  double* work = base + equations_first * S;
  Elimination el;
  const int* order = el.order;
  const double pivot = gauss_jordan<true>(work, unknowns, unknowns_first, S, w, el);
  if (!sys.record.empty()) {
    const std::size_t n = rod.poses.node_count();
    record_base(sys.record.data() + (n - 1) * kCondensedRecordPerStep, el, unknowns);
  }
  if (pivot < report.smallest_pivot) {
    report.smallest_pivot = pivot;
    report.node = 0;
  }
  if (!(pivot >= kCondensedPivotFloor)) {
    report.ok = false;
    report.node = 0;
    return report;
  }
  for (int c = 0; c < sys.columns; ++c) {
    double* y = sys.base.data() + 10 * c;
    for (int i = 0; i < 10; ++i) y[i] = 0.0;
    for (int i = 0; i < unknowns; ++i) y[unknowns_first + i] = -work[order[i] * S + RHS + c];
    for (int i = 0; i < 10; ++i)
      if (!std::isfinite(y[i])) report.ok = false;
  }
  return report;
}

// ---- The sweep ----

// The right-hand-side chunks [first, end) of one step, in one pass each: the interface rows'
// values (10 per column) in registers, the operations of the 16-lane pass replayed with the
// scalars it left — the section's frame, the elimination, and the interface's share `a` of
// δq_{k+1} — writing the gains and the next interface.
inline void fused_rhs_pass(const SectionFrame& g, const double (&a)[10][4], const Elimination& el, double* pi,
                           double* gain, int stride, int first, int end) {
  const double h = g.h;
  const V3 c = g.chord, b = -1.0 * g.mid;
  const V3 d0 = h * g.d[0], d1 = h * g.d[1], d2 = h * g.d[2];
  for (int j = first; j < end; ++j) {
    v4 p[10];
    for (int r = 0; r < 10; ++r) p[r] = chunks(pi + r * stride)[j];
    // δM_k += chord × δF_k (right-hand sides: no kinematic terms).
    p[0] = fmadd(broadcast<v4>(c.y), p[5], fmadd(broadcast<v4>(-c.z), p[4], p[0]));
    p[1] = fmadd(broadcast<v4>(c.z), p[3], fmadd(broadcast<v4>(-c.x), p[5], p[1]));
    p[2] = fmadd(broadcast<v4>(c.x), p[4], fmadd(broadcast<v4>(-c.y), p[3], p[2]));
    // Section force: h Rᵀ (δM + (r_k − p) × δF), h d3·δF.
    const v4 x0 = fmadd(broadcast<v4>(b.y), p[5], fmadd(broadcast<v4>(-b.z), p[4], p[0]));
    const v4 x1 = fmadd(broadcast<v4>(b.z), p[3], fmadd(broadcast<v4>(-b.x), p[5], p[1]));
    const v4 x2 = fmadd(broadcast<v4>(b.x), p[4], fmadd(broadcast<v4>(-b.y), p[3], p[2]));
    const v4 s[4] = {fmadd(broadcast<v4>(d0.z), x2, fmadd(broadcast<v4>(d0.y), x1, d0.x * x0)),
                     fmadd(broadcast<v4>(d1.z), x2, fmadd(broadcast<v4>(d1.y), x1, d1.x * x0)),
                     fmadd(broadcast<v4>(d2.z), x2, fmadd(broadcast<v4>(d2.y), x1, d2.x * x0)),
                     fmadd(broadcast<v4>(d2.z), p[5], fmadd(broadcast<v4>(d2.y), p[4], d2.x * p[3]))};
    // Node k+1's strain rows, eliminated as the 16 lanes were.
    v4 e[4];
    for (int r = 0; r < 4; ++r) e[r] = fmadd(broadcast<v4>(0.5), s[r], p[6 + r]);
    for (int step = 0; step < 4; ++step) {
      const int pr = el.order[step];
      e[pr] *= el.inv[step];
      for (int r = 0; r < 4; ++r) e[r] = fmadd(broadcast<v4>(-el.factor[step][r]), e[pr], e[r]);
    }
    v4 u[4];
    for (int r = 0; r < 4; ++r) {
      u[r] = -e[el.order[r]];
      chunks(gain + r * stride)[j] = u[r];
    }
    for (int r = 0; r < 10; ++r) {
      const v4 in = r < 6 ? p[r] : 0.5 * s[r - 6];
      chunks(pi + r * stride)[j] =
          fmadd(broadcast<v4>(a[r][3]), u[3],
                fmadd(broadcast<v4>(a[r][2]), u[2],
                      fmadd(broadcast<v4>(a[r][1]), u[1], fmadd(broadcast<v4>(a[r][0]), u[0], in))));
    }
  }
}

// Two 2-double halves of a and b (0, 1: a's low, high; 2, 3: b's) as one vector: one
// vperm2f128 (the generic shuffle may compile to forms valgrind cannot decode: the instruction gate).
template <int Low, int High>
inline v4 halves(v4 a, v4 b) {
#if defined(__AVX__)
  return std::bit_cast<v4>(
      _mm256_permute2f128_pd(std::bit_cast<__m256d>(a), std::bit_cast<__m256d>(b), Low | (High << 4)));
#else
  constexpr int l = 2 * Low, h = 2 * High;
  return __builtin_shufflevector(a, b, l, l + 1, h, h + 1);
#endif
}

// a with its last lane 0.
inline v4 without_last(v4 a) {
#if defined(__AVX__)
  return std::bit_cast<v4>(_mm256_blend_pd(std::bit_cast<__m256d>(a), _mm256_setzero_pd(), 8));
#else
  return v4{a[0], a[1], a[2], 0.0};
#endif
}

// Node k+1's interface rows [δw_{k+1}; c_{k+1}] (pi: 10 rows over (δφ_{k+1}, δr_{k+1}, δq_{k+1},
// right-hand sides)) written over z = (δφ_k, δr_k, δq_k, δq_{k+1}, the first two right-hand sides)
// through the section's transport xr: the 6 kinematic rows of δφ_{k+1}, δr_{k+1} over z. Of the
// transport's 16 lanes only the strain lanes are a full 6 × 4 block (the same for δq_k and
// δq_{k+1}); the rotation lanes are the identity plus δr's skew(chord), the position lanes the
// identity, the right-hand sides zero. So each row is the strain block once (six multiply-adds on
// one register) placed in both strain chunks, and three multiply-adds for the first chunk — the
// products and sums of the dense 16-lane product, in its order, without the terms that are exact
// zeros and ones: the same numbers.
inline void interface_over_z(const double* pi, const double* xr, double* wr, double* cr, int S) {
  v4 block[6];  // the transport's strain lanes of δφ_{k+1}, δr_{k+1}: xr rows' lanes QK..QK+3
  for (int i = 0; i < 6; ++i) block[i] = *reinterpret_cast<const v4*>(xr + i * S + QK);
  // δr_{k+1}'s first chunk: its rotation lanes (δφ_k × chord) and, at lane POS, δr_k's identity.
  const v4 rotation_x = chunks(xr + 3 * S)[0], rotation_y = chunks(xr + 4 * S)[0], rotation_z = chunks(xr + 5 * S)[0];
  for (int r = 0; r < 10; ++r) {
    const double* p = pi + r * S;
    double* out = r < 6 ? wr + r * S : cr + (r - 6) * S;
    const v4 p0 = broadcast<v4>(p[0]), p1 = broadcast<v4>(p[1]), p2 = broadcast<v4>(p[2]);
    const v4 p3 = broadcast<v4>(p[3]), p4 = broadcast<v4>(p[4]), p5 = broadcast<v4>(p[5]);
    const v4 strain =
        fmadd(p5, block[5],
              fmadd(p4, block[4], fmadd(p3, block[3], fmadd(p2, block[2], fmadd(p1, block[1], p0 * block[0])))));
    const v4 next = strain + *reinterpret_cast<const v4*>(p + QK);  // δq_{k+1}'s lanes: + Π's own
    const v4* in = chunks(p);
    v4* o = chunks(out);
    // δφ 0–2 (the identity: the row's own) and δr 0 (from rotation_x's 1 at lane POS).
    o[0] = fmadd(p5, rotation_z, fmadd(p4, rotation_y, fmadd(p3, rotation_x, without_last(in[0]))));
    o[1] = halves<0, 2>(in[1], strain);  // δr 1–2, δq_k 0–1
    o[2] = halves<1, 2>(strain, next);   // δq_k 2–3, δq_{k+1} 0–1
    o[3] = halves<1, 3>(next, in[3]);    // δq_{k+1} 2–3, rhs 0–1
  }
}

// One function of ~290 lines on purpose: it is one recurrence from the tip to the base whose state
// (the rows of Π, the interface's w and c, the distal wrench and its derivatives) passes from node
// to node; each step of it is marked below (the tip, a joint, the wrench, the interface, section
// k's force, node k+1's strain rows, U_k, the base). Split into functions, every call would carry
// that state, and rod_condense_lanes must stay step for step the same (decision 0041: the same
// bits for a rod alone and in a lane).
template <int W>
CondenseReport sweep(const RodLinearization& rod, StrainView<const double> residual, std::span<const UnitLoad> loads,
                     CondensedSystem sys, const CondensedRange& range) {
  // Rows are `stride` doubles apart (room for every column); `w` lanes are live. A unit load's
  // column is zero distal to its node and the columns are numbered in the order the sweep meets
  // them, so at each node only a prefix of them is live.
  const int stride = W > 0 ? W : condensed_width(sys.columns);
  int w = W > 0 ? W : condensed_width(1);
  const int S = W > 0 ? W : stride;  // a compile-time stride where there is one
  const std::size_t last = range.last;
  const std::size_t first = range.first;
  const bool has_stiffness = !rod.stiffness.force.empty();
  constexpr int kZc = kZ / 4;       // chunks of the kinematic lanes
  double* pi = sys.scratch.data();  // 10 rows: the interface (w 0–5: δM, δF; c 6–9)
  double* wr = pi + 10 * S;         // 6 rows: δM_k, δF_k over z
  double* cr = wr + 6 * S;          // 4 rows: node k+1's strain equations over z
  double* sr = cr + 4 * S;          // 4 rows: section k's generalized force over z
  double* xr = sr + 4 * S;          // 6 rows: δφ_{k+1}, δr_{k+1} over z (16 lanes)
  CondenseReport report;

  for (int i = 0; i < 10 * S; ++i) pi[i] = 0.0;
  V3 force{}, moment{};  // loads beyond node k+1 (moment about r_{k+1})
  if (!range.joint) {
    // The tip: no distal wrench; node N's strain rows see only its own law.
    const Tangent t = tangent_of(rod, last);
    const double m = rod.section_length[last - 1] / 3.0;
    for (int c = 0; c < 4; ++c) {
      for (int j = 0; j < 4; ++j) pi[(6 + c) * S + QK + j] = -m * t.at(c, j);
      pi[(6 + c) * S + RHS] = residual.at(last, static_cast<std::size_t>(c));
    }
  } else {
    // A joint: δw_m and λ_c = c_m + A_mm δq_m are the unknowns of columns 1–10; node m's rows
    // keep its own law's −A_mm δq_m. The loads beyond m shape the linearization all the same.
    const Tangent t = tangent_of(rod, last);
    const double m = (rod.section_length[last - 1] + rod.section_length[last]) / 3.0;
    for (int r = 0; r < 6; ++r) pi[r * S + RHS + 1 + r] = 1.0;
    for (int c = 0; c < 4; ++c) {
      for (int j = 0; j < 4; ++j) pi[(6 + c) * S + QK + j] = -m * t.at(c, j);
      pi[(6 + c) * S + RHS + 7 + c] = 1.0;
    }
    if constexpr (W == 0) w = std::max(w, condensed_width(1 + kJointColumns));
    const std::size_t n = rod.poses.node_count();
    const V3 rm = load(rod.poses.node_position, last);
    for (std::size_t j = last + 1; j < n; ++j) {
      const V3 f = load(rod.node_force, j);
      force = force + f;
      moment = moment + load(rod.node_moment, j) + cross(load(rod.poses.node_position, j) - rm, f);
    }
  }
  std::size_t next_load = 0;
  while (next_load < loads.size() && loads[next_load].node > last) ++next_load;
  Tangent t_next = tangent_of(rod, last);
  for (std::size_t k = last; k-- > first;) {
    const SectionFrame g = section_frame(rod, k);
    const double h = g.h;
    const double h_prev = k > 0 ? rod.section_length[k - 1] : 0.0;
    const Tangent t_k = tangent_of(rod, k);
    // The distal wrench at node k: F_k = F_{k+1} + f_{k+1}, M_k = M_{k+1} + m_{k+1} + chord × F_k.
    force = force + load(rod.node_force, k + 1);
    moment = moment + load(rod.node_moment, k + 1) + cross(g.chord, force);
    // The columns whose loads sit at node k+1 come alive here: a unit load joins the wrench
    // transported across section k. (Right-hand-side lanes pass the interface's change of
    // unknowns unchanged, so it can join w_{k+1} before it.)
    for (; next_load < loads.size() && loads[next_load].node == k + 1; ++next_load) {
      const UnitLoad& u = loads[next_load];
      if constexpr (W == 0) w = std::max(w, condensed_width(static_cast<int>(u.column) + 1));
      double* rows = pi + (u.is_moment ? 0 : 3) * S;
      for (int i = 0; i < 3; ++i) rows[i * S + RHS + static_cast<int>(u.column)] += u.load[i];
    }
    // The 16 lanes of the unknowns (and the first two right-hand sides) first; the remaining
    // right-hand sides in one fused pass below, with the scalars this pass leaves.
    const int nc = kZc;

    // δφ_{k+1}, δr_{k+1} over z.
    for (int i = 0; i < 6; ++i)
      for (int c = 0; c < kZc; ++c) chunks(xr + i * S)[c] = v4{};
    const double half = 0.5 * h;
    for (int i = 0; i < 3; ++i) {
      double* xp = xr + i * S;
      double* xq = xr + (3 + i) * S;
      xp[PHI + i] = 1.0;
      xq[POS + i] = 1.0;
      for (int j = 0; j < 3; ++j) {
        const double theta = half * g.d[j][i];
        // θ × lever: column j of −skew(lever) Θ = ½h d_j × lever.
        const double arm = half * cross(g.d[j], g.lever)[i];
        xp[QK + j] = xp[QN + j] = theta;
        xq[QK + j] = xq[QN + j] = arm;
      }
      xq[QK + 3] = xq[QN + 3] = half * g.d[2][i];
    }
    // δφ_k × chord.
    xr[3 * S + PHI + 1] = g.chord.z;
    xr[3 * S + PHI + 2] = -g.chord.y;
    xr[4 * S + PHI + 0] = -g.chord.z;
    xr[4 * S + PHI + 2] = g.chord.x;
    xr[5 * S + PHI + 0] = g.chord.y;
    xr[5 * S + PHI + 1] = -g.chord.x;

    interface_over_z(pi, xr, wr, cr, S);
    // δF_k = δF_{k+1} − K_{k+1} δr_{k+1}.
    double* fr = wr + 3 * S;
    double* mr = wr;
    if (has_stiffness) {
      const Eigen::Matrix3d& kk = rod.stiffness.force[k + 1];
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          if (kk(i, j) != 0.0) axpy(-kk(i, j), xr + (3 + j) * S, fr + i * S, kZc);
    }
    // δM_k = δM_{k+1} + chord × δF_k − F_k × (δr_{k+1} − δr_k) − s δφ_{k+1}.
    {
      const V3 c = g.chord;
      v4* m0 = chunks(mr);
      v4* m1 = chunks(mr + S);
      v4* m2 = chunks(mr + 2 * S);
      const v4* f0 = chunks(fr);
      const v4* f1 = chunks(fr + S);
      const v4* f2 = chunks(fr + 2 * S);
      for (int j = 0; j < nc; ++j) {
        const v4 a0 = f0[j], a1 = f1[j], a2 = f2[j];
        m0[j] = fmadd(broadcast<v4>(c.y), a2, fmadd(broadcast<v4>(-c.z), a1, m0[j]));
        m1[j] = fmadd(broadcast<v4>(c.z), a0, fmadd(broadcast<v4>(-c.x), a2, m1[j]));
        m2[j] = fmadd(broadcast<v4>(c.x), a1, fmadd(broadcast<v4>(-c.y), a0, m2[j]));
      }
      const V3 f = force;
      const v4* r0 = chunks(xr + 3 * S);
      const v4* r1 = chunks(xr + 4 * S);
      const v4* r2 = chunks(xr + 5 * S);
      for (int j = 0; j < kZc; ++j) {
        const v4 a0 = r0[j], a1 = r1[j], a2 = r2[j];
        m0[j] = fmadd(broadcast<v4>(-f.y), a2, fmadd(broadcast<v4>(f.z), a1, m0[j]));
        m1[j] = fmadd(broadcast<v4>(-f.z), a0, fmadd(broadcast<v4>(f.x), a2, m1[j]));
        m2[j] = fmadd(broadcast<v4>(-f.x), a1, fmadd(broadcast<v4>(f.y), a0, m2[j]));
      }
      // ... and + F_k × δr_k (the unit lanes of δr_k that δr_{k+1} carries, taken back).
      mr[POS + 1] -= f.z;
      mr[POS + 2] += f.y;
      mr[S + POS] += f.z;
      mr[S + POS + 2] -= f.x;
      mr[2 * S + POS] -= f.y;
      mr[2 * S + POS + 1] += f.x;
      if (has_stiffness && !rod.stiffness.moment.empty()) {
        const double sp = rod.stiffness.moment[k + 1];
        if (sp != 0.0)
          for (int i = 0; i < 3; ++i) axpy(-sp, xr + i * S, mr + i * S, kZc);
      }
    }
    // Section k's generalized force: h Rᵀ (δM_k + (r_k − p) × δF_k), h d3·δF_k, plus the terms of
    // its own rotation (P) and strain (X).
    {
      const V3 b = -1.0 * g.mid;  // r_k − p
      const v4* m0 = chunks(mr);
      const v4* m1 = chunks(mr + S);
      const v4* m2 = chunks(mr + 2 * S);
      const v4* f0 = chunks(fr);
      const v4* f1 = chunks(fr + S);
      const v4* f2 = chunks(fr + 2 * S);
      const V3 d0 = h * g.d[0], d1 = h * g.d[1], d2 = h * g.d[2];
      v4* s0 = chunks(sr);
      v4* s1 = chunks(sr + S);
      v4* s2 = chunks(sr + 2 * S);
      v4* s3 = chunks(sr + 3 * S);
      for (int j = 0; j < nc; ++j) {
        const v4 a0 = f0[j], a1 = f1[j], a2 = f2[j];
        const v4 x0 = fmadd(broadcast<v4>(b.y), a2, fmadd(broadcast<v4>(-b.z), a1, m0[j]));
        const v4 x1 = fmadd(broadcast<v4>(b.z), a0, fmadd(broadcast<v4>(-b.x), a2, m1[j]));
        const v4 x2 = fmadd(broadcast<v4>(b.x), a1, fmadd(broadcast<v4>(-b.y), a0, m2[j]));
        s0[j] = fmadd(broadcast<v4>(d0.z), x2, fmadd(broadcast<v4>(d0.y), x1, d0.x * x0));
        s1[j] = fmadd(broadcast<v4>(d1.z), x2, fmadd(broadcast<v4>(d1.y), x1, d1.x * x0));
        s2[j] = fmadd(broadcast<v4>(d2.z), x2, fmadd(broadcast<v4>(d2.y), x1, d2.x * x0));
        s3[j] = fmadd(broadcast<v4>(d2.z), a2, fmadd(broadcast<v4>(d2.y), a1, d2.x * a0));
      }
      const V3 m_mid = moment + cross(b, force);
      const V3 fm{dot(g.d[0], force), dot(g.d[1], force), dot(g.d[2], force)};
      const V3 mmat{dot(g.d[0], m_mid), dot(g.d[1], m_mid), dot(g.d[2], m_mid)};
      for (int c = 0; c < 3; ++c) {
        const V3 p = h * (cross(g.d[c], m_mid) - cross(cross(g.d[c], force), g.mid));
        sr[c * S + PHI] += p.x;
        sr[c * S + PHI + 1] += p.y;
        sr[c * S + PHI + 2] += p.z;
      }
      const V3 p3 = h * cross(g.d[2], force);
      sr[3 * S + PHI] += p3.x;
      sr[3 * S + PHI + 1] += p3.y;
      sr[3 * S + PHI + 2] += p3.z;
      const double xq = 0.25 * h * h;
      const double x[4][4] = {{0.0, -xq * mmat.z, xq * mmat.y, xq * fm.y},
                              {xq * mmat.z, 0.0, -xq * mmat.x, -xq * fm.x},
                              {-xq * mmat.y, xq * mmat.x, 0.0, 0.0},
                              {-xq * fm.y, xq * fm.x, 0.0, 0.0}};
      for (int c = 0; c < 4; ++c)
        for (int j = 0; j < 4; ++j) {
          sr[c * S + QK + j] += x[c][j];
          sr[c * S + QN + j] += x[c][j];
        }
    }
    // Node k+1's strain rows: ½ δs_k − A_{k+1,k} δq_k + c_{k+1} = 0.
    const double m_side = h / 6.0;
    for (int c = 0; c < 4; ++c) {
      double* row = cr + c * S;
      axpy(0.5, sr + c * S, row, nc);
      for (int j = 0; j < 4; ++j) row[QK + j] -= m_side * t_k.at(c, j);
    }
    // δq_{k+1} = U_k (y_k, 1).
    Elimination el;
    const int* order = el.order;
    const double pivot = gauss_jordan<true, 4, kZ>(cr, 4, QN, S, kZ, el);
    if (pivot < report.smallest_pivot) {
      report.smallest_pivot = pivot;
      report.node = k + 1;
    }
    if (!(pivot >= kCondensedPivotFloor)) {
      report.ok = false;
      report.node = k + 1;
      return report;
    }
    double* gain = sys.gain.data() + (k - first) * 4 * static_cast<std::size_t>(S);
    for (int r = 0; r < 4; ++r) {
      v4* u = chunks(gain + r * S);
      const v4* row = chunks(cr + order[r] * S);
      for (int j = 0; j < nc; ++j) u[j] = -row[j];
      for (int j = w / 4; j < S / 4; ++j) u[j] = v4{};
      for (int j = 0; j < 4; ++j) gain[r * S + QN + j] = 0.0;
    }
    // The interface of node k: w_k, and c_k = ½ δs_k − A_kk δq_k − A_{k,k+1} δq_{k+1} + ρ_k, with
    // δq_{k+1} substituted.
    const double m_self = (h_prev + h) / 3.0;
    for (int c = 0; c < 4; ++c) {
      double* row = pi + (6 + c) * S;
      const v4* srow = chunks(sr + c * S);
      for (int j = 0; j < nc; ++j) chunks(row)[j] = 0.5 * srow[j];
      for (int j = 0; j < 4; ++j) {
        row[QK + j] -= m_self * t_k.at(c, j);
        row[QN + j] -= m_side * t_next.at(c, j);
      }
      row[RHS] += residual.at(k, static_cast<std::size_t>(c));
    }
    const v4* g0 = chunks(gain);
    const v4* g1 = chunks(gain + S);
    const v4* g2 = chunks(gain + 2 * S);
    const v4* g3 = chunks(gain + 3 * S);
    double a[10][4];  // how much of δq_{k+1} each interface row holds
    for (int r = 0; r < 10; ++r) {
      const double* row = r < 6 ? wr + r * S : pi + r * S;
      for (int j = 0; j < 4; ++j) a[r][j] = row[QN + j];
      const v4* in = chunks(row);
      v4* out = chunks(pi + r * S);
      for (int j = 0; j < nc; ++j)
        out[j] = fmadd(broadcast<v4>(a[r][3]), g3[j],
                       fmadd(broadcast<v4>(a[r][2]), g2[j],
                             fmadd(broadcast<v4>(a[r][1]), g1[j], fmadd(broadcast<v4>(a[r][0]), g0[j], in[j]))));
      for (int j = 0; j < 4; ++j) pi[r * S + QN + j] = 0.0;
    }
    if constexpr (W == 0) fused_rhs_pass(g, a, el, pi, gain, S, kZc, w / 4);
    if (!sys.record.empty()) record_step(sys.record.data() + k * kCondensedRecordPerStep, g, a, el);
    t_next = t_k;
  }

  if (first > 0) {  // a tip part: its interface at node `first`
    for (int i = 0; i < 10 * S; ++i) range.interface[static_cast<std::size_t>(i)] = pi[i];
    return report;
  }
  // The base: y_0 for every column. Every column is live here (loads at node 0 start here).
  force = force + load(rod.node_force, 0);
  moment = moment + load(rod.node_moment, 0);
  return solve_base(rod, loads.subspan(next_load), pi, S, stride, force, moment, sys, report);
}

}  // namespace haustra::kernels::condensed
