#pragma once
// Static triangle meshes of the environment (other organs, the pelvis), behind an Embree scene for
// closest-point queries. A closed mesh has an inside: a bead found inside is pushed out through
// the surface, the side decided by angle-weighted pseudo-normals (exact at edges and vertices).
// An open mesh is a two-sided sheet. Built once with the model; queries are thread-safe.
#include <embree3/rtcore.h>

#include <memory>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <unordered_map>
#include <vector>

#include "haustra/embree_scene.hpp"
#include "haustra/world_desc.hpp"

namespace haustra::detail {

class StaticMeshes {
 public:
  explicit StaticMeshes(const std::vector<MeshObstacleDesc>& meshes);
  ~StaticMeshes();
  StaticMeshes(const StaticMeshes&) = delete;
  StaticMeshes& operator=(const StaticMeshes&) = delete;

  struct Hit {
    bool found = false;
    std::uint32_t mesh = 0;
    Eigen::Vector3d point = Eigen::Vector3d::Zero();  // closest point on the surface
    Eigen::Vector3d push = Eigen::Vector3d::UnitZ();  // unit direction that takes the query point out
    double signed_distance = 0.0;                     // along `push` from the surface: < 0 inside
  };
  // The closest surface point within `radius` of p, over all meshes.
  [[nodiscard]] Hit closest(const Eigen::Vector3d& p, double radius) const;
  [[nodiscard]] std::size_t size() const { return meshes_.size(); }
  [[nodiscard]] bool closed(std::size_t mesh) const { return meshes_[mesh].closed; }

 private:
  struct Mesh {
    std::vector<Eigen::Vector3d> vertices;
    std::vector<std::array<std::uint32_t, 3>> triangles;
    std::vector<Eigen::Vector3d> face_normal;    // unit
    std::vector<Eigen::Vector3d> vertex_normal;  // angle-weighted pseudo-normals
    std::unordered_map<std::uint64_t, Eigen::Vector3d> edge_normal;
    bool closed = false;
  };

  std::vector<Mesh> meshes_;
  std::unique_ptr<EmbreeScene> embree_;
};

}  // namespace haustra::detail
