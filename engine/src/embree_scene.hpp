#pragma once
// An Embree device and scene of static triangle meshes, built once (environment obstacles, cages,
// organ meshes for checks and rendering) and then queried from any thread.
//
// Why commits run on the calling thread only: Debian's Embree schedules its BVH build on oneTBB,
// in the caller's arena. Neither library is built with ThreadSanitizer, so memory that a builder
// thread allocates and the caller frees looks like a race, and a build spread over a host's arena
// would also compete with the host's own work. The scenes here are small (a cage has hundreds of
// triangles, an organ mesh tens of thousands), so a single-threaded build costs milliseconds.
#include <embree3/rtcore.h>

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <span>

namespace haustra::detail {

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

  [[nodiscard]] RTCScene scene() const { return scene_; }
  [[nodiscard]] RTCDevice device() const { return device_; }

 private:
  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
  unsigned geometries_ = 0;
};

}  // namespace haustra::detail
