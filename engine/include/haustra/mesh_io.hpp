#pragma once
// Triangle meshes from any format assimp reads (OBJ, PLY, STL, glTF, FBX, ...), with the node
// transforms applied, polygons triangulated and identical vertices joined.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <filesystem>
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

}  // namespace haustra
