// The forward sweep: node and midpoint poses from the base pose and the strains.
#include "haustra/kernels/rod_forward_sweep.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <unsupported/Eigen/MatrixFunctions>

namespace haustra::kernels {
namespace {

// The sweep takes its sections in blocks of this many: first every half-section exponential of the
// block (independent of each other, so the loop runs several sections in parallel lanes), then the
// poses composed along the block (the only dependent chain). The block's exponentials live on the
// stack: nothing is allocated.
constexpr std::size_t kBlock = 64;

// Up to this squared half-section angle (θ ≤ 0.5 rad: a curvature radius of a section's length or
// less) the four coefficients are their Taylor series in θ² to θ¹⁴, whose first omitted term is
// below 6·10⁻¹⁸ of the value: exact to rounding, without a sine, a cosine or a branch. Beyond it,
// section_exp's closed forms (libm).
constexpr double kSeriesAngleSq = 0.25;

// One block's half-section exponentials: rotation (w, x, y, z) and translation; first the turn
// w = ½h ξ_{0:3}, the advance ν = ½h (1 + ξ_3) and t = |w|².
struct HalfExps {
  std::array<double, kBlock> wx, wy, wz, nu, t;
  std::array<double, kBlock> qw, qx, qy, qz, px, py, pz;
};

// a·b + c in one rounding where the target has FMA (x86-64-v3), as two elsewhere.
inline double mul_add(double a, double b, double c) {
#ifdef __FMA__
  return std::fma(a, b, c);
#else
  return a * b + c;
#endif
}

// Σ c_n tⁿ by Horner, written out so that the loop over sections holds no inner loop.
inline double series(double t, const std::array<double, 8>& c) {
  double s = mul_add(t, c[7], c[6]);
  s = mul_add(t, s, c[5]);
  s = mul_add(t, s, c[4]);
  s = mul_add(t, s, c[3]);
  s = mul_add(t, s, c[2]);
  s = mul_add(t, s, c[1]);
  return mul_add(t, s, c[0]);
}

// Taylor coefficients in t = θ²: cos(θ/2), sin(θ/2)/θ, (1 − cos θ)/θ², (θ − sin θ)/θ³.
constexpr std::array<double, 8> kCosHalf{1.0,
                                         -1.0 / 8,
                                         1.0 / 384,
                                         -1.0 / 46080,
                                         1.0 / 10321920,
                                         -1.0 / 3715891200.0,
                                         1.0 / 1961990553600.0,
                                         -1.0 / 1428329123020800.0};
constexpr std::array<double, 8> kSinHalfOver{1.0 / 2,
                                             -1.0 / 48,
                                             1.0 / 3840,
                                             -1.0 / 645120,
                                             1.0 / 185794560,
                                             -1.0 / 81749606400.0,
                                             1.0 / 51011754393600.0,
                                             -1.0 / 42849873690624000.0};
constexpr std::array<double, 8> kOneMinusCos{
    1.0 / 2,       -1.0 / 24,          1.0 / 720,           -1.0 / 40320,
    1.0 / 3628800, -1.0 / 479001600.0, 1.0 / 87178291200.0, -1.0 / 20922789888000.0};
constexpr std::array<double, 8> kThetaMinusSin{1.0 / 6,
                                               -1.0 / 120,
                                               1.0 / 5040,
                                               -1.0 / 362880,
                                               1.0 / 39916800,
                                               -1.0 / 6227020800.0,
                                               1.0 / 1307674368000.0,
                                               -1.0 / 355687428096000.0};

// The half-section exponentials of sections [k0, k0 + count): exp(½h_k ξ̂_k), ξ_k = ½(q_k + q_{k+1}).
// Returns false where a section turns by more than the series' range (the caller falls back). The
// second loop is arithmetic on arrays alone, which the compiler runs four sections to a register.
bool half_exps(const double* q, const double* h, std::size_t count, HalfExps& e) {
  double worst = 0.0;
  for (std::size_t i = 0; i < count; ++i) {
    const double* qa = q + 4 * i;
    const double l = 0.25 * h[i];  // ½h times the ½ of the two nodes' mean
    e.wx[i] = (qa[0] + qa[4]) * l;
    e.wy[i] = (qa[1] + qa[5]) * l;
    e.wz[i] = (qa[2] + qa[6]) * l;
    e.nu[i] = (2.0 + qa[3] + qa[7]) * l;
    e.t[i] = e.wx[i] * e.wx[i] + e.wy[i] * e.wy[i] + e.wz[i] * e.wz[i];
    worst = std::max(worst, e.t[i]);
  }
  if (!(worst <= kSeriesAngleSq)) return false;
  for (std::size_t i = 0; i < count; ++i) {
    const double wx = e.wx[i], wy = e.wy[i], wz = e.wz[i], nu = e.nu[i], t = e.t[i];
    const double s = series(t, kSinHalfOver);
    e.qw[i] = series(t, kCosHalf);
    e.qx[i] = s * wx;
    e.qy[i] = s * wy;
    e.qz[i] = s * wz;
    // p = ν e3 + a w × ν e3 + b w × (w × ν e3), a = (1 − cos θ)/θ², b = (θ − sin θ)/θ³.
    const double a = series(t, kOneMinusCos), b = series(t, kThetaMinusSin);
    e.px[i] = nu * mul_add(b * wx, wz, a * wy);
    e.py[i] = nu * mul_add(b * wy, wz, -a * wx);
    e.pz[i] = nu * (1.0 - b * (wx * wx + wy * wy));
  }
  return true;
}

// The same through section_exp (libm's sine and cosine): any angle.
void half_exps_closed(const double* q, const double* h, std::size_t count, HalfExps& e) {
  for (std::size_t i = 0; i < count; ++i) {
    const double* qa = q + 4 * i;
    const Eigen::Vector3d u(0.5 * (qa[0] + qa[4]), 0.5 * (qa[1] + qa[5]), 0.5 * (qa[2] + qa[6]));
    const Pose p = section_exp(u, 0.5 * (qa[3] + qa[7]), 0.5 * h[i]);
    e.qw[i] = p.rotation.w();
    e.qx[i] = p.rotation.x();
    e.qy[i] = p.rotation.y();
    e.qz[i] = p.rotation.z();
    e.px[i] = p.position.x();
    e.py[i] = p.position.y();
    e.pz[i] = p.position.z();
  }
}

// A product of unit quaternions is unit to a few roundings: one Newton step of 1/√n is exact to
// rounding there and keeps a square root and a division out of the chain; anything further from
// unit (a base given unnormalized) is normalized in full.
Eigen::Quaterniond renormalized(const Eigen::Quaterniond& q) {
  const double n = q.squaredNorm();
  if (std::abs(n - 1.0) > 1e-8) return q.normalized();
  return Eigen::Quaterniond(q.coeffs() * (1.5 - 0.5 * n));
}

}  // namespace

void rod_forward_sweep(const Pose& base, std::span<const double> section_length, StrainView<const double> strain,
                       RodPoses<double> out) {
  const std::size_t sections = section_length.size();
  assert(strain.size() == sections + 1 && out.node_count() == sections + 1);
  Eigen::Quaterniond rot = base.rotation;
  Eigen::Vector3d pos = base.position;
  out.node_position.set(0, pos);
  out.node_rotation.set(0, rot);
  HalfExps e;
  for (std::size_t k0 = 0; k0 < sections; k0 += kBlock) {
    const std::size_t count = std::min(kBlock, sections - k0);
    const double* q = strain.data.data() + 4 * k0;
    if (!half_exps(q, section_length.data() + k0, count, e)) half_exps_closed(q, section_length.data() + k0, count, e);
    for (std::size_t i = 0; i < count; ++i) {
      const std::size_t k = k0 + i;
      const Eigen::Quaterniond hq(e.qw[i], e.qx[i], e.qy[i], e.qz[i]);
      const Eigen::Vector3d hp(e.px[i], e.py[i], e.pz[i]);
      // Midpoint.
      pos += rot * hp;
      rot = rot * hq;
      out.mid_position.set(k, pos);
      out.mid_rotation.set(k, rot);
      // End node. Renormalize once per node so rounding cannot accumulate over 10⁴ sections.
      pos += rot * hp;
      rot = renormalized(rot * hq);
      out.node_position.set(k + 1, pos);
      out.node_rotation.set(k + 1, rot);
    }
  }
}

namespace {

Eigen::Matrix4d twist_matrix(const Eigen::Vector4d& xi, double length) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  const Eigen::Vector3d w = xi.head<3>() * length;
  m(0, 1) = -w.z();
  m(0, 2) = w.y();
  m(1, 0) = w.z();
  m(1, 2) = -w.x();
  m(2, 0) = -w.y();
  m(2, 1) = w.x();
  m(2, 3) = (1.0 + xi[3]) * length;
  return m;
}

Eigen::Matrix4d homogeneous(const Pose& p) {
  Eigen::Matrix4d g = Eigen::Matrix4d::Identity();
  g.topLeftCorner<3, 3>() = p.rotation.toRotationMatrix();
  g.topRightCorner<3, 1>() = p.position;
  return g;
}

void store(const Eigen::Matrix4d& g, Vec3View<double> pos, RotationView<double> rot, std::size_t i) {
  pos.set(i, g.topRightCorner<3, 1>());
  rot.set(i, Eigen::Quaterniond(Eigen::Matrix3d(g.topLeftCorner<3, 3>())).normalized());
}

}  // namespace

void rod_forward_sweep_reference(const Pose& base, std::span<const double> section_length,
                                 StrainView<const double> strain, RodPoses<double> out) {
  Eigen::Matrix4d g = homogeneous(base);
  store(g, out.node_position, out.node_rotation, 0);
  for (std::size_t k = 0; k < section_length.size(); ++k) {
    const Eigen::Vector4d xi = 0.5 * (strain.get(k) + strain.get(k + 1));
    const Eigen::Matrix4d mid = g * twist_matrix(xi, 0.5 * section_length[k]).exp();
    store(mid, out.mid_position, out.mid_rotation, k);
    g = g * twist_matrix(xi, section_length[k]).exp();
    store(g, out.node_position, out.node_rotation, k + 1);
  }
}

}  // namespace haustra::kernels
