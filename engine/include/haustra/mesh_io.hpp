#pragma once
// Triangle meshes from any format assimp reads (OBJ, PLY, STL, glTF, FBX, ...), with the node
// transforms applied, polygons triangulated and identical vertices joined.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

namespace haustra {

struct TriangleMesh {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;
};

// Throws Error{io} (cannot read), Error{parse} (assimp's message), or Error{invalid_geometry}
// (no triangles, non-finite coordinates, indices out of range), naming the file.
TriangleMesh load_mesh(const std::filesystem::path& file);

// True when every edge is shared by exactly two triangles (the mesh bounds a volume).
bool is_closed(const TriangleMesh& mesh);

// Writes a mesh in the format of the file's extension (.obj, .ply binary, .stl, .glb), through
// assimp's exporters. normals: one per vertex, or empty. Throws Error{io} naming the file.
void save_mesh(const std::filesystem::path& file, const TriangleMesh& mesh,
               std::span<const Eigen::Vector3d> normals = {});

// Enclosed volume of a closed, outward-oriented mesh (divergence theorem), m³.
double mesh_volume(std::span<const Eigen::Vector3d> vertices, std::span<const std::array<std::uint32_t, 3>> triangles);

}  // namespace haustra
