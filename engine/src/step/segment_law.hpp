#pragma once
// What the rod stages share about one segment: its strain law at a step length, its drag, the
// prefactored mass matrix, and its attachments as loads and as constraint rows.
#include <algorithm>

#include "haustra/kernels/mass_matrix.hpp"
#include "haustra/kernels/strain_update.hpp"
#include "haustra/kernels/tissue_law.hpp"
#include "step/rod_stages.hpp"

namespace haustra::detail {

inline kernels::MassMatrixFactorView factor_of(const WorldModel& model, const SegmentModel& seg) {
  return {std::span<const double>(model.mass_inv_pivot).subspan(seg.node_offset, seg.node_count),
          std::span<const double>(model.mass_lower).subspan(seg.node_offset, seg.node_count)};
}

inline kernels::StrainLawCoefficients law_of(const SegmentModel& seg, double dt) {
  kernels::StrainLawCoefficients law;
  for (std::size_t c = 0; c < 4; ++c) {
    law.stiffness[c] = seg.stiffness[c];
    law.rate[c] = seg.viscosity[c] / dt;
  }
  return law;
}

inline std::array<double, 4> law_total(const SegmentModel& seg, double dt) {
  const kernels::StrainLawCoefficients law = law_of(seg, dt);
  return {law.stiffness[0] + law.rate[0], law.stiffness[1] + law.rate[1], law.stiffness[2] + law.rate[2],
          law.stiffness[3] + law.rate[3]};
}

inline kernels::NodalLaw nodal_law_of(const SegmentModel& seg, double dt) {
  const kernels::StrainLawCoefficients law = law_of(seg, dt);
  return {law.stiffness, law.rate, seg.exp2, seg.tissue, seg.tube};
}

inline std::span<const double> drag_of(const WorldModel& model, const SegmentModel& seg) {
  return std::span<const double>(model.node_drag).subspan(seg.node_offset, seg.node_count);
}

inline std::span<const double> spin_drag_of(const WorldModel& model, const SegmentModel& seg) {
  return std::span<const double>(model.node_spin_drag).subspan(seg.node_offset, seg.node_count);
}

inline void zero(kernels::Vec3View<double> v) {
  std::fill(v.x.begin(), v.x.end(), 0.0);
  std::fill(v.y.begin(), v.y.end(), 0.0);
  std::fill(v.z.begin(), v.z.end(), 0.0);
}

// Adds the attachments' current constraint forces and moments to the node loads.
inline void add_attachment_loads(const SegmentModel& seg, const WorldState& state, const SegmentViews& v) {
  for (std::size_t a = 0; a < seg.attachments.size(); ++a) {
    const AttachmentState& as = state.now.attachment[seg.attachment_offset + a];
    if (!as.active) continue;
    const std::size_t k = as.node;
    v.force.set(k, v.force.get(k) + as.force);
    v.moment.set(k, v.moment.get(k) + as.moment);
  }
}

// Wrench about node 0 of a unit constraint load, and the base twist it causes through the drag.
inline kernels::Vector6d unit_wrench(const ConstraintRow& row, const SegmentViews& v) {
  kernels::Vector6d w;
  if (row.is_moment) {
    w.head<3>() = row.dir;
    w.tail<3>().setZero();
  } else {
    w.head<3>() = (v.poses.node_position.get(row.node) - v.poses.node_position.get(0)).cross(row.dir);
    w.tail<3>() = row.dir;
  }
  return w;
}

// The attachment's remaining error along a row, for its node at `position` with frame `rotation`.
inline double row_error(const ConstraintRow& row, const AttachmentState& as, const Eigen::Vector3d& position,
                        const Eigen::Quaterniond& rotation) {
  const Eigen::Vector3d e = row.is_moment ? kernels::rotation_log(as.target_rotation * rotation.conjugate())
                                          : Eigen::Vector3d(as.target - position);
  return row.dir.dot(e);
}

// ... measured on the current poses.
inline double row_error(const ConstraintRow& row, const AttachmentState& as, const SegmentViews& v) {
  return row_error(row, as, v.poses.node_position.get(row.node), v.poses.node_rotation.get(row.node));
}

}  // namespace haustra::detail
