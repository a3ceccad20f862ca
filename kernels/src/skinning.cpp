// Skinning the organ mesh from the cage rings: rigid groups and the along-rod screw (SIMD and scalar references),
// sparse rows.
#include "haustra/kernels/skinning.hpp"

#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <cstring>

#include "haustra/kernels/cage_rings.hpp"

namespace haustra::kernels {

namespace {

// Eight floats as one AVX register (GCC/Clang vector extension): the compiler's own loop
// vectorizer turns the lane loop into scalar code once the slot loop is unrolled.
using Lanes = float __attribute__((vector_size(kSkinLanes * sizeof(float))));
static_assert(sizeof(Lanes) == kSkinLanes * sizeof(float));

inline Lanes load(const float* p) {
  Lanes v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

// A block's 8 lanes to their vertices (a padding lane has none).
inline void scatter(const SkinBindingView& binding, std::size_t base, const Lanes& x, const Lanes& y, const Lanes& z,
                    const FloatVec3Out& out) {
  for (std::size_t l = 0; l < kSkinLanes; ++l) {
    const std::uint32_t v = binding.vertex[base + l];
    if (v == kNoVertex) continue;
    out.x[v] = x[l];
    out.y[v] = y[l];
    out.z[v] = z[l];
  }
}

// sin φ / φ and (1 − cos φ) / φ² as Taylor polynomials in x = φ² through φ¹⁴ (coefficients from the
// highest power down): no division, so no branch at φ = 0; within 1e-6 of the functions up to φ = π
// (the largest turn a screw takes).
constexpr std::array<float, 8> kSincOfSquare = {
    -1.0f / 1307674368000.0f, 1.0f / 6227020800.0f, -1.0f / 39916800.0f, 1.0f / 362880.0f,
    -1.0f / 5040.0f,          1.0f / 120.0f,        -1.0f / 6.0f,        1.0f};
constexpr std::array<float, 8> kCoscOfSquare = {
    -1.0f / 20922789888000.0f, 1.0f / 87178291200.0f, -1.0f / 479001600.0f, 1.0f / 3628800.0f,
    -1.0f / 40320.0f,          1.0f / 720.0f,         -1.0f / 24.0f,        0.5f};
template <class T>
T horner(T x, const std::array<float, 8>& c) {
  T r = T{} + c[0];
  for (std::size_t i = 1; i < c.size(); ++i) r = r * x + c[i];
  return r;
}
template <class T>
T sinc_of_square(T x) {
  return horner(x, kSincOfSquare);
}
template <class T>
T cosc_of_square(T x) {
  return horner(x, kCoscOfSquare);
}

// The same in double by the functions themselves, with their series below 1e-3.
double sinc(double x) { return std::abs(x) < 1e-3 ? 1.0 - x * x / 6.0 + x * x * x * x / 120.0 : std::sin(x) / x; }
double cosc(double x) {
  return std::abs(x) < 1e-3 ? 0.5 - x * x / 24.0 + x * x * x * x / 720.0 : (1.0 - std::cos(x)) / (x * x);
}

}  // namespace

Screw screw_between(const RingPose& a, const RingPose& b) {
  Screw s;
  s.rotation = a.rotation;
  s.centre = a.centre;
  Eigen::Quaterniond q(Eigen::Matrix3d(a.rotation.transpose() * b.rotation));
  q.normalize();
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();  // the shorter way round: θ ≤ π
  const double sn = q.vec().norm(), cs = q.w(), half = std::atan2(sn, cs);
  s.angle = 2.0 * half;
  if (sn > 0.0) s.axis = q.vec() / sn;
  s.cot = half < 1e-4 ? 1.0 - half * half / 3.0 : half * cs / sn;
  const Eigen::Vector3d moved = a.rotation.transpose() * (b.centre - a.centre);
  s.along = s.axis.dot(moved);
  s.across = moved - s.along * s.axis;
  s.turned = s.axis.cross(s.across);
  return s;
}

RingPose screw_pose(const Screw& s, double t) {
  const double phi = t * s.angle;
  const double kp = 0.5 * phi * phi * cosc(phi) + t * s.cot * sinc(phi);
  const double kq = phi * (t * s.cot * cosc(phi) - 0.5 * sinc(phi));
  RingPose p;
  p.rotation = s.rotation * Eigen::AngleAxisd(phi, s.axis).toRotationMatrix();
  p.centre = s.centre + s.rotation * (kp * s.across + kq * s.turned + t * s.along * s.axis);
  return p;
}

void screw_frame(std::span<const RingPose> station, std::span<float> out) {
  for (std::size_t g = 0; g < station.size(); ++g) {
    const Screw s = screw_between(station[g], station[std::min(g + 1, station.size() - 1)]);
    float* f = out.data() + kScrewFloats * g;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) f[4 * r + c] = static_cast<float>(s.rotation(r, c));
      f[4 * r + 3] = static_cast<float>(s.centre[r]);
    }
    const Eigen::Vector3d* rows[3] = {&s.axis, &s.across, &s.turned};
    const double last[3] = {s.angle, s.cot, s.along};
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) f[12 + 4 * r + c] = static_cast<float>((*rows[r])[c]);
      f[12 + 4 * r + 3] = static_cast<float>(last[r]);
    }
  }
}

void skin_screw(const SkinBindingView& binding, std::span<const float> screw, std::size_t first, std::size_t count,
                const FloatVec3Out& out) {
  for (std::size_t block = first; block < first + count; ++block) {
    const std::size_t base = block * kSkinLanes, slot = binding.slot_start[block];
    const float* f = screw.data() + kScrewFloats * binding.ring[slot];
    const float* coef = binding.coefficient.data() + slot * kSkinCoefficients * kSkinLanes;
    const Lanes t = load(coef), ox = load(coef + kSkinLanes), oy = load(coef + 2 * kSkinLanes),
                oz = load(coef + 3 * kSkinLanes);
    const float wx = f[12], wy = f[13], wz = f[14];
    const Lanes phi = t * f[15], phi2 = phi * phi;
    const Lanes sc = sinc_of_square(phi2), cc = cosc_of_square(phi2);
    const Lanes sn = phi * sc, omc = phi2 * cc, tc = t * f[19], td = t * f[23];
    const Lanes kp = 0.5f * omc + tc * sc, kq = phi * (tc * cc - 0.5f * sc);
    // Rodrigues: o + sin φ ω×o + (1 − cos φ) ω×(ω×o), then the screw's translation.
    const Lanes ax = wy * oz - wz * oy, ay = wz * ox - wx * oz, az = wx * oy - wy * ox;
    const Lanes bx = wy * az - wz * ay, by = wz * ax - wx * az, bz = wx * ay - wy * ax;
    const Lanes yx = ox + sn * ax + omc * bx + kp * f[16] + kq * f[20] + td * wx;
    const Lanes yy = oy + sn * ay + omc * by + kp * f[17] + kq * f[21] + td * wy;
    const Lanes yz = oz + sn * az + omc * bz + kp * f[18] + kq * f[22] + td * wz;
    const Lanes x = f[0] * yx + f[1] * yy + f[2] * yz + f[3];
    const Lanes y = f[4] * yx + f[5] * yy + f[6] * yz + f[7];
    const Lanes z = f[8] * yx + f[9] * yy + f[10] * yz + f[11];
    scatter(binding, base, x, y, z, out);
  }
}

void skin_screw_reference(const SkinBindingView& binding, std::span<const float> screw, const FloatVec3Out& out) {
  for (std::size_t i = 0; i < binding.rest_x.size(); ++i) {
    const std::uint32_t v = binding.vertex[i];
    if (v == kNoVertex) continue;
    const std::size_t block = i / kSkinLanes, lane = i % kSkinLanes, slot = binding.slot_start[block];
    const float* f = screw.data() + kScrewFloats * binding.ring[slot];
    const float* coef = binding.coefficient.data() + slot * kSkinCoefficients * kSkinLanes + lane;
    const Eigen::Vector3d o(coef[kSkinLanes], coef[2 * kSkinLanes], coef[3 * kSkinLanes]);
    const Eigen::Vector3d x = screw_point(f, coef[0], o, Eigen::Vector3d::Zero()).position;
    out.x[v] = static_cast<float>(x.x());
    out.y[v] = static_cast<float>(x.y());
    out.z[v] = static_cast<float>(x.z());
  }
}

void skin_rigid_groups(const SkinBindingView& binding, std::span<const float> ring_delta, std::size_t first,
                       std::size_t count, const FloatVec3Out& out) {
  const float* delta = ring_delta.data();
  for (std::size_t block = first; block < first + count; ++block) {
    const std::size_t base = block * kSkinLanes;
    Lanes x = load(binding.rest_x.data() + base);
    Lanes y = load(binding.rest_y.data() + base);
    Lanes z = load(binding.rest_z.data() + base);
    const std::size_t first_slot = binding.slot_start[block], slots = binding.slot_start[block + 1] - first_slot;
    const std::uint32_t* ring = binding.ring.data() + first_slot;
    const float* coef = binding.coefficient.data() + first_slot * kSkinCoefficients * kSkinLanes;
    for (std::size_t s = 0; s < slots; ++s, coef += kSkinCoefficients * kSkinLanes) {
      // One ring for all lanes: its 3×4 delta is broadcast against 8 vertices' coefficients.
      const float* t = delta + kRingDeltaFloats * ring[s];
      const Lanes b = load(coef), ax = load(coef + kSkinLanes), ay = load(coef + 2 * kSkinLanes),
                  az = load(coef + 3 * kSkinLanes);
      x += t[0] * ax + t[1] * ay + t[2] * az + t[3] * b;
      y += t[4] * ax + t[5] * ay + t[6] * az + t[7] * b;
      z += t[8] * ax + t[9] * ay + t[10] * az + t[11] * b;
    }
    scatter(binding, base, x, y, z, out);
  }
}

void skin_rigid_groups_reference(const SkinBindingView& binding, std::span<const float> ring_delta,
                                 const FloatVec3Out& out) {
  for (std::size_t i = 0; i < binding.rest_x.size(); ++i) {
    const std::uint32_t v = binding.vertex[i];
    if (v == kNoVertex) continue;
    const std::size_t block = i / kSkinLanes, lane = i % kSkinLanes;
    double d[3] = {0.0, 0.0, 0.0};
    for (std::size_t s = binding.slot_start[block]; s < binding.slot_start[block + 1]; ++s) {
      const std::size_t c = (s * kSkinCoefficients) * kSkinLanes + lane;
      const double coef[4] = {binding.coefficient[c + kSkinLanes], binding.coefficient[c + 2 * kSkinLanes],
                              binding.coefficient[c + 3 * kSkinLanes], binding.coefficient[c]};  // Ax Ay Az b
      const float* t = ring_delta.data() + kRingDeltaFloats * binding.ring[s];
      for (int r = 0; r < 3; ++r)
        for (int k = 0; k < 4; ++k) d[r] += static_cast<double>(t[4 * r + k]) * coef[k];
    }
    out.x[v] = static_cast<float>(binding.rest_x[i] + d[0]);
    out.y[v] = static_cast<float>(binding.rest_y[i] + d[1]);
    out.z[v] = static_cast<float>(binding.rest_z[i] + d[2]);
  }
}

void skin_csr_reference(std::span<const std::uint32_t> row_start, std::span<const std::uint32_t> column,
                        std::span<const double> weight, std::span<const Eigen::Vector3d> rest_mesh,
                        std::span<const Eigen::Vector3d> rest_cage, std::span<const Eigen::Vector3d> cage,
                        std::span<Eigen::Vector3d> out) {
  for (std::size_t v = 0; v < rest_mesh.size(); ++v) {
    Eigen::Vector3d x = rest_mesh[v];
    for (std::uint32_t k = row_start[v]; k < row_start[v + 1]; ++k)
      x += weight[k] * (cage[column[k]] - rest_cage[column[k]]);
    out[v] = x;
  }
}

}  // namespace haustra::kernels
