// The skin's stretch over the rod's own stretch at each vertex's place (decision 0121).
#include "haustra/studies/skin_stretch.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_set>

namespace haustra::studies {
namespace {

// Each node's rest tangent, from its neighbours within its own piece (another organ's nodes may
// follow it in the world's arrays).
std::vector<Eigen::Vector3d> rest_tangents(const World& world) {
  const auto x = world.node_positions();
  std::vector<Eigen::Vector3d> t(x.size(), Eigen::Vector3d::UnitZ());
  for (std::size_t p = 0; p < world.segment_count(); ++p) {
    const Range nodes = world.segment(p).nodes;
    for (std::size_t k = nodes.offset; k < nodes.offset + nodes.count; ++k) {
      const std::size_t before = k > nodes.offset ? k - 1 : k;
      const std::size_t after = k + 1 < nodes.offset + nodes.count ? k + 1 : k;
      const Eigen::Vector3d d = x.get(after) - x.get(before);
      if (d.norm() > 0.0) t[k] = d.normalized();
    }
  }
  return t;
}

}  // namespace

SkinStretch::SkinStretch(const World& world) {
  const auto x = world.mesh_positions();
  node_ = world.mesh_vertex_nodes();
  const std::vector<Eigen::Vector3d> tangent = rest_tangents(world);
  std::unordered_set<std::uint64_t> seen;
  for (const auto& t : world.mesh_triangles())
    for (std::size_t i = 0; i < 3; ++i) {
      const auto [a, b] = std::minmax(t[i], t[(i + 1) % 3]);
      if (!seen.insert((std::uint64_t{a} << 32) | b).second) continue;
      const Eigen::Vector3d e = x.get(a) - x.get(b);
      const Eigen::Vector3d along = tangent[node_[a]] + tangent[node_[b]];
      const double c = e.norm() > 0.0 && along.norm() > 0.0 ? e.dot(along) / (e.norm() * along.norm()) : 0.0;
      ends_.emplace_back(a, b);
      rest_.push_back(e.norm());
      along_squared_.push_back(c * c);
    }
  torn_.assign(ends_.size(), 0);
}

void SkinStretch::measure(const World& world, bool resting) {
  const auto x = world.mesh_positions();
  const auto strain = world.strains().data;
  for (std::size_t i = 0; i < ends_.size(); ++i) {
    if (rest_[i] <= 0.0) continue;
    const auto [a, b] = ends_[i];
    const double own = (x.get(a) - x.get(b)).norm() / rest_[i];
    // The rod's stretch along the edge's rest direction: a segment at angle θ to a rod stretched by
    // λ (and not across it) grows by √(1 + (λ² − 1) cos²θ); compression is not counted in its favour.
    const double lambda = 1.0 + std::max({0.0, strain[4 * node_[a] + 3], strain[4 * node_[b] + 3]});
    const double ratio = own / std::sqrt(1.0 + (lambda * lambda - 1.0) * along_squared_[i]);
    worst_raw = std::max(worst_raw, own);
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
