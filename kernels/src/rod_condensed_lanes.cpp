// Four rods of one node count condensed at once, one rod per lane of a 4-double vector
// (rod_condensed.hpp: rod_condense_lanes). The sweep of condensed_rows.hpp with every scalar of a
// rod made a vector of four rods' — the geometry, the distal loads, the law, the pivoted 4×4
// elimination (its row swaps blended per lane) — for rods whose solve has the residual column
// alone. The base systems are solved rod by rod.
#include <algorithm>
#include <cmath>
#include <limits>

#include "condensed_rows.hpp"
#include "haustra/kernels/rod_condensed.hpp"

namespace haustra::kernels {
namespace {

using condensed::fmadd;
using condensed::kZ;
using condensed::PHI;
using condensed::POS;
using condensed::QK;
using condensed::QN;
using condensed::RHS;
constexpr int kL = kCondensedLanes;

using L = double __attribute__((vector_size(32)));
using Mask = long long __attribute__((vector_size(32)));

struct V3L {
  L x{}, y{}, z{};
};
inline V3L operator+(V3L a, V3L b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline V3L operator-(V3L a, V3L b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline V3L operator*(L s, V3L a) { return {s * a.x, s * a.y, s * a.z}; }
inline V3L cross(V3L a, V3L b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline L dot(V3L a, V3L b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline L component(const V3L& a, int i) { return i == 0 ? a.x : (i == 1 ? a.y : a.z); }
inline L abs(L a) { return a < 0.0 ? -a : a; }
inline L select(Mask m, L a, L b) { return m ? a : b; }

// Lane l of each of the four rods' arrays.
template <class F>
L gather(F&& f) {
  return L{f(0), f(1), f(2), f(3)};
}

V3L load(const std::array<const RodLinearization*, kL>& rods, Vec3View<const double> RodLinearization::*field,
         std::size_t i) {
  V3L v;
  for (int l = 0; l < kL; ++l) {
    const Vec3View<const double>& a = rods[static_cast<std::size_t>(l)]->*field;
    v.x[l] = a.x[i];
    v.y[l] = a.y[i];
    v.z[l] = a.z[i];
  }
  return v;
}

// The tangent's entries per lane (diagonal and the κ1–κ2 coupling).
struct TangentL {
  L diag[4];
  L bend{};
  [[nodiscard]] L at(int r, int c) const {
    if (r == c) return diag[r];
    return (r + c == 1) ? bend : L{};
  }
};

TangentL tangent_of(const std::array<const RodLinearization*, kL>& rods, std::size_t k) {
  TangentL t;
  for (int l = 0; l < kL; ++l) {
    const condensed::Tangent s = condensed::tangent_of(*rods[static_cast<std::size_t>(l)], k);
    for (int c = 0; c < 4; ++c) t.diag[c][l] = s.diag[c];
    t.bend[l] = s.bend;
  }
  return t;
}

using Row = L[kZ];

}  // namespace

// One function of ~260 lines on purpose: condensed::sweep's recurrence (condensed_rows.hpp), four
// rods to a register, step for step the same as it (decision 0041) so that a rod gives the same
// bits alone or in a lane; the steps are marked as they are there.
void rod_condense_lanes(const std::array<const RodLinearization*, kCondensedLanes>& rods,
                        const std::array<StrainView<const double>, kCondensedLanes>& residuals,
                        const std::array<CondensedSystem, kCondensedLanes>& systems,
                        std::array<CondenseReport, kCondensedLanes>& reports) {
  const std::size_t n = rods[0]->poses.node_count(), last = n - 1;
  const bool stiffness = !rods[0]->stiffness.force.empty();
  Row pi[10], wr[6], cr[4], sr[4], xr[6];
  for (auto& r : pi)
    for (L& e : r) e = L{};
  L smallest = L{} + 1.0;
  L failed{};  // per lane: a pivot below the floor was met
  // The tip.
  {
    const TangentL t = tangent_of(rods, last);
    const L m = gather([&](int l) { return rods[static_cast<std::size_t>(l)]->section_length[last - 1]; }) / 3.0;
    for (int c = 0; c < 4; ++c) {
      for (int j = 0; j < 4; ++j) pi[6 + c][QK + j] = -m * t.at(c, j);
      pi[6 + c][RHS] =
          gather([&](int l) { return residuals[static_cast<std::size_t>(l)].at(last, static_cast<std::size_t>(c)); });
    }
  }
  V3L force{}, moment{};
  TangentL t_next = tangent_of(rods, last);
  for (std::size_t k = last; k-- > 0;) {
    // Section k's frame, lane by lane.
    V3L d[3], chord, lever, mid;
    L h{};
    for (int l = 0; l < kL; ++l) {
      const condensed::SectionFrame g = condensed::section_frame(*rods[static_cast<std::size_t>(l)], k);
      for (int i = 0; i < 3; ++i) {
        d[i].x[l] = g.d[i].x;
        d[i].y[l] = g.d[i].y;
        d[i].z[l] = g.d[i].z;
      }
      h[l] = g.h;
      chord.x[l] = g.chord.x, chord.y[l] = g.chord.y, chord.z[l] = g.chord.z;
      lever.x[l] = g.lever.x, lever.y[l] = g.lever.y, lever.z[l] = g.lever.z;
      mid.x[l] = g.mid.x, mid.y[l] = g.mid.y, mid.z[l] = g.mid.z;
    }
    const L h_prev =
        k > 0 ? gather([&](int l) { return rods[static_cast<std::size_t>(l)]->section_length[k - 1]; }) : L{};
    const TangentL t_k = tangent_of(rods, k);
    force = force + load(rods, &RodLinearization::node_force, k + 1);
    moment = moment + load(rods, &RodLinearization::node_moment, k + 1) + cross(chord, force);

    // δφ_{k+1}, δr_{k+1} over z.
    for (auto& r : xr)
      for (L& e : r) e = L{};
    const L half = 0.5 * h;
    for (int i = 0; i < 3; ++i) {
      xr[i][PHI + i] = L{} + 1.0;
      xr[3 + i][POS + i] = L{} + 1.0;
      for (int j = 0; j < 3; ++j) {
        const L theta = half * component(d[j], i);
        const L arm = half * component(cross(d[j], lever), i);
        xr[i][QK + j] = xr[i][QN + j] = theta;
        xr[3 + i][QK + j] = xr[3 + i][QN + j] = arm;
      }
      xr[3 + i][QK + 3] = xr[3 + i][QN + 3] = half * component(d[2], i);
    }
    xr[3][PHI + 1] = chord.z;
    xr[3][PHI + 2] = -chord.y;
    xr[4][PHI + 0] = -chord.z;
    xr[4][PHI + 2] = chord.x;
    xr[5][PHI + 0] = chord.y;
    xr[5][PHI + 1] = -chord.x;

    // The interface of node k+1 over z.
    for (int r = 0; r < 10; ++r) {
      const Row& p = pi[r];
      Row& out = r < 6 ? wr[r] : cr[r - 6];
      Row acc;
      for (int j = 0; j < kZ; ++j)
        acc[j] = fmadd(p[5], xr[5][j],
                       fmadd(p[4], xr[4][j],
                             fmadd(p[3], xr[3][j], fmadd(p[2], xr[2][j], fmadd(p[1], xr[1][j], p[0] * xr[0][j])))));
      const L rhs0 = p[RHS], rhs1 = p[RHS + 1];
      const L q0 = p[QK], q1 = p[QK + 1], q2 = p[QK + 2], q3 = p[QK + 3];
      for (int j = 0; j < kZ; ++j) out[j] = acc[j];
      out[QN] += q0;
      out[QN + 1] += q1;
      out[QN + 2] += q2;
      out[QN + 3] += q3;
      out[RHS] = rhs0;
      out[RHS + 1] = rhs1;
    }
    // δF_k = δF_{k+1} − K_{k+1} δr_{k+1}.
    Row* fr = wr + 3;
    Row* mr = wr;
    if (stiffness) {
      L kk[3][3];
      for (int l = 0; l < kL; ++l) {
        const Eigen::Matrix3d& m = rods[static_cast<std::size_t>(l)]->stiffness.force[k + 1];
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) kk[i][j][l] = m(i, j);
      }
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          for (int e = 0; e < kZ; ++e) fr[i][e] = fmadd(-kk[i][j], xr[3 + j][e], fr[i][e]);
    }
    // δM_k = δM_{k+1} + chord × δF_k − F_k × (δr_{k+1} − δr_k) − s δφ_{k+1}.
    for (int e = 0; e < kZ; ++e) {
      const L a0 = fr[0][e], a1 = fr[1][e], a2 = fr[2][e];
      mr[0][e] = fmadd(chord.y, a2, fmadd(-chord.z, a1, mr[0][e]));
      mr[1][e] = fmadd(chord.z, a0, fmadd(-chord.x, a2, mr[1][e]));
      mr[2][e] = fmadd(chord.x, a1, fmadd(-chord.y, a0, mr[2][e]));
    }
    for (int e = 0; e < kZ; ++e) {
      const L a0 = xr[3][e], a1 = xr[4][e], a2 = xr[5][e];
      mr[0][e] = fmadd(-force.y, a2, fmadd(force.z, a1, mr[0][e]));
      mr[1][e] = fmadd(-force.z, a0, fmadd(force.x, a2, mr[1][e]));
      mr[2][e] = fmadd(-force.x, a1, fmadd(force.y, a0, mr[2][e]));
    }
    mr[0][POS + 1] -= force.z;
    mr[0][POS + 2] += force.y;
    mr[1][POS] += force.z;
    mr[1][POS + 2] -= force.x;
    mr[2][POS] -= force.y;
    mr[2][POS + 1] += force.x;
    if (stiffness && !rods[0]->stiffness.moment.empty()) {
      const L sp = gather([&](int l) { return rods[static_cast<std::size_t>(l)]->stiffness.moment[k + 1]; });
      for (int i = 0; i < 3; ++i)
        for (int e = 0; e < kZ; ++e) mr[i][e] = fmadd(-sp, xr[i][e], mr[i][e]);
    }
    // Section k's generalized force.
    {
      const V3L b = (L{} - 1.0) * mid;
      const V3L d0 = h * d[0], d1 = h * d[1], d2 = h * d[2];
      for (int e = 0; e < kZ; ++e) {
        const L a0 = fr[0][e], a1 = fr[1][e], a2 = fr[2][e];
        const L x0 = fmadd(b.y, a2, fmadd(-b.z, a1, mr[0][e]));
        const L x1 = fmadd(b.z, a0, fmadd(-b.x, a2, mr[1][e]));
        const L x2 = fmadd(b.x, a1, fmadd(-b.y, a0, mr[2][e]));
        sr[0][e] = fmadd(d0.z, x2, fmadd(d0.y, x1, d0.x * x0));
        sr[1][e] = fmadd(d1.z, x2, fmadd(d1.y, x1, d1.x * x0));
        sr[2][e] = fmadd(d2.z, x2, fmadd(d2.y, x1, d2.x * x0));
        sr[3][e] = fmadd(d2.z, a2, fmadd(d2.y, a1, d2.x * a0));
      }
      const V3L m_mid = moment + cross(b, force);
      const V3L fm{dot(d[0], force), dot(d[1], force), dot(d[2], force)};
      const V3L mmat{dot(d[0], m_mid), dot(d[1], m_mid), dot(d[2], m_mid)};
      for (int c = 0; c < 3; ++c) {
        const V3L pv = h * (cross(d[c], m_mid) - cross(cross(d[c], force), mid));
        sr[c][PHI] += pv.x;
        sr[c][PHI + 1] += pv.y;
        sr[c][PHI + 2] += pv.z;
      }
      const V3L p3 = h * cross(d[2], force);
      sr[3][PHI] += p3.x;
      sr[3][PHI + 1] += p3.y;
      sr[3][PHI + 2] += p3.z;
      const L xq = 0.25 * h * h;
      const L x[4][4] = {{L{}, -xq * mmat.z, xq * mmat.y, xq * fm.y},
                         {xq * mmat.z, L{}, -xq * mmat.x, -xq * fm.x},
                         {-xq * mmat.y, xq * mmat.x, L{}, L{}},
                         {-xq * fm.y, xq * fm.x, L{}, L{}}};
      for (int c = 0; c < 4; ++c)
        for (int j = 0; j < 4; ++j) {
          sr[c][QK + j] += x[c][j];
          sr[c][QN + j] += x[c][j];
        }
    }
    // Node k+1's strain rows.
    const L m_side = h / 6.0;
    for (int c = 0; c < 4; ++c) {
      for (int e = 0; e < kZ; ++e) cr[c][e] = fmadd(L{} + 0.5, sr[c][e], cr[c][e]);
      for (int j = 0; j < 4; ++j) cr[c][QK + j] -= m_side * t_k.at(c, j);
    }
    // Gauss–Jordan with scaled partial pivoting over lanes QN..QN+3, the pivot rows chosen per
    // lane (rows swapped by blends).
    L inv_scale[4];
    for (int r = 0; r < 4; ++r) {
      L s{};
      for (int j = 0; j < 4; ++j) s = select(abs(cr[r][QN + j]) > s, abs(cr[r][QN + j]), s);
      inv_scale[r] = select(s > 0.0, 1.0 / s, L{});
    }
    for (int j = 0; j < 4; ++j) {
      L best = abs(cr[j][QN + j]) * inv_scale[j], p = L{} + static_cast<double>(j);
      for (int r = j + 1; r < 4; ++r) {
        const L v = abs(cr[r][QN + j]) * inv_scale[r];
        const Mask m = v > best;
        best = select(m, v, best);
        p = select(m, L{} + static_cast<double>(r), p);
      }
      for (int r = j + 1; r < 4; ++r) {
        const Mask m = p == static_cast<double>(r);
        for (int e = 0; e < kZ; ++e) {
          const L a = cr[j][e], b = cr[r][e];
          cr[j][e] = select(m, b, a);
          cr[r][e] = select(m, a, b);
        }
        const L a = inv_scale[j], b = inv_scale[r];
        inv_scale[j] = select(m, b, a);
        inv_scale[r] = select(m, a, b);
      }
      smallest = select(best < smallest, best, smallest);
      const L pivot = cr[j][QN + j];
      failed = select(best >= kCondensedPivotFloor, failed, L{} + 1.0);
      const L inv = 1.0 / pivot;
      for (int e = 0; e < kZ; ++e) cr[j][e] *= inv;
      cr[j][QN + j] = L{} + 1.0;
      for (int r = 0; r < 4; ++r) {
        if (r == j) continue;
        const L f = cr[r][QN + j];
        for (int e = 0; e < kZ; ++e) cr[r][e] = fmadd(-f, cr[j][e], cr[r][e]);
        cr[r][QN + j] = L{};
      }
    }
    // The gains, rod by rod (lane l into its own rows).
    Row u[4];
    for (int r = 0; r < 4; ++r) {
      for (int e = 0; e < kZ; ++e) u[r][e] = -cr[r][e];
      for (int j = 0; j < 4; ++j) u[r][QN + j] = L{};
    }
    for (int l = 0; l < kL; ++l) {
      double* gain = systems[static_cast<std::size_t>(l)].gain.data() + k * 4 * kZ;
      for (int r = 0; r < 4; ++r)
        for (int e = 0; e < kZ; ++e) gain[r * kZ + e] = u[r][e][l];
    }
    // The interface of node k.
    const L m_self = (h_prev + h) / 3.0;
    for (int c = 0; c < 4; ++c) {
      Row& row = pi[6 + c];
      for (int e = 0; e < kZ; ++e) row[e] = 0.5 * sr[c][e];
      for (int j = 0; j < 4; ++j) {
        row[QK + j] -= m_self * t_k.at(c, j);
        row[QN + j] -= m_side * t_next.at(c, j);
      }
      row[RHS] +=
          gather([&](int l) { return residuals[static_cast<std::size_t>(l)].at(k, static_cast<std::size_t>(c)); });
    }
    for (int r = 0; r < 10; ++r) {
      const Row& in = r < 6 ? wr[r] : pi[r];
      const L a0 = in[QN], a1 = in[QN + 1], a2 = in[QN + 2], a3 = in[QN + 3];
      Row out;
      for (int e = 0; e < kZ; ++e)
        out[e] = fmadd(a3, u[3][e], fmadd(a2, u[2][e], fmadd(a1, u[1][e], fmadd(a0, u[0][e], in[e]))));
      for (int j = 0; j < 4; ++j) out[QN + j] = L{};
      for (int e = 0; e < kZ; ++e) pi[r][e] = out[e];
    }
    t_next = t_k;
  }
  // Each rod's base system on its own.
  force = force + load(rods, &RodLinearization::node_force, 0);
  moment = moment + load(rods, &RodLinearization::node_moment, 0);
  for (int l = 0; l < kL; ++l) {
    double base[10 * kZ];
    for (int r = 0; r < 10; ++r)
      for (int e = 0; e < kZ; ++e) base[r * kZ + e] = pi[r][e][l];
    CondenseReport report;
    report.smallest_pivot = smallest[l];
    report.ok = failed[l] == 0.0;
    if (!report.ok) {
      reports[static_cast<std::size_t>(l)] = report;
      continue;
    }
    const condensed::V3 f{force.x[l], force.y[l], force.z[l]}, m{moment.x[l], moment.y[l], moment.z[l]};
    reports[static_cast<std::size_t>(l)] = condensed::solve_base(*rods[static_cast<std::size_t>(l)], {}, base, kZ, kZ,
                                                                 f, m, systems[static_cast<std::size_t>(l)], report);
  }
}

}  // namespace haustra::kernels
