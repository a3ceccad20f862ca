#pragma once
// Headless pictures of a world: every triangle of it (organ meshes, the rod as a tube where there
// is no mesh, floor planes, obstacles, instruments, and optional overlays: beads, cage, centreline,
// contact points, colour by strain or penetration) ray-cast with Embree, shaded with a sun, a fill
// light and shadows, antialiased.
#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "haustra/render/image.hpp"
#include "haustra/world.hpp"
#include "haustra/world_desc.hpp"

namespace haustra::render {

struct Camera {
  Eigen::Vector3d eye = Eigen::Vector3d(1.0, -2.0, 1.0);
  Eigen::Vector3d target = Eigen::Vector3d::Zero();
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  double fov_degrees = 35.0;  // vertical
};

enum class Colouring : std::uint8_t {
  tissue,       // one colour
  strain,       // the organ by the bending strain |κ − κ̂| of its nearest node (1/m)
  penetration,  // beads by their deepest contact over their radius
};

struct Overlays {
  bool beads = false;
  bool cage = false;
  bool centreline = false;
  bool contacts = false;
  Colouring colour = Colouring::tissue;
};

struct RenderOptions {
  int width = 960, height = 600;
  std::optional<Camera> camera;                                 // default: fitted to the segments and instruments
  Eigen::Vector3d view_from = Eigen::Vector3d(1.0, -1.6, 0.9);  // direction from the target to a fitted eye
  Overlays overlays;
  int samples = 2;  // per pixel side (2: 4 rays per pixel)
  // Extra polylines drawn as thin wires (the cage's colour): templates, construction lines.
  std::vector<std::vector<Eigen::Vector3d>> wires;
  bool shadows = true;
};

// What each pixel shows (the most opaque thing along its centre ray), for checks.
enum class Shows : std::uint8_t {
  background,
  floor,
  organ,
  rod,
  bead,
  cage,
  centreline,
  contact,
  instrument,
  obstacle
};

struct Picture {
  Image image;
  std::vector<Shows> shows;  // width × height
  Camera camera;
  double colour_min = 0.0, colour_max = 0.0;  // range of the colour overlay's values (strain 1/m, depth/r)
  [[nodiscard]] Shows at(int x, int y) const { return shows[static_cast<std::size_t>(y * image.width() + x)]; }
};

// The box around the segments (nodes, meshes) and instrument tips, grown to include them.
void grow_bounds(const World& world, Eigen::Vector3d& lo, Eigen::Vector3d& hi);
// The camera that frames a box (or the world's current box) from direction `from`.
Camera fit_camera(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const Eigen::Vector3d& from, double fov_degrees,
                  double aspect);
Camera fit_camera(const World& world, const Eigen::Vector3d& from, double fov_degrees, double aspect);

// Per mesh vertex (an index into the world's mesh buffers), the nearest node of its own segment at
// the world's current pose: what colours a vertex by its node's strain.
std::vector<std::uint32_t> nearest_nodes(const World& world);

// desc: the description the world was built from (for planes, obstacles and instrument sizes).
Picture render(const World& world, const WorldDesc& desc, const RenderOptions& options);

}  // namespace haustra::render
