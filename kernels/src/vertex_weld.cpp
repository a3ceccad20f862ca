// Vertices of several meshes that are one point, set to their mean.
#include "haustra/kernels/vertex_weld.hpp"

namespace haustra::kernels {

void weld_vertex_groups(std::span<const std::uint32_t> start, std::span<const std::uint32_t> members,
                        std::span<float> x, std::span<float> y, std::span<float> z) {
  for (std::size_t g = 0; g + 1 < start.size(); ++g) {
    double sx = 0.0, sy = 0.0, sz = 0.0;  // in double: the mean of equal floats is that float
    for (std::uint32_t k = start[g]; k < start[g + 1]; ++k) {
      sx += x[members[k]];
      sy += y[members[k]];
      sz += z[members[k]];
    }
    const double n = static_cast<double>(start[g + 1] - start[g]);
    const auto mx = static_cast<float>(sx / n), my = static_cast<float>(sy / n), mz = static_cast<float>(sz / n);
    for (std::uint32_t k = start[g]; k < start[g + 1]; ++k) {
      x[members[k]] = mx;
      y[members[k]] = my;
      z[members[k]] = mz;
    }
  }
}

}  // namespace haustra::kernels
