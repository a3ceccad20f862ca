// Connective tissue in the frame: anchors' responses and energy, tearing, cutting.
#include "step/anchors.hpp"

#include <algorithm>
#include <cmath>

namespace haustra::detail {

kernels::AnchorResponse anchor_response(const WorldModel& model, const WorldState& state, std::size_t a, double dt) {
  const AnchorModel& an = model.anchors;
  const std::size_t node = an.node[a];
  return kernels::tissue_anchor(state.now.position.view().get(node), state.position_substep_start.view().get(node),
                                an.target[a], an.stiffness[a], an.slack[a], an.damping[a] / dt);
}

double anchor_energy(const WorldModel& model, const WorldState& state, kernels::Vec3View<const double> position,
                     std::size_t rod) {
  const AnchorModel& an = model.anchors;
  double energy = 0.0;
  for_each_intact_anchor(model, state, rod, [&](std::size_t a, std::size_t node) {
    const double stretch = std::max(0.0, (position.get(node) - an.target[a]).norm() - an.slack[a]);
    energy += 0.5 * an.stiffness[a] * stretch * stretch;
  });
  return energy;
}

void tear_anchors(const WorldModel& model, WorldState& state, std::vector<TornAnchor>& torn) {
  const AnchorModel& an = model.anchors;
  const auto pos = state.now.position.view();
  for (std::size_t a = 0; a < an.size(); ++a) {
    if (state.now.anchor_intact[a] == 0) continue;
    const double tension = kernels::tissue_anchor_tension(pos.get(an.node[a]), an.target[a], an.stiffness[a], an.slack[a]);
    if (tension <= an.strength[a]) continue;
    state.now.anchor_intact[a] = 0;
    torn.push_back({a, tension});
  }
}

namespace {

// The distance from p to the segment [a, b].
double distance_to_segment(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

}  // namespace

void cut_anchors(const WorldModel& model, WorldState& state, const Eigen::Vector3d& centre, double radius,
                 std::vector<TornAnchor>& cut) {
  const AnchorModel& an = model.anchors;
  const auto pos = state.now.position.view();
  for (std::size_t a = 0; a < an.size(); ++a) {
    // The tissue runs from the node to where it is held: cut where the sphere meets it.
    if (state.now.anchor_intact[a] == 0 || distance_to_segment(centre, pos.get(an.node[a]), an.target[a]) > radius)
      continue;
    state.now.anchor_intact[a] = 0;
    cut.push_back({a, 0.0});
  }
}

}  // namespace haustra::detail
