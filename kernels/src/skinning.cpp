#include "haustra/kernels/skinning.hpp"

#include <cmath>

#include "haustra/kernels/cage_rings.hpp"

namespace haustra::kernels {

void skin_rigid_groups(const SkinBindingView& binding, std::span<const float> ring_delta, std::size_t first,
                       std::size_t count, const FloatVec3Out& out) {
  const std::size_t slots = binding.slots;
  const float* delta = ring_delta.data();
  for (std::size_t block = first; block < first + count; ++block) {
    alignas(32) float dx[kSkinLanes] = {}, dy[kSkinLanes] = {}, dz[kSkinLanes] = {};
    const std::uint32_t* ring = binding.ring.data() + block * slots * kSkinLanes;
    const float* coef = binding.coefficient.data() + block * slots * kSkinCoefficients * kSkinLanes;
    for (std::size_t s = 0; s < slots; ++s, ring += kSkinLanes, coef += kSkinCoefficients * kSkinLanes) {
      // Lane by lane with no dependence between lanes: the compiler turns this into gathers of the
      // ring deltas and FMAs across the 8 lanes.
      for (std::size_t l = 0; l < kSkinLanes; ++l) {
        const float* t = delta + kRingDeltaFloats * ring[l];
        const float b = coef[l], ax = coef[kSkinLanes + l], ay = coef[2 * kSkinLanes + l], az = coef[3 * kSkinLanes + l];
        dx[l] += t[0] * ax + t[1] * ay + t[2] * az + t[3] * b;
        dy[l] += t[4] * ax + t[5] * ay + t[6] * az + t[7] * b;
        dz[l] += t[8] * ax + t[9] * ay + t[10] * az + t[11] * b;
      }
    }
    const std::size_t base = block * kSkinLanes;
    for (std::size_t l = 0; l < kSkinLanes; ++l) {
      out.x[base + l] = binding.rest_x[base + l] + dx[l];
      out.y[base + l] = binding.rest_y[base + l] + dy[l];
      out.z[base + l] = binding.rest_z[base + l] + dz[l];
    }
  }
}

void skin_rigid_groups_reference(const SkinBindingView& binding, std::span<const float> ring_delta,
                                 const FloatVec3Out& out) {
  const std::size_t slots = binding.slots;
  for (std::size_t v = 0; v < binding.rest_x.size(); ++v) {
    const std::size_t block = v / kSkinLanes, lane = v % kSkinLanes;
    double d[3] = {0.0, 0.0, 0.0};
    for (std::size_t s = 0; s < slots; ++s) {
      const std::size_t at = (block * slots + s) * kSkinLanes + lane;
      const std::size_t c = ((block * slots + s) * kSkinCoefficients) * kSkinLanes + lane;
      const double coef[4] = {binding.coefficient[c + kSkinLanes], binding.coefficient[c + 2 * kSkinLanes],
                              binding.coefficient[c + 3 * kSkinLanes], binding.coefficient[c]};  // Ax Ay Az b
      const float* t = ring_delta.data() + kRingDeltaFloats * binding.ring[at];
      for (int r = 0; r < 3; ++r)
        for (int k = 0; k < 4; ++k) d[r] += static_cast<double>(t[4 * r + k]) * coef[k];
    }
    out.x[v] = static_cast<float>(binding.rest_x[v] + d[0]);
    out.y[v] = static_cast<float>(binding.rest_y[v] + d[1]);
    out.z[v] = static_cast<float>(binding.rest_z[v] + d[2]);
  }
}

void skin_csr_reference(std::span<const std::uint32_t> row_start, std::span<const std::uint32_t> column,
                        std::span<const double> weight, std::span<const Eigen::Vector3d> rest_mesh,
                        std::span<const Eigen::Vector3d> rest_cage, std::span<const Eigen::Vector3d> cage,
                        std::span<Eigen::Vector3d> out) {
  for (std::size_t v = 0; v < rest_mesh.size(); ++v) {
    Eigen::Vector3d x = rest_mesh[v];
    for (std::uint32_t k = row_start[v]; k < row_start[v + 1]; ++k) x += weight[k] * (cage[column[k]] - rest_cage[column[k]]);
    out[v] = x;
  }
}

void vertex_normals(std::span<const std::array<std::uint32_t, 3>> triangles,
                    std::span<const std::uint32_t> vertex_triangle_start, std::span<const std::uint32_t> vertex_triangle,
                    std::span<const float> x, std::span<const float> y, std::span<const float> z,
                    std::size_t first_vertex, std::size_t vertex_count, const FloatVec3Out& normal) {
  for (std::size_t v = first_vertex; v < first_vertex + vertex_count; ++v) {
    float n[3] = {0.0f, 0.0f, 0.0f};
    for (std::uint32_t k = vertex_triangle_start[v]; k < vertex_triangle_start[v + 1]; ++k) {
      const auto& t = triangles[vertex_triangle[k]];
      const float e1[3] = {x[t[1]] - x[t[0]], y[t[1]] - y[t[0]], z[t[1]] - z[t[0]]};
      const float e2[3] = {x[t[2]] - x[t[0]], y[t[2]] - y[t[0]], z[t[2]] - z[t[0]]};
      // The cross product's length is twice the area: area weighting for free.
      n[0] += e1[1] * e2[2] - e1[2] * e2[1];
      n[1] += e1[2] * e2[0] - e1[0] * e2[2];
      n[2] += e1[0] * e2[1] - e1[1] * e2[0];
    }
    const float len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    const float inv = len > 0.0f ? 1.0f / len : 0.0f;
    normal.x[v] = n[0] * inv;
    normal.y[v] = n[1] * inv;
    normal.z[v] = n[2] * inv;
  }
}

}  // namespace haustra::kernels
