#pragma once
// An Embree device and scene of static triangle meshes, built once (environment obstacles, cages,
// organ meshes for checks, pictures) and then queried from any thread: first hits along rays,
// winding numbers (inside tests) and closest points.
//
// Why commits run on the calling thread only: Debian's Embree schedules its BVH build on oneTBB,
// in the caller's arena. Neither library is built with ThreadSanitizer, so memory that a builder
// thread allocates and the caller frees looks like a race, and a build spread over a host's arena
// would also compete with the host's own work. The scenes here are small (a cage has hundreds of
// triangles, an organ mesh tens of thousands), so a single-threaded build costs milliseconds.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <span>
#include <vector>

// Embree's handles, declared rather than included: Embree stays off the engine's public include
// and link lines.
struct RTCDeviceTy;
struct RTCSceneTy;
struct RTCPointQueryFunctionArguments;

namespace haustra {

class EmbreeScene {
 public:
  EmbreeScene();
  ~EmbreeScene();
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  // Adds a triangle mesh (vertices rounded to float); returns its geometry id, counting from 0.
  unsigned add_triangles(std::span<const Eigen::Vector3d> vertices,
                         std::span<const std::array<std::uint32_t, 3>> triangles);
  // Builds the acceleration structure; throws Error{internal} with Embree's complaint.
  void commit();

  // Queries on a committed scene; thread-safe. Triangles are named by (geometry, primitive).
  struct Hit {
    bool found = false;
    unsigned geometry = 0, triangle = 0;
    double distance = 0.0;    // along the ray, or to the closest point
    double u = 0.0, v = 0.0;  // ray hits: barycentric coordinates of vertices 1 and 2 of the triangle
  };
  // The first triangle a ray meets in (t_near, t_far); direction need not be unit (t scales with it).
  [[nodiscard]] Hit first_hit(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_near,
                              double t_far) const;
  // The winding number of closed, outward-oriented surfaces around the ray's origin, counted along
  // the ray: +1 for every triangle it leaves through, −1 for every one it enters through.
  [[nodiscard]] int winding(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) const;
  // Inside (winding number ≥ 1, so the union of overlapping closed surfaces counts as inside),
  // by majority over three fixed, unrelated directions: a ray grazing an edge or a vertex can
  // miscount, two rarely both do.
  [[nodiscard]] bool inside(const Eigen::Vector3d& p) const;
  // The closest point on any triangle within `radius` (in double, from the stored geometry).
  [[nodiscard]] Hit closest(const Eigen::Vector3d& p, double radius) const;
  [[nodiscard]] const std::vector<Eigen::Vector3d>& vertices(unsigned geometry) const {
    return meshes_[geometry].vertices;
  }
  [[nodiscard]] const std::vector<std::array<std::uint32_t, 3>>& triangles(unsigned geometry) const {
    return meshes_[geometry].triangles;
  }

 private:
  struct Mesh {
    std::vector<Eigen::Vector3d> vertices;
    std::vector<std::array<std::uint32_t, 3>> triangles;
  };
  struct ClosestQuery;
  static bool on_closest(RTCPointQueryFunctionArguments* args);

  RTCDeviceTy* device_ = nullptr;
  RTCSceneTy* scene_ = nullptr;
  unsigned geometries_ = 0;
  std::vector<Mesh> meshes_;
};

}  // namespace haustra
