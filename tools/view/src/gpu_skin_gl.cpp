// Skinning on the GPU in OpenGL 3.3 core: texture buffers for the binding and the frame's rings.
#include "gpu_skin_gl.hpp"

#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>

#include <algorithm>
#include <cstddef>
#include <cstring>

#include "haustra/render/haustra_skin_glsl.hpp"

namespace haustra::view {

std::vector<SkinVertex> skin_vertices(const GpuSkinBinding& b, std::span<const std::uint32_t> source) {
  std::vector<SkinVertex> out(source.size());
  for (std::size_t i = 0; i < source.size(); ++i) {
    const std::size_t v = source[i];
    SkinVertex& s = out[i];
    std::memcpy(s.rest, b.rest_position.data() + 3 * v, sizeof s.rest);
    std::memcpy(s.normal, b.rest_normal.data() + 3 * v, sizeof s.normal);
    std::memcpy(s.slots, b.slot_range.data() + 2 * v, sizeof s.slots);
  }
  return out;
}

bool gpu_skinning_supported(const GpuSkinBinding& b) {
  int major = 0, minor = 0, texels = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &major);
  glGetIntegerv(GL_MINOR_VERSION, &minor);
  glGetIntegerv(GL_MAX_TEXTURE_BUFFER_SIZE, &texels);
  const std::size_t need = std::max(b.slots(), 12 * b.rings);  // the rings' rows and screws, 6 texels each
  return (major > 3 || (major == 3 && minor >= 3)) && std::size_t(texels) >= need;
}

std::string skin_vertex_shader(const std::string& main_source) {
  return std::string("#version 330 core\n") + render::kSkinGlsl + "\n" + main_source;
}

GpuSkinBuffers::~GpuSkinBuffers() {
  if (buffers_[0] == 0) return;
  glDeleteTextures(3, textures_);
  glDeleteBuffers(3, buffers_);
}

void GpuSkinBuffers::upload_binding(const GpuSkinBinding& b) {
  if (buffers_[0] == 0) {
    glGenBuffers(3, buffers_);
    glGenTextures(3, textures_);
  }
  const auto texture = [&](int i, unsigned format, const void* data, std::size_t bytes) {
    glBindBuffer(GL_TEXTURE_BUFFER, buffers_[i]);
    // A texture buffer of no bytes is incomplete; one texel of zeros stands for an empty binding.
    static const float zeros[4] = {0, 0, 0, 0};
    glBufferData(GL_TEXTURE_BUFFER, static_cast<GLsizeiptr>(bytes > 0 ? bytes : sizeof zeros), bytes > 0 ? data : zeros,
                 i == 0 ? GL_STREAM_DRAW : GL_STATIC_DRAW);
    glBindTexture(GL_TEXTURE_BUFFER, textures_[i]);
    glTexBuffer(GL_TEXTURE_BUFFER, format, buffers_[i]);
  };
  texture(0, GL_RGBA32F, nullptr,
          std::max<std::size_t>(b.rings, 1) * kGpuRingDataFloats * sizeof(float));  // each frame's
  texture(1, GL_RGBA32F, b.slot_coefficient.data(), b.slot_coefficient.size() * sizeof(float));
  texture(2, GL_R32UI, b.slot_ring.data(), b.slot_ring.size() * sizeof(std::uint32_t));
  glBindBuffer(GL_TEXTURE_BUFFER, 0);
  glBindTexture(GL_TEXTURE_BUFFER, 0);
  rings_ = static_cast<unsigned>(std::max<std::size_t>(b.rings, 1));
}

void GpuSkinBuffers::upload_rings(std::span<const float> ring_frame) {
  glBindBuffer(GL_TEXTURE_BUFFER, buffers_[0]);
  glBufferSubData(GL_TEXTURE_BUFFER, 0, static_cast<GLsizeiptr>(ring_frame.size_bytes()), ring_frame.data());
  glBindBuffer(GL_TEXTURE_BUFFER, 0);
}

void GpuSkinBuffers::bind(unsigned program, int first_unit) const {
  const char* names[3] = {"haustra_rings", "haustra_coefficients", "haustra_slot_rings"};
  for (int i = 0; i < 3; ++i) {
    glActiveTexture(static_cast<GLenum>(GL_TEXTURE0 + first_unit + i));
    glBindTexture(GL_TEXTURE_BUFFER, textures_[i]);
    glUniform1i(glGetUniformLocation(program, names[i]), first_unit + i);
  }
  glActiveTexture(GL_TEXTURE0);
}

void GpuSkinBuffers::vertex_attributes(unsigned slot_location) {
  glEnableVertexAttribArray(0);
  glEnableVertexAttribArray(1);
  glEnableVertexAttribArray(slot_location);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(SkinVertex),
                        reinterpret_cast<void*>(offsetof(SkinVertex, rest)));
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, sizeof(SkinVertex),
                        reinterpret_cast<void*>(offsetof(SkinVertex, normal)));
  glVertexAttribIPointer(slot_location, 2, GL_UNSIGNED_INT, sizeof(SkinVertex),
                         reinterpret_cast<void*>(offsetof(SkinVertex, slots)));
}

}  // namespace haustra::view
