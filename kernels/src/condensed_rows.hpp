#pragma once
// The condensed sweep's recurrence (rod_condensed.hpp), written once over its value type T: double
// for one rod, L (a 4-double vector) for four rods of one node count, one per lane. A section's
// frame, the row operations over (δφ_k, δr_k, δq_k, δq_{k+1}, right-hand sides), the pivoted 4×4
// elimination and the tip → base sweep itself. Rows are `S` contiguous T; a row operation works on
// packs P of four doubles: four columns of one rod (v4) or one column of four rods (L). W = 16 (the
// residual alone) is a compile-time width, W = 0 a run-time one (one rod only).
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>
#include <type_traits>
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

// ---- The value types and their helpers: what differs between one rod and four ----
// Explicit 4-double vectors (one AVX2 register): the rows share one scratch buffer, so a compiler
// cannot prove they do not alias and would not vectorize plain loops over them.
using v4 = double __attribute__((vector_size(32), aligned(8), may_alias));
using L = double __attribute__((vector_size(32)));  // four rods, one per lane
using Mask = decltype(L{} < L{});                   // a comparison of two L

template <class T>
constexpr bool kOne = std::is_same_v<T, double>;
template <class T>
constexpr int kPer = kOne<T> ? 4 : 1;  // columns per pack

inline v4* chunks(double* p) { return reinterpret_cast<v4*>(p); }
inline const v4* chunks(const double* p) { return reinterpret_cast<const v4*>(p); }
inline L* chunks(L* p) { return p; }
inline const L* chunks(const L* p) { return p; }
inline v4 zero_pack(const double*) { return v4{}; }
inline L zero_pack(const L*) { return L{}; }

// a·b + c rounded once. The condensed sweeps are compiled with floating-point contraction off so
// that every product and sum rounds alike for a rod alone and in a lane; where a fused
// multiply-add is wanted, it is said here.
template <class T>
inline T fmadd(T a, T b, T c) {
#if defined(__FMA__)
  if constexpr (kOne<T>)
    return std::fma(a, b, c);
  else
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
  if constexpr (sizeof(T) == sizeof(double))
    return s;
  else
    return T{s, s, s, s};
}
// A T as a pack's coefficient: one rod's scalar in every lane, or the four rods' as they are.
inline v4 coefficient(double s) { return broadcast<v4>(s); }
inline L coefficient(L s) { return s; }
inline double select(bool m, double a, double b) { return m ? a : b; }
inline int select(bool m, int a, int b) { return m ? a : b; }
inline L select(Mask m, L a, L b) { return m ? a : b; }
inline L abs(L a) { return a < 0.0 ? -a : a; }
using std::abs;
// Whether a coefficient can be skipped (one rod: an exact zero; four rods: never, no branch per lane).
inline bool nonzero(double a) { return a != 0.0; }
inline bool nonzero(L) { return true; }
// The pivot row p (per rod) moved to row j, with its scale and (one rod) its number: one rod's
// rows by one exchange, four rods' (a 4 × 4) by blends, lane by lane where p is each later row.
inline void swap_pivot(int r, int j, double* rows, int stride, int np, double* scale, int* order) {
  if (r == j) return;
  std::swap_ranges(chunks(rows + j * stride), chunks(rows + j * stride) + np, chunks(rows + r * stride));
  std::swap(scale[j], scale[r]);
  std::swap(order[j], order[r]);
}
inline void swap_pivot(L p, int j, L* rows, int stride, int np, L* scale, int* /*order*/) {
  for (int r = j + 1; r < 4; ++r) {
    const Mask m = p == static_cast<double>(r);
    L* a = rows + j * stride;
    L* b = rows + r * stride;
    for (int e = 0; e < np; ++e) {
      const L x = a[e], y = b[e];
      a[e] = select(m, y, x);
      b[e] = select(m, x, y);
    }
    const L x = scale[j], y = scale[r];
    scale[j] = select(m, y, x);
    scale[r] = select(m, x, y);
  }
}

template <class T>
struct V3 {
  T x{}, y{}, z{};
  T operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  friend V3 operator+(V3 a, V3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
  friend V3 operator-(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
  friend V3 operator*(T s, V3 a) { return {s * a.x, s * a.y, s * a.z}; }
  friend V3 cross(V3 a, V3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
  friend T dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
};

// The rods a sweep reads: one, or four of one node count (their bases, laws and loads their own).
template <class T>
struct Rods {
  static constexpr int kLanes = sizeof(T) / sizeof(double);
  std::array<const RodLinearization*, kLanes> rod{};
  std::array<StrainView<const double>, kLanes> residual{};
  // f(lane) of every lane: one rod's number, or the four rods' gathered into a vector.
  template <class F>
  T each(F&& f) const {
    if constexpr (kLanes == 1)
      return f(0);
    else
      return T{f(0), f(1), f(2), f(3)};
  }
  template <class F>
  T get(F&& f) const {
    return each([&](int l) { return f(*rod[static_cast<std::size_t>(l)]); });
  }
  template <class F>
  V3<T> get3(F&& view, std::size_t i) const {
    return {get([&](const RodLinearization& r) { return view(r).x[i]; }),
            get([&](const RodLinearization& r) { return view(r).y[i]; }),
            get([&](const RodLinearization& r) { return view(r).z[i]; })};
  }
  V3<T> force(std::size_t i) const {
    return get3([](const RodLinearization& r) { return r.node_force; }, i);
  }
  V3<T> moment(std::size_t i) const {
    return get3([](const RodLinearization& r) { return r.node_moment; }, i);
  }
  V3<T> node(std::size_t i) const {
    return get3([](const RodLinearization& r) { return r.poses.node_position; }, i);
  }
  T length(std::size_t k) const {
    return get([&](const RodLinearization& r) { return r.section_length[k]; });
  }
  T rho(std::size_t k, std::size_t c) const {
    return each([&](int l) { return residual[static_cast<std::size_t>(l)].at(k, c); });
  }
};
inline V3<double> load(Vec3View<const double> v, std::size_t i) { return {v.x[i], v.y[i], v.z[i]}; }

// Section k: its midpoint frame and the lever arms the kinematics need.
template <class T>
struct SectionFrame {
  V3<T> d[3];   // material axes d1 d2 d3 (world)
  T h;          // length
  V3<T> chord;  // r_{k+1} − r_k
  V3<T> lever;  // r_{k+1} − p_k (midpoint to the distal node)
  V3<T> mid;    // p_k − r_k
};

template <class T>
inline SectionFrame<T> section_frame(const Rods<T>& rods, std::size_t k) {
  SectionFrame<T> g;
  auto q = [&](auto part) {
    return rods.get([&](const RodLinearization& r) { return part(r.poses.mid_rotation)[k]; });
  };
  const T w = q([](const auto&v) { return v.w; }), x = q([](const auto&v) { return v.x; });
  const T y = q([](const auto&v) { return v.y; }), z = q([](const auto&v) { return v.z; });
  // The columns of the rotation matrix of a unit quaternion.
  g.d[0] = {1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + w * z), 2.0 * (x * z - w * y)};
  g.d[1] = {2.0 * (x * y - w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z + w * x)};
  g.d[2] = {2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y)};
  g.h = rods.length(k);
  const V3<T> rk = rods.node(k), rn = rods.node(k + 1);
  const V3<T> p = rods.get3([](const RodLinearization& r) { return r.poses.mid_position; }, k);
  g.chord = rn - rk;
  g.lever = rn - p;
  g.mid = p - rk;
  return g;
}
inline SectionFrame<double> section_frame(const RodLinearization& rod, std::size_t k) {
  return section_frame(Rods<double>{{&rod}, {}}, k);
}

// Node k+1's δφ, δr from node k's and both strains: the rows 4–9 of rod_newton.hpp.
// θ = ½h R (δu_k + δu_{k+1}); δφ_{k+1} = δφ_k + θ; δr_{k+1} = δr_k + δφ_k × chord + θ × lever
// + ½h d3 (δε_k + δε_{k+1}). y: 10 numbers (δφ, δr, δq) of node k, becomes node k+1's.
inline void advance_kinematics(const SectionFrame<double>& g, double* y, const double* next) {
  using V = V3<double>;
  const double half = 0.5 * g.h;
  const V su{y[6] + next[0], y[7] + next[1], y[8] + next[2]};
  const double se = y[9] + next[3];
  const V theta = half * (su.x * g.d[0] + su.y * g.d[1] + su.z * g.d[2]);
  const V phi{y[0], y[1], y[2]};
  const V r = V{y[3], y[4], y[5]} + cross(phi, g.chord) + cross(theta, g.lever) + (half * se) * g.d[2];
  y[0] += theta.x;
  y[1] += theta.y;
  y[2] += theta.z;
  y[3] = r.x;
  y[4] = r.y;
  y[5] = r.z;
  for (int i = 0; i < 4; ++i) y[6 + i] = next[i];
}

// A node's law tangent: ∂s/∂q, diagonal plus the κ1–κ2 coupling of a nonlinear law.
template <class T>
struct Tangent {
  T diag[4];
  T bend{};
  [[nodiscard]] T at(int r, int c) const {
    if (r == c) return diag[r];
    return (r + c == 1) ? bend : T{};
  }
  // Whether entry (r, c) can be other than zero. A row less m · (a structural zero) is the row
  // itself, bit for bit, for a finite m ≥ 0 (a mass: h/6, (h_prev + h)/3): those are skipped.
  [[nodiscard]] static constexpr bool coupled(int r, int c) { return r == c || r + c == 1; }
};

inline Tangent<double> tangent_of(const RodLinearization& rod, std::size_t k) {
  Tangent<double> t{};
  const double scale = rod.law_scale;
  if (rod.nodal.tangent.data.empty()) {
    for (int c = 0; c < 4; ++c) t.diag[c] = scale * rod.law_total[static_cast<std::size_t>(c)];
  } else {
    for (std::size_t c = 0; c < 4; ++c) t.diag[c] = scale * rod.nodal.tangent.at(k, c);
    t.bend = scale * rod.nodal.bend_coupling[k];
  }
  return t;
}
template <class T>
inline Tangent<T> tangent_of(const Rods<T>& rods, std::size_t k) {
  std::array<Tangent<double>, Rods<T>::kLanes> s;
  for (std::size_t l = 0; l < s.size(); ++l) s[l] = tangent_of(*rods.rod[l], k);
  Tangent<T> t;
  for (int c = 0; c < 4; ++c) t.diag[c] = rods.each([&](int l) { return s[static_cast<std::size_t>(l)].diag[c]; });
  t.bend = rods.each([&](int l) { return s[static_cast<std::size_t>(l)].bend; });
  return t;
}

// ---- Row operations ----

// y += a x over `n` packs.
template <class T>
inline void axpy(T a, const T* x, T* y, int n) {
  const auto* xv = chunks(x);
  auto* yv = chunks(y);
  const auto av = coefficient(a);
  for (int c = 0; c < n; ++c) yv[c] = fmadd(av, xv[c], yv[c]);
}

// Pack c of a row with its lane `lane` (of the row) set to v where the pack holds it.
template <class T, class P>
inline P with_lane(P p, int c, int lane, double v) {
  if constexpr (kOne<T>) {
    if (lane / 4 == c) p[lane % 4] = v;
    return p;
  } else {
    return c == lane ? broadcast<P>(v) : p;
  }
}

// What an elimination did, to replay on more columns (one rod): step j scales row order[j] (its
// rows numbered as they were before any swap) by inv[j], then subtracts factor[j][r] times it from
// row r (0 for the pivot row).
struct Elimination {
  int order[10];
  double inv[10];
  double factor[10][10];
};

// Gauss–Jordan with scaled partial pivoting on `count` rows over lanes [first, first + count),
// rows `stride` apart with `w` live lanes; the pivot row chosen per rod and swapped into place (by
// blends for four rods). Afterwards row i has 1 at lane first + i and 0 at the other eliminated
// lanes. Returns the smallest pivot relative to its row's scale (0 when a row is all zero or a
// pivot is not finite). Count and W, where not 0, fix count and w at compile time (the sweep's
// 4 × 4 over 16 lanes: its loops unrolled, the same operations). Factors false: e.factor is not
// written (nothing will replay the elimination: ≈ 70 instructions of a sweep's step).
template <class T>
inline auto row_number(int r) {
  if constexpr (kOne<T>)
    return r;
  else
    return broadcast<T>(r);
}

template <class T, int Count = 0, int W = 0, bool Factors = true>
[[gnu::always_inline]] inline T gauss_jordan(T* rows, int count_, int first, int stride, int w_, Elimination& e) {
  const int count = Count > 0 ? Count : count_;
  const int np = (W > 0 ? W : w_) / kPer<T>;
  T inv_scale[10];  // 1 / each row's largest entry in the eliminated lanes (0: an empty row)
  for (int r = 0; r < count; ++r) {
    T s{};
    for (int j = 0; j < count; ++j) {
      const T a = abs(rows[r * stride + first + j]);
      s = select(a > s, a, s);
    }
    inv_scale[r] = select(s > 0.0, 1.0 / s, T{});
    e.order[r] = r;
  }
  T smallest = broadcast<T>(std::numeric_limits<double>::infinity());
#pragma GCC unroll 4
  for (int j = 0; j < count; ++j) {
    T best = broadcast<T>(-1.0);
    auto p = row_number<T>(j);  // the pivot row: a number, or four rods' numbers as doubles
    for (int r = j; r < count; ++r) {
      const T v = abs(rows[r * stride + first + j]) * inv_scale[r];
      const auto m = v > best;
      best = select(m, v, best);
      p = select(m, row_number<T>(r), p);
    }
    swap_pivot(p, j, rows, stride, np, inv_scale, e.order);
    smallest = select(best < smallest, best, smallest);
    smallest = select(best > 0.0, smallest, T{});  // stays 0: every later pivot is ≥ 0 or fails again
    T* pr = rows + j * stride;
    const T inv = 1.0 / pr[first + j];
    if constexpr (kOne<T>) e.inv[j] = inv;
    const auto iv = coefficient(inv);
    // The pivot's lane set to 1 and the other rows' to 0 in the packs as they are stored (a scalar
    // store into a pack that the next step loads whole would stall the load).
    for (int c = 0; c < np; ++c) chunks(pr)[c] = with_lane<T>(chunks(pr)[c] * iv, c, first + j, 1.0);
    for (int r = 0; r < count; ++r) {
      T* rr = rows + r * stride;
      const T f = r == j ? T{} : rr[first + j];
      if constexpr (kOne<T> && Factors) e.factor[j][e.order[r]] = f;
      if (r == j || !nonzero(f)) continue;
      const auto fv = coefficient(-f);
      for (int c = 0; c < np; ++c)
        chunks(rr)[c] = with_lane<T>(fmadd(fv, chunks(pr)[c], chunks(rr)[c]), c, first + j, 0.0);
    }
  }
  return smallest;
}

// ---- A sweep's record, for a chord iteration's replay ----

inline void record_step(double* r, const SectionFrame<double>& g, const double (&a)[10][4], const Elimination& el) {
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

inline void read_step(const double* r, SectionFrame<double>& g, double (&a)[10][4], Elimination& el) {
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

// The base system of one rod: Π_0's rows (clamped: the strain rows alone; free: with the rod's
// total wrench balanced, δM_0 − s_0 δφ_0 + M = 0, δF_0 − K_0 δr_0 + F = 0, node 0's unit loads
// included) eliminated for y_0 of every column. loads: those at node 0. force, moment: every
// load's total about node 0.
inline CondenseReport solve_base(const RodLinearization& rod, std::span<const UnitLoad> loads, double* base, int S,
                                 int w, V3<double> force, V3<double> moment, CondensedSystem sys,
                                 CondenseReport report) {
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
  const double pivot = gauss_jordan<double>(work, unknowns, unknowns_first, S, w, el);
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
    for (int i = 0; i < unknowns; ++i) y[unknowns_first + i] = -work[i * S + RHS + c];
    for (int i = 0; i < 10; ++i)
      if (!std::isfinite(y[i])) report.ok = false;
  }
  return report;
}

// ---- One step replayed on more right-hand sides ----

// A step of the sweep on right-hand-side columns alone, with the scalars its 16-lane pass left —
// the section's frame, the elimination, the interface's share `a` of δq_{k+1}: p (the interface's
// 10 values at node k+1) becomes node k's, u the gains'. P: v4 (four columns: the sweep's wide
// pass) or double (the residual column: a chord iteration's replay, which adds node k's residual
// rho). The same operations as the 16-lane pass's on those lanes: the same bits.
template <class P>
inline void replay_step(const SectionFrame<double>& g, const double (&a)[10][4], const Elimination& el, P (&p)[10],
                        P (&u)[4], const double* rho = nullptr) {
  const auto bc = [](double s) { return broadcast<P>(s); };
  const double h = g.h;
  const V3<double> c = g.chord, b = -1.0 * g.mid;
  const V3<double> d0 = h * g.d[0], d1 = h * g.d[1], d2 = h * g.d[2];
  // δM_k += chord × δF_k (right-hand sides: no kinematic terms).
  p[0] = fmadd(bc(c.y), p[5], fmadd(bc(-c.z), p[4], p[0]));
  p[1] = fmadd(bc(c.z), p[3], fmadd(bc(-c.x), p[5], p[1]));
  p[2] = fmadd(bc(c.x), p[4], fmadd(bc(-c.y), p[3], p[2]));
  // Section force: h Rᵀ (δM + (r_k − p) × δF), h d3·δF.
  const P x0 = fmadd(bc(b.y), p[5], fmadd(bc(-b.z), p[4], p[0]));
  const P x1 = fmadd(bc(b.z), p[3], fmadd(bc(-b.x), p[5], p[1]));
  const P x2 = fmadd(bc(b.x), p[4], fmadd(bc(-b.y), p[3], p[2]));
  const P s[4] = {
      fmadd(bc(d0.z), x2, fmadd(bc(d0.y), x1, d0.x * x0)), fmadd(bc(d1.z), x2, fmadd(bc(d1.y), x1, d1.x * x0)),
      fmadd(bc(d2.z), x2, fmadd(bc(d2.y), x1, d2.x * x0)), fmadd(bc(d2.z), p[5], fmadd(bc(d2.y), p[4], d2.x * p[3]))};
  // Node k+1's strain rows, eliminated as the 16 lanes were.
  P e[4];
  for (int r = 0; r < 4; ++r) e[r] = fmadd(bc(0.5), s[r], p[6 + r]);
  for (int step = 0; step < 4; ++step) {
    const int pr = el.order[step];
    e[pr] *= el.inv[step];
    for (int r = 0; r < 4; ++r) e[r] = fmadd(bc(-el.factor[step][r]), e[pr], e[r]);
  }
  for (int r = 0; r < 4; ++r) u[r] = -e[el.order[r]];
  for (int r = 0; r < 10; ++r) {
    P in = r < 6 ? p[r] : 0.5 * s[r - 6];
    if (r >= 6 && rho != nullptr) in += rho[r - 6];
    p[r] = fmadd(bc(a[r][3]), u[3], fmadd(bc(a[r][2]), u[2], fmadd(bc(a[r][1]), u[1], fmadd(bc(a[r][0]), u[0], in))));
  }
}

// ---- Node k+1's interface over z ----

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
// identity, the right-hand sides zero. So each row is the strain block once (six multiply-adds)
// placed in both strain lanes, and three multiply-adds for the rotation lanes and δr's first — the
// products and sums of the dense 16-lane product, in its order, without the terms that are exact
// zeros and ones: the same numbers. One rod's form works on whole packs of four lanes.
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
// Four rods' form: the same operations lane by lane.
inline void interface_over_z(const L* pi, const L* xr, L* wr, L* cr, int S) {
  for (int r = 0; r < 10; ++r) {
    const L* p = pi + r * S;
    L* out = r < 6 ? wr + r * S : cr + (r - 6) * S;
    for (int j = 0; j < 4; ++j) {
      const L strain =
          fmadd(p[5], xr[5 * S + QK + j],
                fmadd(p[4], xr[4 * S + QK + j],
                      fmadd(p[3], xr[3 * S + QK + j],
                            fmadd(p[2], xr[2 * S + QK + j], fmadd(p[1], xr[S + QK + j], p[0] * xr[QK + j])))));
      out[QK + j] = strain;
      out[QN + j] = strain + p[QK + j];
    }
    for (int j = 0; j < 4; ++j)
      out[j] = fmadd(p[5], xr[5 * S + j], fmadd(p[4], xr[4 * S + j], fmadd(p[3], xr[3 * S + j], j < 3 ? p[j] : L{})));
    out[POS + 1] = p[POS + 1];
    out[POS + 2] = p[POS + 2];
    out[RHS] = p[RHS];
    out[RHS + 1] = p[RHS + 1];
  }
}

// A pack of the values lane(l) of its lanes l: pack j of a row (one rod: lanes 4j..4j+3; four
// rods: lane j, one value per rod).
template <class T, class F>
inline auto lane_pack(int j, F&& lane) {
  if constexpr (kOne<T>)
    return v4{lane(4 * j), lane(4 * j + 1), lane(4 * j + 2), lane(4 * j + 3)};
  else
    return lane(j);
}

// Pack j of a row with δq_{k+1}'s lanes set to +0 (one blend, not scalar stores a pack would reload).
template <class T, class P>
inline P without_next_strain(P v, int j) {
  static_assert(QN == 10, "one rod: δq_{k+1} is the upper half of chunk 2 and the lower of chunk 3");
  if constexpr (kOne<T>) {
#if defined(__AVX__)
    if (j == 2) return std::bit_cast<P>(_mm256_blend_pd(std::bit_cast<__m256d>(v), _mm256_setzero_pd(), 12));
    if (j == 3) return std::bit_cast<P>(_mm256_blend_pd(std::bit_cast<__m256d>(v), _mm256_setzero_pd(), 3));
#else
    if (j == 2) return P{v[0], v[1], 0.0, 0.0};
    if (j == 3) return P{0.0, 0.0, v[2], v[3]};
#endif
    return v;
  } else {
    return j >= QN && j < QN + 4 ? P{} : v;
  }
}

// ---- The sweep ----

// One function of ~300 lines on purpose: it is one recurrence from the tip to the base whose state
// (the rows of Π, the interface's w and c, the distal wrench and its derivatives) passes from node
// to node; each step of it is marked below (the tip, a joint, the wrench, the interface, section
// k's force, node k+1's strain rows, U_k, the base). T = double: one rod (unit loads, a part of a
// split rod, a record for chord iterations: W = 0 for more than the residual column). T = L: four
// rods of one node count, the residual column alone (W = 16), the same operations lane by lane —
// so a rod gives the same bits alone or in a lane (decision 0041). Each rod's gains go to its
// system, its report to `reports`; scratch: 26 rows of S values of T (room for 30).
template <class T, int W>
void sweep(const Rods<T>& rods_in, std::span<const UnitLoad> loads,
           const std::array<CondensedSystem, Rods<T>::kLanes>& sys, const CondensedRange& range, T* scratch,
           std::array<CondenseReport, Rods<T>::kLanes>& reports) {
  static_assert(kOne<T> || W == kZ, "four rods in lanes: the residual column alone");
  const Rods<T> rods = rods_in;  // a local copy: the row stores (may_alias) cannot reach it
  constexpr int per = kPer<T>;
  // Rows are `stride` doubles apart (room for every column); `w` lanes are live. A unit load's
  // column is zero distal to its node and the columns are numbered in the order the sweep meets
  // them, so at each node only a prefix of them is live.
  const int stride = W > 0 ? W : condensed_width(sys[0].columns);
  int w = condensed_width(1);
  const int S = W > 0 ? W : stride;  // a compile-time stride where there is one
  const std::size_t last = range.last;
  const std::size_t first = range.first;
  const RodLinearization& rod0 = *rods.rod[0];
  const bool has_stiffness = !rod0.stiffness.force.empty();  // alike in every lane
  constexpr int nc = kZ / per;                               // packs of the kinematic lanes
  T* pi = scratch;                                           // 10 rows: the interface (w 0–5: δM, δF; c 6–9)
  T* wr = pi + 10 * S;                                       // 6 rows: δM_k, δF_k over z
  T* cr = wr + 6 * S;                                        // 4 rows: node k+1's strain equations over z
  T* xr = cr + 4 * S;                                        // 6 rows: δφ_{k+1}, δr_{k+1} over z (16 lanes)
  T smallest = broadcast<T>(1.0), at{}, failed{};            // per rod: the smallest pivot, its node, a failure
  T lane_gain[kOne<T> ? 1 : 4 * kZ];                         // four rods' gains of a step, before each goes to its rod

  for (int i = 0; i < 10 * S; ++i) pi[i] = T{};
  V3<T> force{}, moment{};  // loads beyond node k+1 (moment about r_{k+1})
  if (!range.joint) {
    // The tip: no distal wrench; node N's strain rows see only its own law.
    const Tangent<T> t = tangent_of(rods, last);
    const T m = rods.length(last - 1) / 3.0;
    for (int c = 0; c < 4; ++c) {
      for (int j = 0; j < 4; ++j) pi[(6 + c) * S + QK + j] = -m * t.at(c, j);
      pi[(6 + c) * S + RHS] = rods.rho(last, static_cast<std::size_t>(c));
    }
  } else if constexpr (kOne<T>) {
    // A joint: δw_m and λ_c = c_m + A_mm δq_m are the unknowns of columns 1–10; node m's rows
    // keep its own law's −A_mm δq_m. The loads beyond m shape the linearization all the same.
    const Tangent<T> t = tangent_of(rods, last);
    const T m = (rods.length(last - 1) + rods.length(last)) / 3.0;
    for (int r = 0; r < 6; ++r) pi[r * S + RHS + 1 + r] = 1.0;
    for (int c = 0; c < 4; ++c) {
      for (int j = 0; j < 4; ++j) pi[(6 + c) * S + QK + j] = -m * t.at(c, j);
      pi[(6 + c) * S + RHS + 7 + c] = 1.0;
    }
    w = std::max(w, condensed_width(1 + kJointColumns));
    const std::size_t n = rod0.poses.node_count();
    const V3<T> rm = rods.node(last);
    for (std::size_t j = last + 1; j < n; ++j) {
      const V3<T> f = rods.force(j);
      force = force + f;
      moment = moment + rods.moment(j) + cross(rods.node(j) - rm, f);
    }
  }
  std::size_t next_load = 0;
  while (next_load < loads.size() && loads[next_load].node > last) ++next_load;
  Tangent<T> t_next = tangent_of(rods, last);
  // The transport rows' lanes that no node writes (every node writes the same ones).
  for (int i = 0; i < 6; ++i)
    for (int c = 0; c < nc; ++c) chunks(xr + i * S)[c] = zero_pack(xr);
  for (std::size_t k = last; k-- > first;) {
    const SectionFrame<T> g = section_frame(rods, k);
    const T h = g.h;
    const T h_prev = k > 0 ? rods.length(k - 1) : T{};
    const Tangent<T> t_k = tangent_of(rods, k);
    // The distal wrench at node k: F_k = F_{k+1} + f_{k+1}, M_k = M_{k+1} + m_{k+1} + chord × F_k.
    force = force + rods.force(k + 1);
    moment = moment + rods.moment(k + 1) + cross(g.chord, force);
    // The columns whose loads sit at node k+1 come alive here (one rod): a unit load joins the
    // wrench transported across section k. (Right-hand-side lanes pass the interface's change of
    // unknowns unchanged, so it can join w_{k+1} before it.)
    for (; next_load < loads.size() && loads[next_load].node == k + 1; ++next_load) {
      const UnitLoad& u = loads[next_load];
      w = std::max(w, condensed_width(static_cast<int>(u.column) + 1));
      T* rows = pi + (u.is_moment ? 0 : 3) * S;
      for (int i = 0; i < 3; ++i) rows[i * S + RHS + static_cast<int>(u.column)] += u.load[i];
    }
    // The 16 lanes of the unknowns (and the first two right-hand sides) first; one rod's remaining
    // right-hand sides in one replay pass below, with the scalars this pass leaves.

    // δφ_{k+1}, δr_{k+1} over z (the lanes written below; the others stay the zeros set before the loop).
    const T half = 0.5 * h;
    if constexpr (kOne<T>) {
      // One rod: each row's four packs built in registers and stored whole (the loads of them below
      // would stall on scalar stores); lanes not named are 0, as set before the loop.
      const V3<T> cz = g.chord;
      const T chord_rows[3][3] = {{0.0, cz.z, -cz.y}, {-cz.z, 0.0, cz.x}, {cz.y, -cz.x, 0.0}};
      for (int i = 0; i < 3; ++i) {
        v4* xp = chunks(xr + i * S);
        v4* xq = chunks(xr + (3 + i) * S);
        const T th0 = half * g.d[0][i], th1 = half * g.d[1][i], th2 = half * g.d[2][i];
        // θ × lever: column j of −skew(lever) Θ = ½h d_j × lever.
        const T arm0 = half * cross(g.d[0], g.lever)[i], arm1 = half * cross(g.d[1], g.lever)[i];
        const T arm2 = half * cross(g.d[2], g.lever)[i], e = half * g.d[2][i];
        static_assert(PHI == 0 && POS == 3 && QK == 6 && QN == 10, "the packs below follow this layout");
        xp[0] = v4{i == 0 ? 1.0 : 0.0, i == 1 ? 1.0 : 0.0, i == 2 ? 1.0 : 0.0, 0.0};
        xp[1] = v4{0.0, 0.0, th0, th1};
        xp[2] = v4{th2, 0.0, th0, th1};
        xp[3] = v4{th2, 0.0, 0.0, 0.0};
        xq[0] = v4{chord_rows[i][0], chord_rows[i][1], chord_rows[i][2], i == 0 ? 1.0 : 0.0};
        xq[1] = v4{i == 1 ? 1.0 : 0.0, i == 2 ? 1.0 : 0.0, arm0, arm1};
        xq[2] = v4{arm2, e, arm0, arm1};
        xq[3] = v4{arm2, e, 0.0, 0.0};
      }
    } else {
      for (int i = 0; i < 3; ++i) {
        T* xp = xr + i * S;
        T* xq = xr + (3 + i) * S;
        xp[PHI + i] = broadcast<T>(1.0);
        xq[POS + i] = broadcast<T>(1.0);
        for (int j = 0; j < 3; ++j) {
          const T theta = half * g.d[j][i];
          const T arm = half * cross(g.d[j], g.lever)[i];
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
    }

    interface_over_z(pi, xr, wr, cr, S);
    // δF_k = δF_{k+1} − K_{k+1} δr_{k+1}.
    T* fr = wr + 3 * S;
    T* mr = wr;
    if (has_stiffness) {
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
          const T kk = rods.get([&](const RodLinearization& r) { return r.stiffness.force[k + 1](i, j); });
          if (nonzero(kk)) axpy(-kk, xr + (3 + j) * S, fr + i * S, nc);
        }
    }
    // The rest of the step's rows in one pass over the 16 lanes, each pack loaded once: δM_k, section
    // k's generalized force s_k (kept in registers), node k+1's strain rows and node k's interface
    // rows c_k. The terms that sit in single lanes (F_k × δr_k's unit lanes, s_k's own rotation and
    // strain terms, the laws' tangents, ρ_k) are added as whole packs with −0 in the other lanes
    // (x + (−0) = x for every x, −0 included): each lane's operations and their order are the
    // previous separate passes', so the same bits, without a scalar store that a pack reloads.
    //   δM_k = δM_{k+1} + chord × δF_k − F_k × (δr_{k+1} − δr_k) − s δφ_{k+1};
    //   s_k = (h Rᵀ (δM_k + (r_k − p) × δF_k), h d3·δF_k) + P (its own rotation) + X (its strain);
    //   node k+1's strain rows: ½ s_k − A_{k+1,k} δq_k + c_{k+1} = 0;
    //   c_k = ½ s_k − A_kk δq_k − A_{k,k+1} δq_{k+1} + ρ_k (δq_{k+1} substituted below).
    {
      const V3<T> c = g.chord, f = force;
      const V3<T> b = broadcast<T>(-1.0) * g.mid;  // r_k − p
      const V3<T> d0 = h * g.d[0], d1 = h * g.d[1], d2 = h * g.d[2];
      const V3<T> m_mid = moment + cross(b, force);
      const V3<T> fm{dot(g.d[0], force), dot(g.d[1], force), dot(g.d[2], force)};
      const V3<T> mmat{dot(g.d[0], m_mid), dot(g.d[1], m_mid), dot(g.d[2], m_mid)};
      V3<T> p[4];
      for (int i = 0; i < 3; ++i) p[i] = h * (cross(g.d[i], m_mid) - cross(cross(g.d[i], force), g.mid));
      p[3] = h * cross(g.d[2], force);
      const T xq = 0.25 * h * h;
      const T x[4][4] = {{T{}, -xq * mmat.z, xq * mmat.y, xq * fm.y},
                         {xq * mmat.z, T{}, -xq * mmat.x, -xq * fm.x},
                         {-xq * mmat.y, xq * mmat.x, T{}, T{}},
                         {-xq * fm.y, xq * fm.x, T{}, T{}}};
      const T m_side = h / 6.0, m_self = (h_prev + h) / 3.0;
      const T sp = has_stiffness && !rod0.stiffness.moment.empty()
                       ? rods.get([&](const RodLinearization& r) { return r.stiffness.moment[k + 1]; })
                       : T{};
      const bool with_sp = has_stiffness && !rod0.stiffness.moment.empty() && nonzero(sp);
      const T nz = broadcast<T>(-0.0);
      // Lane l's single-lane term of each row (−0: none).
      const auto moment_lane = [&](int i, int l) {  // + F_k × δr_k
        const T v[3][3] = {{nz, -f.z, f.y}, {f.z, nz, -f.x}, {-f.y, f.x, nz}};
        return l >= POS && l < POS + 3 ? v[i][l - POS] : nz;
      };
      const auto force_lane = [&](int i, int l) {  // P and X
        if (l < PHI + 3) return p[i][l - PHI];
        if (l >= QK && l < QK + 4) return x[i][l - QK];
        if (l >= QN && l < QN + 4) return x[i][l - QN];
        return nz;
      };
      const auto strain_lane = [&](int i, int l) {  // − A_{k+1,k}
        return l >= QK && l < QK + 4 && Tangent<T>::coupled(i, l - QK) ? -(m_side * t_k.at(i, l - QK)) : nz;
      };
      const auto interface_lane = [&](int i, int l) {  // − A_kk, − A_{k,k+1}, ρ_k
        if (l >= QK && l < QK + 4 && Tangent<T>::coupled(i, l - QK)) return -(m_self * t_k.at(i, l - QK));
        if (l >= QN && l < QN + 4 && Tangent<T>::coupled(i, l - QN)) return -(m_side * t_next.at(i, l - QN));
        if (l == RHS) return rods.rho(k, static_cast<std::size_t>(i));
        return nz;
      };
      const auto cf = [](T s) { return coefficient(s); };
#pragma GCC unroll 16
      for (int j = 0; j < nc; ++j) {
        const auto a0 = chunks(fr)[j], a1 = chunks(fr + S)[j], a2 = chunks(fr + 2 * S)[j];
        const auto r0 = chunks(xr + 3 * S)[j], r1 = chunks(xr + 4 * S)[j], r2 = chunks(xr + 5 * S)[j];
        auto n0 = fmadd(cf(c.y), a2, fmadd(cf(-c.z), a1, chunks(mr)[j]));
        auto n1 = fmadd(cf(c.z), a0, fmadd(cf(-c.x), a2, chunks(mr + S)[j]));
        auto n2 = fmadd(cf(c.x), a1, fmadd(cf(-c.y), a0, chunks(mr + 2 * S)[j]));
        decltype(n0) m[3] = {fmadd(cf(-f.y), r2, fmadd(cf(f.z), r1, n0)), fmadd(cf(-f.z), r0, fmadd(cf(f.x), r2, n1)),
                             fmadd(cf(-f.x), r1, fmadd(cf(f.y), r0, n2))};
        const bool transport_lanes = j * per < POS + 3 && (j + 1) * per > POS;
        for (int i = 0; i < 3; ++i) {
          if (transport_lanes) m[i] += lane_pack<T>(j, [&](int l) { return moment_lane(i, l); });
          if (with_sp) m[i] = fmadd(cf(-sp), chunks(xr + i * S)[j], m[i]);
          chunks(mr + i * S)[j] = m[i];
        }
        const auto x0 = fmadd(cf(b.y), a2, fmadd(cf(-b.z), a1, m[0]));
        const auto x1 = fmadd(cf(b.z), a0, fmadd(cf(-b.x), a2, m[1]));
        const auto x2 = fmadd(cf(b.x), a1, fmadd(cf(-b.y), a0, m[2]));
        const decltype(n0) s[4] = {
            fmadd(cf(d0.z), x2, fmadd(cf(d0.y), x1, d0.x * x0)), fmadd(cf(d1.z), x2, fmadd(cf(d1.y), x1, d1.x * x0)),
            fmadd(cf(d2.z), x2, fmadd(cf(d2.y), x1, d2.x * x0)), fmadd(cf(d2.z), a2, fmadd(cf(d2.y), a1, d2.x * a0))};
        const bool own_lanes = j * per < PHI + 3 || ((j + 1) * per > QK && j * per < QN + 4);
        const bool strain_lanes = (j + 1) * per > QK && j * per < QK + 4;
        const bool interface_lanes = own_lanes || (j * per <= RHS && (j + 1) * per > RHS);
        for (int i = 0; i < 4; ++i) {
          const auto si = own_lanes ? s[i] + lane_pack<T>(j, [&](int l) { return force_lane(i, l); }) : s[i];
          auto cv = fmadd(coefficient(broadcast<T>(0.5)), si, chunks(cr + i * S)[j]);
          if (strain_lanes) cv += lane_pack<T>(j, [&](int l) { return strain_lane(i, l); });
          chunks(cr + i * S)[j] = cv;
          auto pv = 0.5 * si;
          if (interface_lanes) pv += lane_pack<T>(j, [&](int l) { return interface_lane(i, l); });
          chunks(pi + (6 + i) * S)[j] = pv;
        }
      }
    }
    // δq_{k+1} = U_k (y_k, 1).
    Elimination el;
    // The factors only where a replay needs them: right-hand sides past the 16 lanes, or a record.
    const T pivot = kOne<T> && (w > kZ || !sys[0].record.empty()) ? gauss_jordan<T, 4, kZ>(cr, 4, QN, S, kZ, el)
                                                                  : gauss_jordan<T, 4, kZ, false>(cr, 4, QN, S, kZ, el);
    const auto lower = pivot < smallest;
    smallest = select(lower, pivot, smallest);
    at = select(lower, broadcast<T>(static_cast<double>(k + 1)), at);
    if constexpr (kOne<T>) {
      if (!(pivot >= kCondensedPivotFloor)) {
        reports[0] = {false, pivot, k + 1};
        return;
      }
    } else {
      failed = select(pivot >= kCondensedPivotFloor, failed, broadcast<T>(1.0));
    }
    T* gain = lane_gain;
    if constexpr (kOne<T>) gain = sys[0].gain.data() + (k - first) * 4 * static_cast<std::size_t>(S);
    for (int r = 0; r < 4; ++r) {
      auto* u = chunks(gain + r * S);
      const auto* row = chunks(cr + r * S);
      for (int j = 0; j < nc; ++j) u[j] = without_next_strain<T>(-row[j], j);
      if constexpr (W > 0) {
        for (int j = nc; j < S / per; ++j)  // unrolled: the chunks past the 16 lanes that are not live
          if (j >= w / per) u[j] = zero_pack(gain);
      } else {
        for (int j = w / per; j < S / per; ++j) u[j] = zero_pack(gain);
      }
    }
    // The interface of node k (w_k, and c_k from the pass above) with δq_{k+1} substituted.
    const auto* g0 = chunks(gain);
    const auto* g1 = chunks(gain + S);
    const auto* g2 = chunks(gain + 2 * S);
    const auto* g3 = chunks(gain + 3 * S);
    T a[10][4];  // how much of δq_{k+1} each interface row holds
    for (int r = 0; r < 10; ++r) {
      const T* row = r < 6 ? wr + r * S : pi + r * S;
      for (int j = 0; j < 4; ++j) a[r][j] = row[QN + j];
      const auto* in = chunks(row);
      auto* out = chunks(pi + r * S);
      const auto a0 = coefficient(a[r][0]), a1 = coefficient(a[r][1]);
      const auto a2 = coefficient(a[r][2]), a3 = coefficient(a[r][3]);
      for (int j = 0; j < nc; ++j)
        out[j] =
            without_next_strain<T>(fmadd(a3, g3[j], fmadd(a2, g2[j], fmadd(a1, g1[j], fmadd(a0, g0[j], in[j])))), j);
    }
    if constexpr (kOne<T>) {
      // The remaining right-hand sides, chunk by chunk, and the step's record.
      for (int j = nc; j < w / 4; ++j) {
        v4 p[10], u[4];
        for (int r = 0; r < 10; ++r) p[r] = chunks(pi + r * S)[j];
        replay_step(g, a, el, p, u);
        for (int r = 0; r < 4; ++r) chunks(gain + r * S)[j] = u[r];
        for (int r = 0; r < 10; ++r) chunks(pi + r * S)[j] = p[r];
      }
      if (!sys[0].record.empty()) record_step(sys[0].record.data() + k * kCondensedRecordPerStep, g, a, el);
    } else {
      for (std::size_t l = 0; l < sys.size(); ++l)  // lane l into its own rod's gains
        for (int e = 0; e < 4 * kZ; ++e) sys[l].gain[k * 4 * kZ + static_cast<std::size_t>(e)] = gain[e][l];
    }
    t_next = t_k;
  }

  // The base: y_0 for every column. Every column is live here (loads at node 0 start here).
  force = force + rods.force(0);
  moment = moment + rods.moment(0);
  for (std::size_t l = 0; l < sys.size(); ++l) {
    auto lane = [&](const T& v) {
      if constexpr (kOne<T>)
        return v;
      else
        return v[l];
    };
    CondenseReport report{lane(failed) == 0.0, lane(smallest), static_cast<std::size_t>(lane(at))};
    if constexpr (kOne<T>) {
      if (first > 0) {  // a tip part: its interface at node `first`
        for (int i = 0; i < 10 * S; ++i) range.interface[static_cast<std::size_t>(i)] = pi[i];
        reports[0] = report;
        return;
      }
      reports[0] = solve_base(rod0, loads.subspan(next_load), pi, S, stride, force, moment, sys[0], report);
    } else {
      if (!report.ok) {
        reports[l] = report;
        continue;
      }
      double base[10 * kZ];
      for (int e = 0; e < 10 * kZ; ++e) base[e] = pi[e][l];
      const V3<double> f{force.x[l], force.y[l], force.z[l]}, m{moment.x[l], moment.y[l], moment.z[l]};
      reports[l] = solve_base(*rods.rod[l], {}, base, kZ, kZ, f, m, sys[l], report);
    }
  }
}

}  // namespace haustra::kernels::condensed
