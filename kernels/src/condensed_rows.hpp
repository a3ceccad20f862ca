#pragma once
// The condensed sweep's inner workings (rod_condensed.hpp): a section's frame, the row operations
// over (δφ_k, δr_k, δq_k, δq_{k+1}, right-hand sides), and the tip → base sweep itself. Rows are
// `w` contiguous doubles; W = 16 (the residual alone) is a compile-time width, W = 0 a run-time one.
#include <algorithm>
#include <cmath>
#include <limits>

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

// The same for `cols` right-hand sides at once: y is 10 rows × cols, next 4 rows × cols.
inline void advance_kinematics_columns(const SectionFrame& g, double* y, const double* next, std::size_t cols) {
  const double half = 0.5 * g.h;
  double t[3][3];  // ½h R
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) t[i][j] = half * g.d[j][i];
  const V3 c = g.chord, l = g.lever, d3 = half * g.d[2];
  for (std::size_t k = 0; k < cols; ++k) {
    const double s0 = y[6 * cols + k] + next[k], s1 = y[7 * cols + k] + next[cols + k],
                 s2 = y[8 * cols + k] + next[2 * cols + k], se = y[9 * cols + k] + next[3 * cols + k];
    const V3 theta{t[0][0] * s0 + t[0][1] * s1 + t[0][2] * s2, t[1][0] * s0 + t[1][1] * s1 + t[1][2] * s2,
                   t[2][0] * s0 + t[2][1] * s1 + t[2][2] * s2};
    const V3 phi{y[k], y[cols + k], y[2 * cols + k]};
    const V3 dr = cross(phi, c) + cross(theta, l) + se * d3;
    y[k] += theta.x;
    y[cols + k] += theta.y;
    y[2 * cols + k] += theta.z;
    y[3 * cols + k] += dr.x;
    y[4 * cols + k] += dr.y;
    y[5 * cols + k] += dr.z;
    for (std::size_t i = 0; i < 4; ++i) y[(6 + i) * cols + k] = next[i * cols + k];
  }
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

// ---- Row operations over `w` lanes (W: compile-time width, or 0 for the run-time w) ----

template <int W>
inline void zero(double* r, int w) {
  const int n = W > 0 ? W : w;
  for (int j = 0; j < n; ++j) r[j] = 0.0;
}

template <int W>
inline void copy(const double* __restrict from, double* __restrict to, int w) {
  const int n = W > 0 ? W : w;
  for (int j = 0; j < n; ++j) to[j] = from[j];
}

template <int W>
inline void axpy(double a, const double* __restrict x, double* __restrict y, int w) {
  const int n = W > 0 ? W : w;
  for (int j = 0; j < n; ++j) y[j] += a * x[j];
}

// y += a x over the first 16 lanes (what kinematic rows can hold).
inline void axpy16(double a, const double* __restrict x, double* __restrict y) {
  for (int j = 0; j < kZ; ++j) y[j] += a * x[j];
}

// Gauss–Jordan with scaled partial pivoting on `count` rows over lanes [first, first + count):
// afterwards row i has 1 at lane first + i and 0 at the other eliminated lanes. Returns the
// smallest pivot relative to its row's scale (0 when a row is all zero).
template <int W>
inline double gauss_jordan(double* rows, int count, int first, int w) {
  const int n = W > 0 ? W : w;
  double scale[10];
  for (int r = 0; r < count; ++r) {
    double s = 0.0;
    for (int j = 0; j < count; ++j) s = std::max(s, std::abs(rows[r * n + first + j]));
    scale[r] = s;
  }
  double smallest = std::numeric_limits<double>::infinity();
  for (int j = 0; j < count; ++j) {
    int p = j;
    double best = -1.0;
    for (int r = j; r < count; ++r) {
      const double v = scale[r] > 0.0 ? std::abs(rows[r * n + first + j]) / scale[r] : 0.0;
      if (v > best) {
        best = v;
        p = r;
      }
    }
    if (p != j) {
      std::swap_ranges(rows + p * n, rows + (p + 1) * n, rows + j * n);
      std::swap(scale[p], scale[j]);
    }
    smallest = std::min(smallest, best);
    double* pr = rows + j * n;
    const double pivot = pr[first + j];
    if (!(best > 0.0) || !std::isfinite(pivot)) return 0.0;
    const double inv = 1.0 / pivot;
    for (int c = 0; c < n; ++c) pr[c] *= inv;
    pr[first + j] = 1.0;
    for (int r = 0; r < count; ++r) {
      if (r == j) continue;
      double* rr = rows + r * n;
      const double f = rr[first + j];
      if (f == 0.0) continue;
      for (int c = 0; c < n; ++c) rr[c] -= f * pr[c];
      rr[first + j] = 0.0;
    }
  }
  return smallest;
}

// ---- The sweep ----

template <int W>
CondenseReport sweep(const RodLinearization& rod, StrainView<const double> residual, std::span<const UnitLoad> loads,
                     CondensedSystem sys) {
  const int w = W > 0 ? W : condensed_width(sys.columns);
  const std::size_t n = rod.poses.node_count();
  const std::size_t last = n - 1;
  const bool has_stiffness = !rod.stiffness.force.empty();
  double* pi = sys.scratch.data();  // 10 rows: the interface (w 0–5: δM, δF; c 6–9)
  double* wr = pi + 10 * w;         // 6 rows: δM_k, δF_k over z
  double* cr = wr + 6 * w;          // 4 rows: node k+1's strain equations over z
  double* sr = cr + 4 * w;          // 4 rows: section k's generalized force over z
  double* xr = sr + 4 * w;          // 6 rows: δφ_{k+1}, δr_{k+1} over z (16 lanes)
  double* mm = xr + 6 * w;          // 3 rows: the distal moment about the midpoint
  CondenseReport report;

  // The tip: no distal wrench; node N's strain rows see only its own law.
  for (int i = 0; i < 10 * w; ++i) pi[i] = 0.0;
  {
    const Tangent t = tangent_of(rod, last);
    const double m = rod.section_length[last - 1] / 3.0;
    for (int c = 0; c < 4; ++c) {
      for (int j = 0; j < 4; ++j) pi[(6 + c) * w + QK + j] = -m * t.at(c, j);
      pi[(6 + c) * w + RHS] = residual.at(last, static_cast<std::size_t>(c));
    }
  }
  std::size_t next_load = 0;
  while (next_load < loads.size() && loads[next_load].node > last) ++next_load;
  V3 force{}, moment{};  // loads beyond node k+1 (moment about r_{k+1})
  Tangent t_next = tangent_of(rod, last);
  for (std::size_t k = last; k-- > 0;) {
    const SectionFrame g = section_frame(rod, k);
    const double h = g.h;
    const double h_prev = k > 0 ? rod.section_length[k - 1] : 0.0;
    const Tangent t_k = tangent_of(rod, k);
    // The distal wrench at node k: F_k = F_{k+1} + f_{k+1}, M_k = M_{k+1} + m_{k+1} + chord × F_k.
    force = force + load(rod.node_force, k + 1);
    moment = moment + load(rod.node_moment, k + 1) + cross(g.chord, force);

    // δφ_{k+1}, δr_{k+1} over z.
    for (int i = 0; i < 6 * w; ++i) xr[i] = 0.0;
    const double half = 0.5 * h;
    for (int i = 0; i < 3; ++i) {
      double* xp = xr + i * w;
      double* xq = xr + (3 + i) * w;
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
    xr[3 * w + PHI + 1] = g.chord.z;
    xr[3 * w + PHI + 2] = -g.chord.y;
    xr[4 * w + PHI + 0] = -g.chord.z;
    xr[4 * w + PHI + 2] = g.chord.x;
    xr[5 * w + PHI + 0] = g.chord.y;
    xr[5 * w + PHI + 1] = -g.chord.x;

    // The interface of node k+1 over z: w_{k+1} into wr, c_{k+1} into cr.
    for (int r = 0; r < 10; ++r) {
      const double* p = pi + r * w;
      double* out = r < 6 ? wr + r * w : cr + (r - 6) * w;
      for (int j = 0; j < kZ; ++j) out[j] = 0.0;
      for (int i = 0; i < 6; ++i)
        if (p[i] != 0.0) axpy16(p[i], xr + i * w, out);
      for (int j = 0; j < 4; ++j) out[QN + j] += p[QK + j];
      for (int j = RHS; j < w; ++j) out[j] = p[j];
    }
    // Unit loads at node k+1 join the wrench transported across section k.
    for (; next_load < loads.size() && loads[next_load].node == k + 1; ++next_load) {
      const UnitLoad& u = loads[next_load];
      double* rows = wr + (u.is_moment ? 0 : 3) * w;
      for (int i = 0; i < 3; ++i) rows[i * w + RHS + static_cast<int>(u.column)] += u.load[i];
    }
    // δF_k = δF_{k+1} − K_{k+1} δr_{k+1}.
    double* fr = wr + 3 * w;
    double* mr = wr;
    if (has_stiffness) {
      const Eigen::Matrix3d& kk = rod.stiffness.force[k + 1];
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          if (kk(i, j) != 0.0) axpy16(-kk(i, j), xr + (3 + j) * w, fr + i * w);
    }
    // δM_k = δM_{k+1} + chord × δF_k − F_k × (δr_{k+1} − δr_k) − s δφ_{k+1}.
    {
      const V3 c = g.chord;
      for (int j = 0; j < w; ++j) {
        const double f0 = fr[j], f1 = fr[w + j], f2 = fr[2 * w + j];
        mr[j] += c.y * f2 - c.z * f1;
        mr[w + j] += c.z * f0 - c.x * f2;
        mr[2 * w + j] += c.x * f1 - c.y * f0;
      }
      const V3 f = force;
      for (int j = 0; j < kZ; ++j) {
        const double r0 = xr[3 * w + j], r1 = xr[4 * w + j], r2 = xr[5 * w + j];
        mr[j] -= f.y * r2 - f.z * r1;
        mr[w + j] -= f.z * r0 - f.x * r2;
        mr[2 * w + j] -= f.x * r1 - f.y * r0;
      }
      // ... and + F_k × δr_k (the unit lanes of δr_k that δr_{k+1} carries, taken back).
      mr[POS + 1] -= f.z;
      mr[POS + 2] += f.y;
      mr[w + POS] += f.z;
      mr[w + POS + 2] -= f.x;
      mr[2 * w + POS] -= f.y;
      mr[2 * w + POS + 1] += f.x;
      if (has_stiffness && !rod.stiffness.moment.empty()) {
        const double s = rod.stiffness.moment[k + 1];
        if (s != 0.0)
          for (int i = 0; i < 3; ++i) axpy16(-s, xr + i * w, mr + i * w);
      }
    }
    // Section k's generalized force: h Rᵀ (δM_k + (r_k − p) × δF_k), h d3·δF_k, plus the terms of
    // its own rotation (P) and strain (X).
    {
      const V3 b = -1.0 * g.mid;  // r_k − p
      for (int j = 0; j < w; ++j) {
        const double f0 = fr[j], f1 = fr[w + j], f2 = fr[2 * w + j];
        mm[j] = mr[j] + b.y * f2 - b.z * f1;
        mm[w + j] = mr[w + j] + b.z * f0 - b.x * f2;
        mm[2 * w + j] = mr[2 * w + j] + b.x * f1 - b.y * f0;
      }
      for (int c = 0; c < 3; ++c) {
        double* s = sr + c * w;
        const V3 dc = h * g.d[c];
        for (int j = 0; j < w; ++j) s[j] = dc.x * mm[j] + dc.y * mm[w + j] + dc.z * mm[2 * w + j];
      }
      {
        double* s = sr + 3 * w;
        const V3 dc = h * g.d[2];
        for (int j = 0; j < w; ++j) s[j] = dc.x * fr[j] + dc.y * fr[w + j] + dc.z * fr[2 * w + j];
      }
      const V3 m_mid = moment + cross(b, force);
      const V3 fm{dot(g.d[0], force), dot(g.d[1], force), dot(g.d[2], force)};
      const V3 mmat{dot(g.d[0], m_mid), dot(g.d[1], m_mid), dot(g.d[2], m_mid)};
      for (int c = 0; c < 3; ++c) {
        const V3 p = h * (cross(g.d[c], m_mid) - cross(cross(g.d[c], force), g.mid));
        sr[c * w + PHI] += p.x;
        sr[c * w + PHI + 1] += p.y;
        sr[c * w + PHI + 2] += p.z;
      }
      const V3 p3 = h * cross(g.d[2], force);
      sr[3 * w + PHI] += p3.x;
      sr[3 * w + PHI + 1] += p3.y;
      sr[3 * w + PHI + 2] += p3.z;
      const double xq = 0.25 * h * h;
      const double x[4][4] = {{0.0, -xq * mmat.z, xq * mmat.y, xq * fm.y},
                              {xq * mmat.z, 0.0, -xq * mmat.x, -xq * fm.x},
                              {-xq * mmat.y, xq * mmat.x, 0.0, 0.0},
                              {-xq * fm.y, xq * fm.x, 0.0, 0.0}};
      for (int c = 0; c < 4; ++c)
        for (int j = 0; j < 4; ++j) {
          sr[c * w + QK + j] += x[c][j];
          sr[c * w + QN + j] += x[c][j];
        }
    }
    // Node k+1's strain rows: ½ δs_k − A_{k+1,k} δq_k + c_{k+1} = 0.
    const double m_side = h / 6.0;
    for (int c = 0; c < 4; ++c) {
      double* row = cr + c * w;
      axpy<W>(0.5, sr + c * w, row, w);
      for (int j = 0; j < 4; ++j) row[QK + j] -= m_side * t_k.at(c, j);
    }
    // δq_{k+1} = U_k (y_k, 1).
    const double pivot = gauss_jordan<W>(cr, 4, QN, w);
    if (pivot < report.smallest_pivot) {
      report.smallest_pivot = pivot;
      report.node = k + 1;
    }
    if (!(pivot >= kCondensedPivotFloor)) {
      report.ok = false;
      report.node = k + 1;
      return report;
    }
    double* gain = sys.gain.data() + k * 4 * static_cast<std::size_t>(w);
    for (int r = 0; r < 4; ++r) {
      double* u = gain + r * w;
      const double* row = cr + r * w;
      for (int j = 0; j < w; ++j) u[j] = -row[j];
      for (int j = 0; j < 4; ++j) u[QN + j] = 0.0;
    }
    // The interface of node k: w_k, and c_k = ½ δs_k − A_kk δq_k − A_{k,k+1} δq_{k+1} + ρ_k, with
    // δq_{k+1} substituted.
    const double m_self = (h_prev + h) / 3.0;
    for (int c = 0; c < 4; ++c) {
      double* row = pi + (6 + c) * w;
      for (int j = 0; j < w; ++j) row[j] = 0.5 * sr[c * w + j];
      for (int j = 0; j < 4; ++j) {
        row[QK + j] -= m_self * t_k.at(c, j);
        row[QN + j] -= m_side * t_next.at(c, j);
      }
      row[RHS] += residual.at(k, static_cast<std::size_t>(c));
    }
    for (int r = 0; r < 10; ++r) {
      double* row = r < 6 ? wr + r * w : pi + r * w;
      const double a0 = row[QN], a1 = row[QN + 1], a2 = row[QN + 2], a3 = row[QN + 3];
      double* out = pi + r * w;
      if (r < 6) copy<W>(row, out, w);
      for (int j = 0; j < w; ++j) out[j] += a0 * gain[j] + a1 * gain[w + j] + a2 * gain[2 * w + j] + a3 * gain[3 * w + j];
      for (int j = 0; j < 4; ++j) out[QN + j] = 0.0;
    }
    t_next = t_k;
  }

  // The base: y_0 for every column.
  force = force + load(rod.node_force, 0);
  moment = moment + load(rod.node_moment, 0);
  double* base = pi;  // reuse the interface rows as the base system
  int unknowns_first = QK, unknowns = 4, equations_first = 6;
  if (rod.free_base) {
    // The rod's total wrench about node 0 balances: δM_0 − s_0 δφ_0 + M = 0, δF_0 − K_0 δr_0 + F = 0,
    // node 0's unit loads included.
    unknowns_first = PHI;
    unknowns = 10;
    equations_first = 0;
    if (has_stiffness) {
      for (int i = 0; i < 3; ++i) {
        if (!rod.stiffness.moment.empty()) base[i * w + PHI + i] -= rod.stiffness.moment[0];
        for (int j = 0; j < 3; ++j) base[(3 + i) * w + POS + j] -= rod.stiffness.force[0](i, j);
      }
    }
    for (int i = 0; i < 3; ++i) {
      base[i * w + RHS] += moment[i];
      base[(3 + i) * w + RHS] += force[i];
    }
    for (; next_load < loads.size() && loads[next_load].node == 0; ++next_load) {
      const UnitLoad& u = loads[next_load];
      double* rows = base + (u.is_moment ? 0 : 3) * w;
      for (int i = 0; i < 3; ++i) rows[i * w + RHS + static_cast<int>(u.column)] += u.load[i];
    }
  }
  double* eq = base + equations_first * w;
  const double pivot = gauss_jordan<W>(eq, unknowns, unknowns_first, w);
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
    for (int i = 0; i < unknowns; ++i) y[unknowns_first + i] = -eq[i * w + RHS + c];
    for (int i = 0; i < 10; ++i)
      if (!std::isfinite(y[i])) report.ok = false;
  }
  return report;
}

}  // namespace haustra::kernels::condensed
