#pragma once
// The host's GPU skinning sum written out plainly from haustra.h's words (an oracle apart from the
// library), for the C API's tests and its fuzzer: the rigid-group slots and the along-rod screws.
#include <haustra/haustra.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace haustra::test {

inline void cross(const double a[3], const double b[3], double out[3]) {
  out[0] = a[1] * b[2] - a[2] * b[1], out[1] = a[2] * b[0] - a[0] * b[2], out[2] = a[0] * b[1] - a[1] * b[0];
}

// A screw slot (HAUSTRA_GPU_SCREW_SLOT) at rows r, fraction t, rest offset o: R y + c with
// y = Rot(axis, t angle) o + kP P + kQ Q + t d axis, from the header's words.
inline void screw_sum(const float* r, double t, const double o[3], double out[3]) {
  const double w[3] = {r[12], r[13], r[14]}, theta = r[15], c = r[19], d = r[23], phi = t * theta;
  const double kp = theta > 1e-6 ? 0.5 * (1 - std::cos(phi)) + std::sin(phi) * c / theta : t;
  const double kq = theta > 1e-6 ? (1 - std::cos(phi)) * c / theta - 0.5 * std::sin(phi) : 0.0;
  double a[3], b[3], y[3];
  cross(w, o, a);
  cross(w, a, b);
  for (int k = 0; k < 3; ++k)
    y[k] = o[k] + std::sin(phi) * a[k] + (1 - std::cos(phi)) * b[k] + kp * r[16 + k] + kq * r[20 + k] + t * d * w[k];
  for (int row = 0; row < 3; ++row)
    out[row] = r[4 * row] * y[0] + r[4 * row + 1] * y[1] + r[4 * row + 2] * y[2] + double(r[4 * row + 3]);
}

// The shader's sum, written out plainly from the header's words (an oracle apart from the library).
inline void shader_sum(const haustra_gpu_skin& g, const std::vector<float>& rings, std::size_t v, double out[3]) {
  double d[3] = {0, 0, 0}, screw[3] = {0, 0, 0};
  bool screwed = false;
  for (std::uint32_t s = g.vertex_slots[2 * v]; s < g.vertex_slots[2 * v] + g.vertex_slots[2 * v + 1]; ++s) {
    const float* c = g.slot_coefficients + 4 * static_cast<std::size_t>(s);
    if ((g.slot_rings[s] & HAUSTRA_GPU_SCREW_SLOT) != 0) {
      const double o[3] = {c[1], c[2], c[3]};
      double x[3];
      screw_sum(rings.data() + HAUSTRA_GPU_RING_FLOATS * (g.slot_rings[s] & ~HAUSTRA_GPU_SCREW_SLOT), c[0], o, x);
      for (int k = 0; k < 3; ++k) screw[k] += c[4] * x[k];  // the next slot's first: the weight
      screwed = true;
      ++s;
      continue;
    }
    const float* r = rings.data() + HAUSTRA_GPU_RING_FLOATS * g.slot_rings[s];
    for (int row = 0; row < 3; ++row)
      d[row] += double(r[4 * row]) * c[1] + double(r[4 * row + 1]) * c[2] + double(r[4 * row + 2]) * c[3] +
                double(r[4 * row + 3]) * c[0];
  }
  for (int k = 0; k < 3; ++k) out[k] = screwed ? screw[k] : g.rest_positions[3 * v + k] + d[k];
}

}  // namespace haustra::test
