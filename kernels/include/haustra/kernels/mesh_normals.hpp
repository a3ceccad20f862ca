#pragma once
// Vertex normals of a triangle mesh: area-weighted (the sum of the incident triangles' normals,
// each as long as twice its triangle's area), unit length, zero for a vertex of no triangle.
//
// The fast form takes one pass over the vertices: each vertex keeps the other two corners (a, b)
// of its incident triangles, in their winding order, so that n_v = Σ (p_a − p_v) × (p_b − p_v)
// — the same area-weighted sum, without writing and re-reading a normal per triangle — for 8
// consecutive vertices at once (AVX2). Their pairs line up in slots; where every lane's pair sits
// at the same offsets from its vertex (a mesh laid out ring by ring: the procedural organs) the
// slot loads its 8 neighbours with two plain vector loads per axis, else it gathers them. The
// reference takes two passes: every triangle's normal, then each vertex's sum of them.
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "haustra/kernels/skinning.hpp"

namespace haustra::kernels {

// The corner pairs of each vertex (CSR): start has vertex_count + 1 entries; pairs 2 per
// incident triangle, in triangle order. Built once with the model.
void vertex_corner_pairs(std::span<const std::array<std::uint32_t, 3>> triangles, std::size_t vertex_count,
                         std::span<std::uint32_t> start, std::span<std::uint32_t> pairs);

// Blocks of kNormalLanes consecutive vertices: per block its slots (CSR), each slot one corner pair
// per lane — at offsets (da, db) from each lane's vertex, or gathered from 16 indices (the lanes'
// a, then their b). A lane short of pairs repeats its own vertex (a zero cross product).
inline constexpr std::size_t kNormalLanes = 8;
inline constexpr std::uint32_t kRegularSlot = 0xFFFFFFFFu;
struct NormalSlot {
  std::int32_t da = 0, db = 0;
  std::uint32_t gather = kRegularSlot;  // else: the index of its 16 entries in gather_pairs / 16
};
struct NormalBlocksView {
  std::span<const std::uint32_t> slot_start;  // blocks + 1
  std::span<const NormalSlot> slots;
  std::span<const std::uint32_t> gather_pairs;
};

// Vertices [first, first + count) of one mesh as blocks and their slots, appended (model building;
// the corner pairs as vertex_corner_pairs gives them). Returns the blocks made; the last
// count % kNormalLanes vertices are left to vertex_normals.
std::size_t append_normal_blocks(std::span<const std::uint32_t> start, std::span<const std::uint32_t> pairs,
                                 std::size_t first, std::size_t count, std::vector<std::uint32_t>& slot_start,
                                 std::vector<NormalSlot>& slots, std::vector<std::uint32_t>& gather_pairs);

// Unit area-weighted normals of vertices [first, first + count): whole blocks from `blocks`
// (their first is first_block), the rest one by one from the corner pairs.
void vertex_normals_blocked(const NormalBlocksView& blocks, std::size_t first_block,
                            std::span<const std::uint32_t> start, std::span<const std::uint32_t> pairs,
                            std::span<const float> x, std::span<const float> y, std::span<const float> z,
                            std::size_t first, std::size_t count, const FloatVec3Out& normal);

// Unit area-weighted normals of vertices [first, first + count) from their corner pairs, one by
// one (the blocked form's tail, and its plain reference).
void vertex_normals(std::span<const std::uint32_t> start, std::span<const std::uint32_t> pairs,
                    std::span<const float> x, std::span<const float> y, std::span<const float> z, std::size_t first,
                    std::size_t count, const FloatVec3Out& normal);

// Reference, pass 1: triangle normals (twice the area long) of triangles [first, first + count).
void face_normals_reference(std::span<const std::array<std::uint32_t, 3>> triangles, std::span<const float> x,
                            std::span<const float> y, std::span<const float> z, std::size_t first, std::size_t count,
                            const FloatVec3Out& normal);

// Reference, pass 2: each vertex's unit sum of its triangles' normals; vertex_triangle(_start):
// CSR rows of the triangles around each vertex, summed in that order.
void vertex_normals_reference(std::span<const std::uint32_t> vertex_triangle_start,
                              std::span<const std::uint32_t> vertex_triangle, std::span<const float> face_x,
                              std::span<const float> face_y, std::span<const float> face_z, std::size_t first_vertex,
                              std::size_t vertex_count, const FloatVec3Out& normal);

}  // namespace haustra::kernels
