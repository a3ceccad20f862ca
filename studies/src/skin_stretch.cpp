// The skin's stretch over the rod's own stretch at each vertex's place (decision 0121).
#include "haustra/studies/skin_stretch.hpp"

#include <algorithm>
#include <unordered_set>

namespace haustra::studies {

SkinStretch::SkinStretch(const World& world) {
  const auto x = world.mesh_positions();
  std::unordered_set<std::uint64_t> seen;
  for (const auto& t : world.mesh_triangles())
    for (std::size_t i = 0; i < 3; ++i) {
      const auto [a, b] = std::minmax(t[i], t[(i + 1) % 3]);
      if (!seen.insert((std::uint64_t{a} << 32) | b).second) continue;
      ends_.emplace_back(a, b);
      rest_.push_back((x.get(a) - x.get(b)).cast<double>().norm());
    }
  torn_.assign(ends_.size(), 0);
  node_ = world.mesh_vertex_nodes();
}

void SkinStretch::measure(const World& world, bool resting) {
  const auto x = world.mesh_positions();
  const auto strain = world.strains().data;
  auto stretch = [&](std::uint32_t v) { return 1.0 + std::max(0.0, strain[4 * node_[v] + 3]); };
  for (std::size_t i = 0; i < ends_.size(); ++i) {
    if (rest_[i] <= 0.0) continue;
    const auto [a, b] = ends_[i];
    const double ratio = (x.get(a) - x.get(b)).cast<double>().norm() / rest_[i] / std::max(stretch(a), stretch(b));
    worst = std::max(worst, ratio);
    if (resting) worst_rest = std::max(worst_rest, ratio);
    if (ratio > 2.0 && (torn_[i] & 1) == 0) {
      torn_[i] |= 1;
      ++edges_past;
    }
    if (resting && ratio > 2.0 && (torn_[i] & 2) == 0) {
      torn_[i] |= 2;
      ++rest_edges_past;
    }
  }
}

}  // namespace haustra::studies
