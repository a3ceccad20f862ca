#pragma once
// Skinning on the GPU in OpenGL 3.3 core (decision 0110): the binding's texture buffers, the frame's
// ring data, and per drawn vertex its rest position, rest normal and slot range, for
// render/shaders/haustra_skin.glsl. Used by the viewer and by its transform-feedback test.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "haustra/gpu_skin.hpp"

namespace haustra::view {

// A drawn vertex's static attributes: locations 0 (rest position), 1 (rest normal), 3 (slots, uvec2).
struct SkinVertex {
  float rest[3];
  float normal[3];
  std::uint32_t slots[2];
};

// The attributes of the mesh vertices `source` (each drawn vertex is mesh vertex source[i]).
std::vector<SkinVertex> skin_vertices(const GpuSkinBinding& b, std::span<const std::uint32_t> source);

// Whether this context runs the shader: GL 3.3 (texture buffers, integer attributes) and a texture
// buffer large enough for the binding's slots.
bool gpu_skinning_supported(const GpuSkinBinding& b);

// "#version 330 core", the shader's text, then `main_source`.
std::string skin_vertex_shader(const std::string& main_source);

class GpuSkinBuffers {
 public:
  GpuSkinBuffers() = default;
  ~GpuSkinBuffers();
  GpuSkinBuffers(const GpuSkinBuffers&) = delete;
  GpuSkinBuffers& operator=(const GpuSkinBuffers&) = delete;

  // The binding's slots (once per model) and room for its rings.
  void upload_binding(const GpuSkinBinding& b);
  // A frame's ring data: kGpuRingDataFloats × rings floats.
  void upload_rings(std::span<const float> ring_frame);
  // The three buffers on texture units first..first+2, and the program's samplers pointed at them.
  void bind(unsigned program, int first_unit) const;
  // Sets up the bound VAO's attributes 0, 1 and `slot_location` from the bound GL_ARRAY_BUFFER of SkinVertex.
  static void vertex_attributes(unsigned slot_location);
  [[nodiscard]] bool ready() const { return rings_ != 0; }

 private:
  unsigned buffers_[3] = {0, 0, 0};  // rings, coefficients, slot rings
  unsigned textures_[3] = {0, 0, 0};
  unsigned rings_ = 0;  // ring count (0: nothing uploaded)
};

}  // namespace haustra::view
