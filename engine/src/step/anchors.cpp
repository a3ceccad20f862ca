// Connective tissue in the frame: anchors' responses and energy, tearing, cutting.
#include "step/anchors.hpp"

#include "haustra/kernels/contact_geometry.hpp"

namespace haustra::detail {
namespace {

// Gravity's direction (what the support carries against), or none in a world without it.
Eigen::Vector3d down(const WorldModel& model) {
  const double g = model.gravity.norm();
  return g > 0.0 ? Eigen::Vector3d(model.gravity / g) : Eigen::Vector3d::Zero();
}

}  // namespace

kernels::AnchorResponse anchor_response(const WorldModel& model, const WorldState& state, std::size_t a, double dt) {
  const AnchorModel& an = model.anchors;
  const std::size_t node = an.node[a];
  return kernels::tissue_anchor(state.now.position.view().get(node), state.position_substep_start.view().get(node),
                                an.target[a], an.stiffness[a], an.slack[a], an.damping[a] / dt, an.support[a],
                                down(model));
}

kernels::AnchorTurn anchor_turn(const WorldModel& model, const WorldState& state, std::size_t a, double dt) {
  const AnchorModel& an = model.anchors;
  const std::size_t node = an.node[a];
  return kernels::tissue_anchor_turn(state.now.rotation.view().get(node), state.rotation_substep_start.view().get(node),
                                     an.rest_rotation[a], an.turn_stiffness[a], an.turn_damping[a] / dt);
}

double anchor_energy(const WorldModel& model, const WorldState& state, kernels::Vec3View<const double> position,
                     kernels::RotationView<const double> rotation, std::size_t rod) {
  const AnchorModel& an = model.anchors;
  const Eigen::Vector3d g = down(model);
  double energy = 0.0;
  for_each_intact_anchor(model, state, rod, [&](std::size_t a, std::size_t node) {
    // The springs alone: no damper (a motion of zero length).
    const Eigen::Vector3d x = position.get(node);
    energy += kernels::tissue_anchor(x, x, an.target[a], an.stiffness[a], an.slack[a], 0.0, an.support[a], g).energy;
    if (an.turn_stiffness[a] > 0.0) {
      const Eigen::Quaterniond r = rotation.get(node);
      energy += kernels::tissue_anchor_turn(r, r, an.rest_rotation[a], an.turn_stiffness[a], 0.0).energy;
    }
  });
  return energy;
}

void tear_anchors(const WorldModel& model, WorldState& state, std::vector<TornAnchor>& torn) {
  const AnchorModel& an = model.anchors;
  const auto pos = state.now.position.view();
  for (std::size_t a = 0; a < an.size(); ++a) {
    if (state.now.anchor_intact[a] == 0) continue;
    const double tension =
        kernels::tissue_anchor_tension(pos.get(an.node[a]), an.target[a], an.stiffness[a], an.slack[a]);
    if (tension <= an.strength[a]) continue;
    state.now.anchor_intact[a] = 0;
    torn.push_back({a, tension});
  }
}

void cut_anchors(const WorldModel& model, WorldState& state, const Eigen::Vector3d& centre, double radius,
                 std::vector<TornAnchor>& cut) {
  const AnchorModel& an = model.anchors;
  const auto pos = state.now.position.view();
  for (std::size_t a = 0; a < an.size(); ++a) {
    // The tissue runs from the tube's wall to where it is held: cut where the sphere meets it.
    if (state.now.anchor_intact[a] == 0 ||
        (kernels::closest_point_on_segment(centre, pos.get(an.node[a]), an.target[a]) - centre).norm() >
            radius + an.wall[a])
      continue;
    state.now.anchor_intact[a] = 0;
    cut.push_back({a, 0.0});
  }
}

}  // namespace haustra::detail
