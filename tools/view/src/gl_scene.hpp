#pragma once
// The viewer's drawing: the organ mesh shaded with its normals, the floor grid, obstacles,
// instruments and the overlays (beads, cage, centreline, contacts, colour by strain or
// penetration), in OpenGL 3.3 core. Geometry is rebuilt on the CPU from each published frame; the
// organ is drawn from its levels of detail (organ_lod.hpp) within a triangle budget, skinned by the
// GPU from the frame's rings where GL allows it (decision 0110), else from the CPU's mesh.
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "gpu_skin_gl.hpp"
#include "haustra/frame_publisher.hpp"
#include "orbit_camera.hpp"
#include "organ_lod.hpp"
#include "simulation.hpp"

namespace haustra::view {

enum class Colouring : int { tissue = 0, strain = 1, penetration = 2 };

// What the inspector has selected, drawn highlighted: an organ, an instrument, an organ's
// connective tissue, or an obstacle (by its kind's index in the environment).
struct Highlight {
  enum class Kind { none, organ, instrument, anchors, plane, sphere, capsule, mesh };
  Kind kind = Kind::none;
  std::size_t index = 0;
  bool operator==(const Highlight&) const = default;
};

// The box around the organs as drawn: their nodes and their skin (a frame skinned by the GPU: the
// nodes' box grown by the model's skin reach).
std::array<Eigen::Vector3d, 2> drawn_bounds(const FramePublisher::Slot& frame, const ModelInfo& model);

struct DrawOptions {
  bool beads = false, cage = false, centreline = false, contacts = false;
  bool anchors = true;  // connective tissue: intact anchors as lines to their targets, torn ones marked
  Colouring colour = Colouring::tissue;
  double strain_range = 10.0;  // 1/m at the top of the colour map
  bool show_mouse = false;     // the mouse's grasper (while it holds or presses)
  double force_scale = 0.1;    // m of arrow per newton
  // The organ's drawn triangles at most (its chunks coarsened where they look small, organ_lod.hpp):
  // what keeps a 300k-vertex mesh interactive on a software renderer.
  std::size_t triangle_budget = 100'000;
  Highlight highlight;
  bool gpu_skinning = true;  // the organ skinned by the GPU (K); the CPU's mesh where GL cannot
};

// Where a ray first meets the organ as drawn.
struct OrganHit {
  double distance = 0.0;
  Eigen::Vector3d point = Eigen::Vector3d::Zero(), normal = Eigen::Vector3d::UnitZ();
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

  // Rebuilds the geometry from a frame (the window holds the slot only during this call); the
  // camera chooses the organ's levels of detail.
  void build(const FramePublisher::Slot& frame, const ModelInfo& model, const DrawOptions& options,
             const OrbitCamera& camera);
  void draw(const OrbitCamera& camera, const DrawOptions& options, int framebuffer_width, int framebuffer_height);
  // The box around the nodes of the frame built last.
  [[nodiscard]] const Eigen::Vector3d& subject_lo() const { return subject_lo_; }
  [[nodiscard]] const Eigen::Vector3d& subject_hi() const { return subject_hi_; }
  // Picking against what is drawn: the organ's triangles of the last build.
  [[nodiscard]] std::optional<OrganHit> pick_organ(const Ray& ray) const;
  [[nodiscard]] std::size_t organ_triangles_drawn() const { return organ_triangles_drawn_; }
  // Whether the next frames should come as rings for the GPU (FramePublisher::skin_on_gpu): asked,
  // and this context runs the shader for the model drawn last.
  [[nodiscard]] bool wants_gpu_skinning(const DrawOptions& o) const {
    return o.gpu_skinning && skin_supported_ && skin_fits_;
  }
  // Whether the organ of the last build was skinned by the GPU.
  [[nodiscard]] bool organ_on_gpu() const { return organ_on_gpu_; }

 private:
  void build_organ(const FramePublisher::Slot& f, const ModelInfo& m, const DrawOptions& o, const OrbitCamera& c);
  void prepare_lod(const FramePublisher::Slot& f, const ModelInfo& m);
  void build_overlays(const FramePublisher::Slot& f, const ModelInfo& m, const DrawOptions& o);
  void build_surroundings(const FramePublisher::Slot& f, const ModelInfo& m, const DrawOptions& o);
  void upload(Batch& b);
  void draw_batch(const Batch& b, unsigned mode);
  void draw_organ();
  void prepare_gpu_skin(const ModelInfo& m);

  unsigned program_ = 0;
  int vp_location_ = -1, eye_location_ = -1, lit_location_ = -1;
  Batch opaque_, organ_, lines_, planes_;  // planes: drawn from their free side only
  Batch grid_;                             // the planes' grid lines, drawn with their plane
  Batch overlay_;                          // lines over everything (the grasp's spring)
  struct PlaneRange {
    Eigen::Vector3d point, normal;
    std::uint32_t first_index = 0, index_count = 0;
  };
  std::vector<PlaneRange> grid_ranges_;
  // The organ's levels (rebuilt when the mesh's triangles change) and this frame's draws: each a
  // block of organ_'s vertices (base) over the block's static indices in the LOD's buffer.
  OrganLod lod_;
  std::vector<std::array<std::uint32_t, 3>> lod_triangles_;
  unsigned lod_ebo_ = 0;
  struct LodDraw {
    std::uint32_t base_vertex = 0, first_index = 0, index_count = 0;
    double distance = 0.0;  // from the eye: drawn nearest first
    std::uint32_t vertex_count = 0;
  };
  std::vector<LodDraw> lod_draws_;
  std::vector<int> lod_levels_;
  std::vector<Eigen::Vector3d> lod_nodes_;
  std::size_t organ_triangles_drawn_ = 0;
  // Skinning on the GPU (decision 0110): its program, the binding's buffers, per LOD vertex its
  // static attributes and (when not plain) its colour; the frame's rings kept for picking.
  unsigned skin_program_ = 0;
  int skin_vp_location_ = -1, skin_eye_location_ = -1, skin_lit_location_ = -1;
  GpuSkinBuffers skin_;
  unsigned skin_vao_ = 0, skin_vbo_ = 0, skin_colour_vbo_ = 0;
  std::shared_ptr<const GpuSkinBinding> skin_binding_;  // uploaded to skin_
  std::size_t skin_lod_build_ = 0, lod_build_ = 0;      // LOD builds: skin_vbo_ holds build skin_lod_build_'s
  bool skin_supported_ = false, organ_on_gpu_ = false, organ_plain_ = true;
  bool skin_fits_ = true;                               // the last model's binding fits a texture buffer
  std::shared_ptr<const GpuSkinBinding> skin_checked_;  // the binding skin_fits_ is of
  std::array<float, 4> organ_colour_{};
  std::vector<float> skin_rings_, skin_colours_;
  Eigen::Matrix4f draw_vp_ = Eigen::Matrix4f::Identity();  // draw()'s, for the organ's own program
  Eigen::Vector3f draw_eye_ = Eigen::Vector3f::Zero();
  Batch tubes_;  // segments without a mesh
  bool organ_transparent_ = false;
  Eigen::Vector3d subject_centre_ = Eigen::Vector3d::Zero(), subject_lo_ = Eigen::Vector3d::Zero(),
                  subject_hi_ = Eigen::Vector3d::Zero();
  double subject_size_ = 1.0;
};

}  // namespace haustra::view
