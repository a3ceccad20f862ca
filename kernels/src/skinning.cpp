// Skinning the organ mesh from the cage rings: rigid groups (SIMD and scalar reference) and sparse rows.
#include "haustra/kernels/skinning.hpp"

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

}  // namespace

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
    for (std::size_t l = 0; l < kSkinLanes; ++l) {
      const std::uint32_t v = binding.vertex[base + l];
      if (v == kNoVertex) continue;
      out.x[v] = x[l];
      out.y[v] = y[l];
      out.z[v] = z[l];
    }
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
