#pragma once
// The organ's drawn levels of detail (issue 39): the mesh cut into chunks along its centreline, each
// chunk simplified by vertex clustering at cells of 2, 4, 8 and 16 mean edges (and the normal's
// dominant direction), with the vertices it
// shares with other chunks kept at every level, so chunks drawn at different levels meet without
// cracks. Every drawn vertex is a vertex of the mesh: the skinned positions each frame are read
// through `source`. Pure: no GL, no files (decision 0104).
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace haustra::view {

inline constexpr int kLodLevels = 5;  // 0: the mesh itself; level l: cells of 2^l mean edges

struct LodBlock {
  std::uint32_t first_vertex = 0, vertex_count = 0;  // into OrganLod::source
  std::uint32_t first_index = 0, index_count = 0;    // into OrganLod::indices (local to the block)
};

struct LodChunk {
  std::uint32_t first_node = 0, node_count = 0;  // its triangles' nodes (the frame's node positions)
  double reach = 0.0;                            // m: the farthest of its vertices from their node, at build
  std::array<LodBlock, kLodLevels> levels;
};

struct OrganLod {
  double mean_edge = 0.0;  // m, over the whole mesh at build
  std::vector<LodChunk> chunks;
  std::vector<std::uint32_t> source;   // per block vertex: the mesh vertex it is
  std::vector<std::uint32_t> indices;  // per block: triangles over the block's own vertices
  [[nodiscard]] double cell(int level) const { return level == 0 ? 0.0 : mean_edge * double(1 << level); }
};

// positions, normals: the mesh's vertices at build (a cell keeps apart vertices facing apart); vertex_node: each
// vertex's nearest node; nodes: the nodes at build; triangles_per_chunk: about how many of the mesh's triangles each
// chunk takes.
[[nodiscard]] OrganLod build_organ_lod(std::span<const Eigen::Vector3d> positions,
                                       std::span<const Eigen::Vector3d> normals,
                                       std::span<const std::array<std::uint32_t, 3>> triangles,
                                       std::span<const std::uint32_t> vertex_node,
                                       std::span<const Eigen::Vector3d> nodes, std::size_t triangles_per_chunk = 4000);

// Which level each chunk is drawn at, -1 for a chunk outside the view: the coarsest level for all,
// then the chunk whose cells look largest on screen refined, again and again, while the drawn
// triangles stay within `triangle_budget` and its cells are more than a pixel.
struct LodView {
  Eigen::Matrix4d view_projection;
  Eigen::Vector3d eye;
  double pixels_per_radian = 1000.0;  // the viewport's height over its vertical field of view
};
void choose_lod_levels(const OrganLod& lod, std::span<const Eigen::Vector3d> node_positions, const LodView& view,
                       std::size_t triangle_budget, std::span<int> level_out);

}  // namespace haustra::view
