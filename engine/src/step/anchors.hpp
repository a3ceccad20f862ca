#pragma once
// Connective tissue in the frame (decision 0095): each intact anchor pulls its node towards where
// the anatomy holds it — a load of the frame's implicit step (stage_loads, the Newton
// linearization, the line search's potential) — and between frames an anchor pulled past its
// strength tears, and a cut takes the anchors within a sphere.
#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "haustra/kernels/tissue_anchor.hpp"
#include "model/world_model.hpp"
#include "state/world_state.hpp"

namespace haustra::detail {

// Calls f(anchor, global node) for each anchor of `rod` that still holds.
template <class F>
void for_each_intact_anchor(const WorldModel& model, const WorldState& state, std::size_t rod, F&& f) {
  const SegmentModel& seg = model.segments[rod];
  for (std::size_t a = seg.anchor_offset; a < seg.anchor_offset + seg.anchor_count; ++a)
    if (state.now.anchor_intact[a] != 0) f(a, static_cast<std::size_t>(model.anchors.node[a]));
}

// Anchor a at the current iterate: spring towards its target and damper on the node's motion over
// the substep (dt: the substep's); and its hold on the node's frame.
kernels::AnchorResponse anchor_response(const WorldModel& model, const WorldState& state, std::size_t a, double dt);
kernels::AnchorTurn anchor_turn(const WorldModel& model, const WorldState& state, std::size_t a, double dt);

// The springs' stored energy of `rod`'s intact anchors at `position` and `rotation` (the guard's
// energy balance).
double anchor_energy(const WorldModel& model, const WorldState& state, kernels::Vec3View<const double> position,
                     kernels::RotationView<const double> rotation, std::size_t rod);

// After an accepted frame: every intact anchor whose tension exceeds its strength tears. Appends
// each torn anchor and its tension to `torn` (capacity: every anchor, so nothing allocates).
struct TornAnchor {
  std::size_t anchor = 0;
  double tension = 0.0;
};
void tear_anchors(const WorldModel& model, WorldState& state, std::vector<TornAnchor>& torn);

// Cuts every intact anchor whose tissue (from the tube's wall round its node to its target)
// passes within `radius` of `centre`, appending each to `cut` (capacity: every anchor).
void cut_anchors(const WorldModel& model, WorldState& state, const Eigen::Vector3d& centre, double radius,
                 std::vector<TornAnchor>& cut);

}  // namespace haustra::detail
