#pragma once
// A deformed mesh over time as one binary glTF 2.0 file (.glb) that Blender, three.js and assimp
// open: the first frame is the mesh, every recorded frame is a morph target (its displacement
// from the first), and an animation switches the targets on one after the other (step
// interpolation), so playing the file replays the run.
#include <array>
#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

namespace haustra {

class MeshAnimation {
 public:
  explicit MeshAnimation(std::span<const std::array<std::uint32_t, 3>> triangles);
  // x, y, z: one float per vertex, the same count every frame. time in seconds, increasing.
  void add_frame(double time, std::span<const float> x, std::span<const float> y, std::span<const float> z);
  [[nodiscard]] std::size_t frames() const { return times_.size(); }
  // Throws Error{io} naming the file.
  void write_glb(const std::filesystem::path& file) const;

 private:
  std::vector<std::uint32_t> indices_;
  std::vector<float> times_;
  std::vector<std::vector<float>> positions_;  // per frame, xyz interleaved
};

}  // namespace haustra
