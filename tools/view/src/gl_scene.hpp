#pragma once
// The viewer's drawing: the organ mesh shaded with its normals, the floor grid, obstacles,
// instruments and the overlays (beads, cage, centreline, contacts, colour by strain or
// penetration), in OpenGL 3.3 core. Geometry is rebuilt on the CPU from each published frame.
#include <cstdint>
#include <string>
#include <vector>

#include "haustra/frame_publisher.hpp"
#include "orbit_camera.hpp"
#include "simulation.hpp"

namespace haustra::view {

enum class Colouring : int { tissue = 0, strain = 1, penetration = 2 };

struct DrawOptions {
  bool beads = false, cage = false, centreline = false, contacts = false;
  bool anchors = true;  // connective tissue: intact anchors as lines to their targets, torn ones marked
  Colouring colour = Colouring::tissue;
  double strain_range = 10.0;  // 1/m at the top of the colour map
  bool show_mouse = false;     // the mouse's grasper (while it holds or presses)
  double force_scale = 0.1;    // m of arrow per newton
};

struct Vertex {
  float p[3];
  float n[3];
  float c[4];
};

// A growable vertex + index list uploaded to its own buffers each frame.
struct Batch {
  std::vector<Vertex> vertices;
  std::vector<std::uint32_t> indices;
  unsigned vao = 0, vbo = 0, ebo = 0;
  void clear() {
    vertices.clear();
    indices.clear();
  }
};

class GlScene {
 public:
  GlScene();  // compiles the shaders: throws haustra::Error with the driver's log
  ~GlScene();
  GlScene(const GlScene&) = delete;
  GlScene& operator=(const GlScene&) = delete;

  // Rebuilds the geometry from a frame (the window holds the slot only during this call).
  void build(const FramePublisher::Slot& frame, const ModelInfo& model, const DrawOptions& options);
  void draw(const OrbitCamera& camera, const DrawOptions& options, int framebuffer_width, int framebuffer_height);

 private:
  void build_organ(const FramePublisher::Slot& f, const ModelInfo& m, const DrawOptions& o);
  void build_overlays(const FramePublisher::Slot& f, const ModelInfo& m, const DrawOptions& o);
  void build_surroundings(const FramePublisher::Slot& f, const ModelInfo& m, const DrawOptions& o);
  void upload(Batch& b);
  void draw_batch(const Batch& b, unsigned mode);

  unsigned program_ = 0;
  int vp_location_ = -1, eye_location_ = -1, lit_location_ = -1;
  Batch opaque_, organ_, lines_, planes_;  // planes: drawn from their free side only
  bool organ_transparent_ = false;
  Eigen::Vector3d subject_centre_ = Eigen::Vector3d::Zero();
  double subject_size_ = 1.0;
};

}  // namespace haustra::view
