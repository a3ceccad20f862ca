// What the engine requires of a triangle mesh it loads (docs/decisions/0022-input-requirements-and-error-codes.md).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "haustra/error.hpp"
#include "haustra/mesh_io.hpp"

namespace haustra {
namespace {

struct HalfEdge {
  std::uint32_t low, high;  // the edge's vertices, sorted
  std::uint32_t triangle;
  bool forward;  // the triangle walks it from low to high
  auto key() const { return std::pair{low, high}; }
};

// Vertices by position as well as index: a reader renumbers them (assimp joins identical ones).
std::string vertex_at(const TriangleMesh& mesh, std::uint32_t v) {
  const Eigen::Vector3d& p = mesh.vertices[v];
  return fmt::format("{} at ({:.4g}, {:.4g}, {:.4g})", v, p.x(), p.y(), p.z());
}

[[noreturn]] void reject(const std::string& where, const std::string& detail) {
  throw Error(ErrorCode::invalid_geometry, fmt::format("{}: {}", where, detail));
}

}  // namespace

void check_mesh(const TriangleMesh& mesh, const std::string& where) {
  if (mesh.vertices.empty() || mesh.triangles.empty()) reject(where, "the mesh holds no triangles");
  if (mesh.vertices.size() > kMaxMeshVertices || mesh.triangles.size() > 2 * kMaxMeshVertices)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("{}: {} vertices and {} triangles: more than the engine takes ({} vertices, twice as many "
                            "triangles); decimate the mesh",
                            where, mesh.vertices.size(), mesh.triangles.size(), kMaxMeshVertices));
  Eigen::Vector3d lo = mesh.vertices.front(), hi = lo;
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    if (!mesh.vertices[v].allFinite()) reject(where, fmt::format("vertex {} is not finite", v));
    lo = lo.cwiseMin(mesh.vertices[v]);
    hi = hi.cwiseMax(mesh.vertices[v]);
  }
  // Zero area relative to the mesh's size: a sliver whose normal is pure rounding.
  const double area_floor = 1e-14 * (hi - lo).squaredNorm();
  std::vector<HalfEdge> edges;
  edges.reserve(3 * mesh.triangles.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    for (std::uint32_t v : tri)
      if (v >= mesh.vertices.size())
        reject(where, fmt::format("triangle {} uses vertex {}, but the mesh has {}", t, v, mesh.vertices.size()));
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2])
      reject(where, fmt::format("triangle {} repeats a vertex ({}, {}, {}): a degenerate triangle", t, tri[0], tri[1],
                                tri[2]));
    const Eigen::Vector3d& a = mesh.vertices[tri[0]];
    const double doubled_area = (mesh.vertices[tri[1]] - a).cross(mesh.vertices[tri[2]] - a).norm();
    if (!(0.5 * doubled_area > area_floor))
      reject(where, fmt::format("triangle {} (vertices {}, {}, {}) has no area: a degenerate triangle", t,
                                vertex_at(mesh, tri[0]), vertex_at(mesh, tri[1]), vertex_at(mesh, tri[2])));
    for (int e = 0; e < 3; ++e) {
      const std::uint32_t from = tri[static_cast<std::size_t>(e)], to = tri[static_cast<std::size_t>((e + 1) % 3)];
      edges.push_back({std::min(from, to), std::max(from, to), static_cast<std::uint32_t>(t), from < to});
    }
  }
  std::sort(edges.begin(), edges.end(), [](const HalfEdge& x, const HalfEdge& y) {
    return x.key() != y.key() ? x.key() < y.key() : x.triangle < y.triangle;
  });
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i + 1;
    while (j < edges.size() && edges[j].key() == edges[i].key()) ++j;
    if (j - i > 2)
      reject(where,
             fmt::format("the edge between vertices {} and {} is shared by {} triangles ({}, {}, {}...): the mesh "
                         "is not a manifold surface",
                         vertex_at(mesh, edges[i].low), vertex_at(mesh, edges[i].high), j - i, edges[i].triangle,
                         edges[i + 1].triangle, edges[i + 2].triangle));
    if (j - i == 2 && edges[i].forward == edges[i + 1].forward)
      reject(
          where,
          fmt::format(
              "triangles {} and {} run the same way along their shared edge (vertices {} and {}): the winding is "
              "inconsistent, so normals would flip between them",
              edges[i].triangle, edges[i + 1].triangle, vertex_at(mesh, edges[i].low), vertex_at(mesh, edges[i].high)));
    i = j;
  }
}

}  // namespace haustra
