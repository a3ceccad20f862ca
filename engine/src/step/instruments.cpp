// Instruments: scripted and host poses, grasps and releases, the force on the grasper.
#include "step/instruments.hpp"

#include <cmath>

#include "haustra/kernels/pose.hpp"
#include "step/instrument_proxy.hpp"

namespace haustra::detail {
namespace {

Eigen::Vector3d node_position(const WorldState& state, std::size_t node) {
  return {state.now.position.x[node], state.now.position.y[node], state.now.position.z[node]};
}

// The grasp slot of `instrument` on `segment`, as a global attachment index.
std::size_t grasp_slot(const SegmentModel& seg, std::size_t instrument) {
  for (std::size_t a = 0; a < seg.attachments.size(); ++a)
    if (seg.attachments[a].grasp_slot && seg.attachments[a].instrument == instrument) return seg.attachment_offset + a;
  return static_cast<std::size_t>(-1);
}

bool node_attached(const WorldModel& model, const WorldState& state, std::size_t segment, std::size_t node) {
  const SegmentModel& seg = model.segments[segment];
  if (node == 0 && seg.base_mode == BaseMode::clamped) return true;
  for (std::size_t a = 0; a < seg.attachments.size(); ++a) {
    const AttachmentState& as = state.now.attachment[seg.attachment_offset + a];
    if (as.active && as.node == node) return true;
  }
  return false;
}

void grasp(const WorldModel& model, WorldState& state, std::size_t i) {
  InstrumentState& s = state.instruments[i];
  const InstrumentModel& d = model.instruments[i];
  // The nearest bead surface within reach of the commanded tip (a proxy's lags it by a frame, or
  // rests on the tissue it was pushed into); ties go to the lower bead index.
  double best = d.grasp_reach;
  std::size_t chosen = model.beads.size();
  for (std::size_t b = 0; b < model.beads.size(); ++b) {
    const std::uint32_t node = model.beads.node[b];
    const std::size_t segment = model.beads.segment[b];
    const std::size_t local = node - model.segments[segment].node_offset;
    if (node_attached(model, state, segment, local)) continue;
    const double gap = (node_position(state, node) - s.command_tip).norm() - model.beads.radius[b];
    if (gap <= best && (chosen == model.beads.size() || gap < best)) {
      best = gap;
      chosen = b;
    }
  }
  if (chosen == model.beads.size()) return;  // nothing in reach: the jaws close on air
  const std::size_t segment = model.beads.segment[chosen];
  const SegmentModel& seg = model.segments[segment];
  const std::size_t slot = grasp_slot(seg, i);
  const std::size_t node = model.beads.node[chosen];
  AttachmentState& as = state.now.attachment[slot];
  // A coupled grasp is a load, not a constraint: the slot stays inactive.
  s.coupled = d.coupling_stiffness > 0.0;
  s.grasp_node = static_cast<std::uint32_t>(node);
  as.active = !s.coupled;
  as.node = node - seg.node_offset;
  as.hold_frame = d.hold_frame;
  as.force.setZero();
  as.moment.setZero();
  const Eigen::Quaterniond node_rot(state.now.rotation.w[node], state.now.rotation.x[node], state.now.rotation.y[node],
                                    state.now.rotation.z[node]);
  // Held where it is, relative to the commanded pose: the grasp keeps that offset as it moves.
  s.grasp_offset = s.frame.conjugate() * (node_position(state, node) - s.command_tip);
  s.grasp_rotation = s.frame.conjugate() * node_rot;
  as.target = node_position(state, node);
  as.target_rotation = node_rot;
  s.grasping = true;
  s.grasp_target = s.target_start = node_position(state, node);
  s.coupling_force.setZero();
  s.grasp_segment = segment;
  s.grasp_attachment = slot;
  s.grasp_bead = static_cast<std::uint32_t>(chosen);
}

// The largest axial strain of a rod's nodes.
double largest_axial_strain(const WorldModel& model, const WorldState& state, std::size_t rod) {
  const SegmentModel& seg = model.segments[rod];
  double largest = 0.0;
  for (std::size_t k = seg.node_offset; k < seg.node_offset + seg.node_count; ++k)
    largest = std::max(largest, state.now.strain[4 * k + 3]);
  return largest;
}

void release(WorldState& state, std::size_t i) {
  InstrumentState& s = state.instruments[i];
  AttachmentState& as = state.now.attachment[s.grasp_attachment];
  as.active = false;
  as.force.setZero();
  as.moment.setZero();
  s.grasping = false;
  s.coupled = false;
  s.coupling_force.setZero();
}

}  // namespace

void set_instrument_pose(InstrumentState& s, const Eigen::Vector3d& tip, const Eigen::Vector3d& axis) {
  s.command_tip = tip;
  s.axis = axis.normalized();
  s.frame = kernels::frame_from_tangent(s.axis, Eigen::Vector3d::UnitX());
}

void init_instruments(const WorldModel& model, WorldState& state) {
  state.instruments.assign(model.instruments.size(), InstrumentState{});
  for (std::size_t i = 0; i < model.instruments.size(); ++i) {
    const InstrumentModel& d = model.instruments[i];
    InstrumentState& s = state.instruments[i];
    s.scripted = !d.keyframes.empty();
    if (s.scripted)
      set_instrument_pose(s, d.keyframes.front().tip, d.keyframes.front().axis);
    else
      set_instrument_pose(s, d.tip, d.axis);
    s.tip = s.command_start = s.proxy_start = s.command_tip;
    s.grasp_limit = d.force_limit;
  }
}

void stage_instruments(const WorldModel& model, WorldState& state, double time) {
  for (std::size_t i = 0; i < model.instruments.size(); ++i) {
    const InstrumentModel& d = model.instruments[i];
    InstrumentState& s = state.instruments[i];
    s.command_start = s.command_tip;
    if (s.scripted) {
      const auto& kf = d.keyframes;
      std::size_t k = 0;
      while (k + 1 < kf.size() && kf[k + 1].time <= time) ++k;
      if (time <= kf.front().time || k + 1 == kf.size()) {
        set_instrument_pose(s, kf[k].tip, kf[k].axis);
      } else {
        const double t = (time - kf[k].time) / (kf[k + 1].time - kf[k].time);
        const Eigen::Vector3d axis = (1.0 - t) * kf[k].axis + t * kf[k + 1].axis;
        set_instrument_pose(s, (1.0 - t) * kf[k].tip + t * kf[k + 1].tip,
                            axis.norm() > 1e-9 ? axis : kf[k + 1].axis);  // opposite axes: take the next one
      }
      s.closed = time >= kf.front().time ? kf[k].grasp : kf.front().grasp;
      s.cutting = time >= kf.front().time ? kf[k].cut : kf.front().cut;
    }
    // A kinematic instrument is where it is commanded; a proxy gets there as far as its coupling
    // and what it meets let it (stage_instrument_proxies), its capsule swept that far for contacts.
    if (!is_proxy(d)) s.tip = s.command_tip;
    s.reach = (s.command_tip - s.tip).norm();
    s.grasp_limit = grasp_limit(d, s);  // until its proxy is solved again this frame
    if (!s.closed) s.slipped = false;   // opened: the next close grasps anew
    if (s.closed && !s.grasping && !s.slipped) grasp(model, state, i);
    if (!s.closed && s.grasping) release(state, i);
    if (s.grasping) {
      AttachmentState& as = state.now.attachment[s.grasp_attachment];
      s.target_start = s.grasp_target;
      s.grasp_target = s.command_tip + s.frame * s.grasp_offset;
      as.target = s.grasp_target;
      as.target_rotation = s.frame * s.grasp_rotation;
    }
  }
}

kernels::CouplingResponse grasp_coupling(const InstrumentModel& d, const InstrumentState& s, const Eigen::Vector3d& x,
                                         const Eigen::Vector3d& x_start, double dt, double frame_dt) {
  const double spring = d.coupling_stiffness, damper = d.coupling_damping / dt;
  // The damper pulls the node's displacement over the substep towards the grasp point's.
  const Eigen::Vector3d moved_with_grasp = x_start + (s.grasp_target - s.target_start) * (dt / frame_dt);
  const Eigen::Vector3d target = (spring * s.grasp_target + damper * moved_with_grasp) / (spring + damper);
  return kernels::virtual_coupling(x, target, spring + damper, s.grasp_limit);
}

void instrument_forces(const WorldModel& model, WorldState& state, double dt, std::vector<std::size_t>& slipped) {
  for (std::size_t i = 0; i < model.instruments.size(); ++i) {
    InstrumentState& s = state.instruments[i];
    Eigen::Vector3d force = Eigen::Vector3d::Zero();
    Eigen::Vector3d torque = Eigen::Vector3d::Zero();
    for (const ContactCandidate& k : state.collision.candidates) {
      if (k.kind != ContactKind::instrument || k.other != i) continue;
      const Eigen::Vector3d on_instrument = -k.force;
      force += on_instrument;
      torque += (node_position(state, model.beads.node[k.bead]) - s.tip).cross(on_instrument);
    }
    // A proxy's capsule: what it meets is what holds it off its command — its coupling's pull,
    // bounded by construction (the contacts' sum equals it once the proxy has settled).
    if (is_proxy(model.instruments[i])) force = -s.proxy_force;
    if (s.grasping && s.coupled) {
      // Over the whole frame: the node's motion since the frame's start against the grasp point's.
      const InstrumentModel& d = model.instruments[i];
      const Eigen::Vector3d x = node_position(state, s.grasp_node);
      const kernels::CouplingResponse c =
          grasp_coupling(d, s, x, state.frame_start.position.view().get(s.grasp_node), dt, dt);
      s.coupling_force = -c.force;
      force += s.coupling_force;
      torque += (x - s.tip).cross(s.coupling_force);
      // Pulled harder than the jaws hold: the tissue slips out (the spring's own force, before the
      // limit caps it, so that a limit above the holding force still lets go). Or pulled past
      // what the wall takes: it tears out of the jaws.
      const double stretched = largest_axial_strain(model, state, s.grasp_segment);
      const bool slips = d.holding_force > 0.0 && c.unsaturated > d.holding_force;
      if (slips || stretched > model.segments[s.grasp_segment].failure_strain) {
        release(state, i);
        s.slipped = true;
        s.slip_pull = c.unsaturated;
        s.slip_strain = slips ? 0.0 : stretched;
        slipped.push_back(i);
      }
    } else if (s.grasping) {
      const AttachmentState& as = state.now.attachment[s.grasp_attachment];
      const std::size_t node = model.segments[s.grasp_segment].node_offset + as.node;
      force -= as.force;
      torque += (node_position(state, node) - s.tip).cross(Eigen::Vector3d(-as.force)) - as.moment;
    }
    s.force = force;
    s.torque = torque;
    const double tau = model.instruments[i].force_filter;
    const double alpha = tau > 0.0 ? dt / (tau + dt) : 1.0;
    s.filtered_force += alpha * (force - s.filtered_force);
    s.filtered_torque += alpha * (torque - s.filtered_torque);
  }
}

}  // namespace haustra::detail
