#include "haustra/mesh_io.hpp"

#include <fmt/format.h>

#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <map>

#include "haustra/error.hpp"

namespace haustra {

TriangleMesh load_mesh(const std::filesystem::path& file) {
  if (!std::filesystem::exists(file)) throw Error(ErrorCode::io, fmt::format("{}: no such mesh file", file.string()));
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(file.string(), aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                                                              aiProcess_PreTransformVertices);
  if (scene == nullptr)
    throw Error(ErrorCode::parse, fmt::format("{}: cannot read the mesh: {}", file.string(), importer.GetErrorString()));
  TriangleMesh mesh;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* am = scene->mMeshes[m];
    const auto base = static_cast<std::uint32_t>(mesh.vertices.size());
    for (unsigned v = 0; v < am->mNumVertices; ++v) {
      const aiVector3D& p = am->mVertices[v];
      const Eigen::Vector3d q(p.x, p.y, p.z);
      if (!q.allFinite())
        throw Error(ErrorCode::invalid_geometry, fmt::format("{}: mesh {} vertex {} is not finite", file.string(), m, v));
      mesh.vertices.push_back(q);
    }
    for (unsigned f = 0; f < am->mNumFaces; ++f) {
      const aiFace& face = am->mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines left by triangulation
      mesh.triangles.push_back({base + face.mIndices[0], base + face.mIndices[1], base + face.mIndices[2]});
    }
  }
  if (mesh.triangles.empty())
    throw Error(ErrorCode::invalid_geometry, fmt::format("{}: the file holds no triangles", file.string()));
  return mesh;
}

bool is_closed(const TriangleMesh& mesh) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> edges;
  for (const auto& t : mesh.triangles)
    for (int e = 0; e < 3; ++e) {
      const std::uint32_t a = t[static_cast<std::size_t>(e)], b = t[static_cast<std::size_t>((e + 1) % 3)];
      edges[{std::min(a, b), std::max(a, b)}] += 1;
    }
  for (const auto& [edge, count] : edges)
    if (count != 2) return false;
  return !edges.empty();
}

}  // namespace haustra
