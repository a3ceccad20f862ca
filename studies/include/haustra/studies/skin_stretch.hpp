#pragma once
// The skin's stretch as a user sees it (issue 35; decisions 0112, 0121): each mesh edge's length over
// its rest length, over the rod's stretch at its vertices' places along the rod in the edge's own
// direction. An edge past twice that is the skin tearing, not the tissue stretching.
#include <cstdint>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "haustra/world.hpp"

namespace haustra::studies {

class SkinStretch {
 public:
  // The world's organ meshes as they rest now: build it before the first step.
  explicit SkinStretch(const World& world);
  // The current mesh against the rest (reading it brings the mesh up to the current frame);
  // `resting`: also counted as the organ left alone.
  void measure(const World& world, bool resting);

  [[nodiscard]] bool empty() const { return ends_.empty(); }
  double worst = 0.0;          // the largest ratio over every measure
  double worst_raw = 0.0;      // the largest edge length over rest length, not divided by the rod's
  std::size_t edges_past = 0;  // edges past 2× at some measure
  double worst_rest = 0.0;     // the same over the measures while resting
  std::size_t rest_edges_past = 0;

 private:
  std::vector<std::pair<std::uint32_t, std::uint32_t>> ends_;  // each edge once
  std::vector<double> rest_;                                   // its rest length
  std::vector<double> along_squared_;                          // cos² of its rest angle to the rod
  std::vector<std::uint8_t> torn_;                             // 1: past 2× ever, 2: while resting
  std::vector<std::uint32_t> node_;                            // per vertex, the node at its place
};

}  // namespace haustra::studies
