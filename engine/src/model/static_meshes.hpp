#pragma once
// Static triangle meshes of the environment (other organs, the pelvis, the body around the organs),
// behind Embree scenes for closest-point queries. A closed obstacle has an inside: a bead found
// inside is pushed out through the surface, the side decided by angle-weighted pseudo-normals
// (exact at edges and vertices). An open obstacle is a two-sided sheet. A container (closed, wound
// outward here whatever its file's winding) keeps beads inside: near its wall or anywhere outside,
// a bead is pushed inward (decision 0093). Built once with the model; queries are thread-safe.
#include <embree3/rtcore.h>

#include <array>
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
    std::uint32_t mesh = 0;                           // index in EnvironmentDesc::meshes
    Eigen::Vector3d point = Eigen::Vector3d::Zero();  // closest point on the surface
    Eigen::Vector3d push = Eigen::Vector3d::UnitZ();  // unit direction that takes the query point to its free side
    double signed_distance = 0.0;                     // along `push` from the surface: < 0 on the wrong side
  };
  // The closest surface point within `radius` of p, over all obstacles (containers apart).
  [[nodiscard]] Hit closest(const Eigen::Vector3d& p, double radius) const;
  // Where container `c` holds p in: its nearest surface point when p lies less than `reach` inside
  // it, or anywhere outside it, however far (a bead that got out is pushed back, never lost);
  // `push` points inward. Not found: p is deeper inside than `reach`.
  [[nodiscard]] Hit container_contact(std::size_t c, const Eigen::Vector3d& p, double reach) const;
  [[nodiscard]] std::size_t size() const { return meshes_.size(); }
  [[nodiscard]] std::size_t container_count() const { return containers_.size(); }
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
  // The closest point on triangle `triangle` of `mesh` and the outward pseudo-normal of the feature
  // (face, edge or vertex) that holds it.
  [[nodiscard]] static std::pair<Eigen::Vector3d, Eigen::Vector3d> closest_feature(const Mesh& mesh,
                                                                                   std::uint32_t triangle,
                                                                                   const Eigen::Vector3d& p);

  std::vector<Mesh> meshes_;                // in the description's order
  std::unique_ptr<EmbreeScene> obstacles_;  // its geometry g is meshes_[obstacle_mesh_[g]]
  std::vector<std::uint32_t> obstacle_mesh_;
  // A container's signed distance (inside > 0) at the centres of a coarse grid over its box: a
  // distance is 1-Lipschitz, so a point whose cell says it lies deeper than a reach everywhere
  // near is free without a query — the same answer, found in nanoseconds.
  struct DepthGrid {
    Eigen::Vector3d lo = Eigen::Vector3d::Zero();
    double cell = 1.0;
    std::array<int, 3> n{0, 0, 0};
    std::vector<double> depth;
    [[nodiscard]] double deeper_than(const Eigen::Vector3d& p) const;  // a lower bound of p's depth
  };
  DepthGrid depth_grid(std::size_t container) const;
  [[nodiscard]] double signed_depth(std::size_t container, const Eigen::Vector3d& p, double bound) const;

  // One scene per container: its winding count (the inside test) must see its own surface only.
  std::vector<std::unique_ptr<EmbreeScene>> containers_;
  std::vector<std::uint32_t> container_mesh_;
  std::vector<DepthGrid> container_grid_;
};

}  // namespace haustra::detail
