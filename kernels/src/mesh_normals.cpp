// Vertex normals (mesh_normals.hpp): the one-pass corner form and its two-pass reference.
#include "haustra/kernels/mesh_normals.hpp"

#include <algorithm>
#include <cmath>
#if defined(__AVX2__)
#include <immintrin.h>
#endif

namespace haustra::kernels {

void vertex_corner_pairs(std::span<const std::array<std::uint32_t, 3>> triangles, std::size_t vertex_count,
                         std::span<std::uint32_t> start, std::span<std::uint32_t> pairs) {
  std::fill(start.begin(), start.end(), 0u);
  for (const auto& t : triangles)
    for (std::uint32_t v : t) ++start[v + 1];
  for (std::size_t v = 0; v < vertex_count; ++v) start[v + 1] += start[v];
  // Fill by a cursor per vertex (start[v] advanced), then shift back.
  for (const auto& t : triangles)
    for (int c = 0; c < 3; ++c) {
      const std::uint32_t v = t[static_cast<std::size_t>(c)];
      const std::uint32_t at = start[v]++;
      pairs[2 * at] = t[static_cast<std::size_t>((c + 1) % 3)];
      pairs[2 * at + 1] = t[static_cast<std::size_t>((c + 2) % 3)];
    }
  for (std::size_t v = vertex_count; v > 0; --v) start[v] = start[v - 1];
  start[0] = 0;
}

void vertex_normals(std::span<const std::uint32_t> start, std::span<const std::uint32_t> pairs,
                    std::span<const float> x, std::span<const float> y, std::span<const float> z, std::size_t first,
                    std::size_t count, const FloatVec3Out& normal) {
  for (std::size_t v = first; v < first + count; ++v) {
    const float px = x[v], py = y[v], pz = z[v];
    float nx = 0.0f, ny = 0.0f, nz = 0.0f;
    for (std::uint32_t k = start[v]; k < start[v + 1]; ++k) {
      const std::uint32_t a = pairs[2 * k], b = pairs[2 * k + 1];
      const float ax = x[a] - px, ay = y[a] - py, az = z[a] - pz;
      const float bx = x[b] - px, by = y[b] - py, bz = z[b] - pz;
      nx += ay * bz - az * by;
      ny += az * bx - ax * bz;
      nz += ax * by - ay * bx;
    }
    const float len = std::sqrt(nx * nx + ny * ny + nz * nz);
    const float inv = len > 0.0f ? 1.0f / len : 0.0f;
    normal.x[v] = nx * inv;
    normal.y[v] = ny * inv;
    normal.z[v] = nz * inv;
  }
}

std::size_t append_normal_blocks(std::span<const std::uint32_t> start, std::span<const std::uint32_t> pairs,
                                 std::size_t first, std::size_t count, std::vector<std::uint32_t>& slot_start,
                                 std::vector<NormalSlot>& slots, std::vector<std::uint32_t>& gather_pairs) {
  constexpr std::size_t L = kNormalLanes;
  if (slot_start.empty()) slot_start.push_back(0);
  const std::size_t blocks = count / L;
  for (std::size_t b = 0; b < blocks; ++b) {
    const std::size_t v0 = first + b * L;
    std::uint32_t most = 0;
    for (std::size_t l = 0; l < L; ++l) most = std::max(most, start[v0 + l + 1] - start[v0 + l]);
    for (std::uint32_t s = 0; s < most; ++s) {
      std::uint32_t a[L], bb[L];
      for (std::size_t l = 0; l < L; ++l) {
        const auto v = static_cast<std::uint32_t>(v0 + l);
        const bool has = s < start[v + 1] - start[v];
        a[l] = has ? pairs[2 * (start[v] + s)] : v;
        bb[l] = has ? pairs[2 * (start[v] + s) + 1] : v;
      }
      NormalSlot slot;
      slot.da = static_cast<std::int32_t>(a[0]) - static_cast<std::int32_t>(v0);
      slot.db = static_cast<std::int32_t>(bb[0]) - static_cast<std::int32_t>(v0);
      bool regular = true;
      for (std::size_t l = 1; l < L; ++l)
        regular = regular && static_cast<std::int64_t>(a[l]) - static_cast<std::int64_t>(v0 + l) == slot.da &&
                  static_cast<std::int64_t>(bb[l]) - static_cast<std::int64_t>(v0 + l) == slot.db;
      if (!regular) {
        slot.gather = static_cast<std::uint32_t>(gather_pairs.size() / (2 * L));
        gather_pairs.insert(gather_pairs.end(), a, a + L);
        gather_pairs.insert(gather_pairs.end(), bb, bb + L);
      }
      slots.push_back(slot);
    }
    slot_start.push_back(static_cast<std::uint32_t>(slots.size()));
  }
  return blocks;
}

void vertex_normals_blocked(const NormalBlocksView& blocks, std::size_t first_block,
                            std::span<const std::uint32_t> start, std::span<const std::uint32_t> pairs,
                            std::span<const float> x, std::span<const float> y, std::span<const float> z,
                            std::size_t first, std::size_t count, const FloatVec3Out& normal) {
  constexpr std::size_t L = kNormalLanes;
  const std::size_t whole = count / L;
#if defined(__AVX2__)
  const float* px = x.data();
  const float* py = y.data();
  const float* pz = z.data();
  for (std::size_t b = 0; b < whole; ++b) {
    const std::size_t v0 = first + b * L, block = first_block + b;
    const __m256 cx = _mm256_loadu_ps(px + v0), cy = _mm256_loadu_ps(py + v0), cz = _mm256_loadu_ps(pz + v0);
    __m256 nx = _mm256_setzero_ps(), ny = _mm256_setzero_ps(), nz = _mm256_setzero_ps();
    for (std::uint32_t s = blocks.slot_start[block]; s < blocks.slot_start[block + 1]; ++s) {
      const NormalSlot& slot = blocks.slots[s];
      __m256 ax, ay, az, bx, by, bz;
      if (slot.gather == kRegularSlot) {
        const std::ptrdiff_t a = static_cast<std::ptrdiff_t>(v0) + slot.da,
                             c = static_cast<std::ptrdiff_t>(v0) + slot.db;
        ax = _mm256_loadu_ps(px + a);
        ay = _mm256_loadu_ps(py + a);
        az = _mm256_loadu_ps(pz + a);
        bx = _mm256_loadu_ps(px + c);
        by = _mm256_loadu_ps(py + c);
        bz = _mm256_loadu_ps(pz + c);
      } else {
        const std::uint32_t* g = blocks.gather_pairs.data() + 2 * L * slot.gather;
        const __m256i ia = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(g));
        const __m256i ib = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(g + L));
        ax = _mm256_i32gather_ps(px, ia, 4);
        ay = _mm256_i32gather_ps(py, ia, 4);
        az = _mm256_i32gather_ps(pz, ia, 4);
        bx = _mm256_i32gather_ps(px, ib, 4);
        by = _mm256_i32gather_ps(py, ib, 4);
        bz = _mm256_i32gather_ps(pz, ib, 4);
      }
      ax = _mm256_sub_ps(ax, cx);
      ay = _mm256_sub_ps(ay, cy);
      az = _mm256_sub_ps(az, cz);
      bx = _mm256_sub_ps(bx, cx);
      by = _mm256_sub_ps(by, cy);
      bz = _mm256_sub_ps(bz, cz);
      nx = _mm256_add_ps(nx, _mm256_fmsub_ps(ay, bz, _mm256_mul_ps(az, by)));
      ny = _mm256_add_ps(ny, _mm256_fmsub_ps(az, bx, _mm256_mul_ps(ax, bz)));
      nz = _mm256_add_ps(nz, _mm256_fmsub_ps(ax, by, _mm256_mul_ps(ay, bx)));
    }
    const __m256 len2 = _mm256_fmadd_ps(nx, nx, _mm256_fmadd_ps(ny, ny, _mm256_mul_ps(nz, nz)));
    const __m256 len = _mm256_sqrt_ps(len2);
    const __m256 positive = _mm256_cmp_ps(len, _mm256_setzero_ps(), _CMP_GT_OQ);
    const __m256 inv = _mm256_and_ps(positive, _mm256_div_ps(_mm256_set1_ps(1.0f), len));
    _mm256_storeu_ps(normal.x.data() + v0, _mm256_mul_ps(nx, inv));
    _mm256_storeu_ps(normal.y.data() + v0, _mm256_mul_ps(ny, inv));
    _mm256_storeu_ps(normal.z.data() + v0, _mm256_mul_ps(nz, inv));
  }
  vertex_normals(start, pairs, x, y, z, first + whole * L, count - whole * L, normal);
#else
  (void)blocks;
  (void)first_block;
  (void)whole;
  vertex_normals(start, pairs, x, y, z, first, count, normal);
#endif
}

void face_normals_reference(std::span<const std::array<std::uint32_t, 3>> triangles, std::span<const float> x,
                            std::span<const float> y, std::span<const float> z, std::size_t first, std::size_t count,
                            const FloatVec3Out& normal) {
  for (std::size_t t = first; t < first + count; ++t) {
    const auto& tri = triangles[t];
    const float e1[3] = {x[tri[1]] - x[tri[0]], y[tri[1]] - y[tri[0]], z[tri[1]] - z[tri[0]]};
    const float e2[3] = {x[tri[2]] - x[tri[0]], y[tri[2]] - y[tri[0]], z[tri[2]] - z[tri[0]]};
    normal.x[t] = e1[1] * e2[2] - e1[2] * e2[1];
    normal.y[t] = e1[2] * e2[0] - e1[0] * e2[2];
    normal.z[t] = e1[0] * e2[1] - e1[1] * e2[0];
  }
}

void vertex_normals_reference(std::span<const std::uint32_t> vertex_triangle_start,
                              std::span<const std::uint32_t> vertex_triangle, std::span<const float> face_x,
                              std::span<const float> face_y, std::span<const float> face_z, std::size_t first_vertex,
                              std::size_t vertex_count, const FloatVec3Out& normal) {
  for (std::size_t v = first_vertex; v < first_vertex + vertex_count; ++v) {
    float n[3] = {0.0f, 0.0f, 0.0f};
    for (std::uint32_t k = vertex_triangle_start[v]; k < vertex_triangle_start[v + 1]; ++k) {
      const std::uint32_t t = vertex_triangle[k];
      n[0] += face_x[t];
      n[1] += face_y[t];
      n[2] += face_z[t];
    }
    const float len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    const float inv = len > 0.0f ? 1.0f / len : 0.0f;
    normal.x[v] = n[0] * inv;
    normal.y[v] = n[1] * inv;
    normal.z[v] = n[2] * inv;
  }
}

}  // namespace haustra::kernels
