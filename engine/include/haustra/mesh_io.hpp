#pragma once
// Triangle meshes read through assimp (OBJ, STL, OFF, glTF: see kMeshFormats), with the node
// transforms applied, polygons triangulated and identical vertices joined; written as OBJ, PLY,
// STL or glTF.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace haustra {

struct TriangleMesh {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;
};

// The mesh formats the engine reads (lower case), all through assimp.
inline constexpr std::array<std::string_view, 5> kMeshFormats = {".obj", ".stl", ".off", ".gltf", ".glb"};

// The largest mesh the engine takes (indices are 32-bit; skinning data grows ~100 bytes a vertex).
inline constexpr std::size_t kMaxMeshVertices = std::size_t{1} << 24;
// And the largest file it will hand to a reader.
inline constexpr std::uintmax_t kMaxMeshFileBytes = std::uintmax_t{2} << 30;

// Throws Error{io} (cannot read), Error{parse} (assimp's message), Error{invalid_argument} (a file
// or mesh beyond the limits above) or Error{invalid_geometry} (what check_mesh finds), naming the file.
TriangleMesh load_mesh(const std::filesystem::path& file);
// The same without check_mesh: what the file holds, defects and all (for a repair to look at).
TriangleMesh load_mesh_as_read(const std::filesystem::path& file);

// What the engine relies on in a mesh: triangles, finite vertices, indices in range, no triangle
// that repeats a vertex or has no area, no edge shared by more than two triangles, neighbouring
// triangles wound the same way. Open boundaries are allowed (a bowel segment is a tube). Throws
// Error{invalid_geometry} naming `where`, the triangle and its vertices.
void check_mesh(const TriangleMesh& mesh, const std::string& where);

// True when every edge is shared by exactly two triangles (the mesh bounds a volume).
bool is_closed(const TriangleMesh& mesh);

// The triangles for which keep[t] is nonzero, with the vertices they use, numbered in the order
// the kept triangles first use them.
// `kept`, when given: each of the submesh's vertices' index in `mesh`.
TriangleMesh submesh(const TriangleMesh& mesh, std::span<const std::uint8_t> keep,
                     std::vector<std::uint32_t>* kept = nullptr);

// Writes a mesh in the format of the file's extension (.obj, .ply binary, .stl, .glb), through
// assimp's exporters. normals: one per vertex, or empty. Throws Error{io} naming the file.
void save_mesh(const std::filesystem::path& file, const TriangleMesh& mesh,
               std::span<const Eigen::Vector3d> normals = {});

// Enclosed volume of a closed, outward-oriented mesh (divergence theorem), m³.
double mesh_volume(std::span<const Eigen::Vector3d> vertices, std::span<const std::array<std::uint32_t, 3>> triangles);

}  // namespace haustra
