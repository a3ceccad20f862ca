// The per-frame state (mjData) sized once from the model.
#include "state/world_state.hpp"

#include <algorithm>

#include "haustra/kernels/rod_forward_sweep.hpp"

namespace haustra::detail {
namespace {

// Copies in place (no allocation: sizes already match).
template <class T>
void copy_buffer(std::vector<T>& dst, const std::vector<T>& src) {
  std::copy(src.begin(), src.end(), dst.begin());
}
void copy_buffer(Vec3Buffer& dst, const Vec3Buffer& src) {
  std::copy(src.x.begin(), src.x.end(), dst.x.begin());
  std::copy(src.y.begin(), src.y.end(), dst.y.begin());
  std::copy(src.z.begin(), src.z.end(), dst.z.begin());
}
void copy_buffer(RotationBuffer& dst, const RotationBuffer& src) {
  std::copy(src.w.begin(), src.w.end(), dst.w.begin());
  std::copy(src.x.begin(), src.x.end(), dst.x.begin());
  std::copy(src.y.begin(), src.y.end(), dst.y.begin());
  std::copy(src.z.begin(), src.z.end(), dst.z.begin());
}

void size_persistent(const WorldModel& model, PersistentState& p) {
#define HAUSTRA_SIZE_BUFFER(type, name, per, width, initial, role, meaning) \
  size_buffer(p.name, count_of(model, Per::per) * (width), initial);
  HAUSTRA_PERSISTENT_STATE(HAUSTRA_SIZE_BUFFER)
#undef HAUSTRA_SIZE_BUFFER
}

}  // namespace

std::size_t count_of(const WorldModel& model, Per per) {
  switch (per) {
    case Per::node: return model.node_total;
    case Per::segment: return model.segments.size();
    case Per::attachment: return model.attachment_total;
    case Per::anchor: return model.anchors.size();
    case Per::constraint_double: return model.constraint_scratch_total;
  }
  return 0;
}

void NewtonSplit::allocate(std::size_t nodes, std::size_t m, int columns) {
  joint = m;
  const int base_max = columns + kernels::kJointColumns;
  const auto c = static_cast<std::size_t>(columns), b = static_cast<std::size_t>(base_max);
  tip_gain.assign(kernels::condensed_gain_size(nodes - 1 - m, columns), 0.0);
  tip_scratch.assign(kernels::condensed_scratch_size(columns), 0.0);
  tip_solution.assign(10 * c, 0.0);
  interface.assign(10 * static_cast<std::size_t>(kernels::condensed_width(columns)), 0.0);
  base_gain.assign(kernels::condensed_gain_size(m, base_max), 0.0);
  base_scratch.assign(kernels::condensed_scratch_size(base_max), 0.0);
  base_solution.assign(10 * b, 0.0);
  base_loads.assign(2 * c, kernels::UnitLoad{});
  tip_column.assign(c, 0);
  base_column.assign(c, 0);
  raw.assign(2 * c * 6 * b, 0.0);
  tip_particular.assign(2 * c * 6 * c, 0.0);
  tip_unit.assign(2 * c * 60, 0.0);
  at_joint.assign(10 * b, 0.0);
  lambda.assign(10 * c, 0.0);
  y_joint.assign(10 * c, 0.0);
  base_weights.assign(b, 0.0);
  const std::size_t tip_nodes = nodes - m;
  rel_position.resize(tip_nodes);
  rel_rotation.resize(tip_nodes);
  rel_mid_position.resize(tip_nodes - 1);
  rel_mid_rotation.resize(tip_nodes - 1);
}

void NewtonWorkspace::allocate(std::size_t nodes, int columns, bool with_band, std::size_t split_at) {
  max_columns = columns;
  gain.assign(kernels::condensed_gain_size(split_at > 0 ? 0 : nodes, columns), 0.0);
  scratch.assign(kernels::condensed_scratch_size(columns), 0.0);
  scratch_second.assign(kernels::condensed_scratch_size(columns), 0.0);
  base_solution.assign(10 * static_cast<std::size_t>(columns), 0.0);
  loads.reserve(2 * static_cast<std::size_t>(columns));
  response_nodes.reserve(2 * static_cast<std::size_t>(columns));
  responses.assign(2 * static_cast<std::size_t>(columns) * 6 * static_cast<std::size_t>(columns), 0.0);
  weights.assign(static_cast<std::size_t>(columns), 0.0);
  column_of.assign(static_cast<std::size_t>(columns), 0);
  band_available = with_band;
#define HAUSTRA_SIZE_BUFFER(type, name, width, initial, allocated, meaning) \
  if (Allocated::allocated == Allocated::always || with_band) size_buffer(name, nodes*(width), initial);
  HAUSTRA_NEWTON_NODE_BUFFERS(HAUSTRA_SIZE_BUFFER)
#undef HAUSTRA_SIZE_BUFFER
  if (with_band) rhs.assign(nodes * kernels::kNewtonBlock * static_cast<std::size_t>(columns), 0.0);
}

void PersistentState::copy_from(const PersistentState& o) {
#define HAUSTRA_COPY_BUFFER(type, name, per, width, initial, role, meaning) copy_buffer(name, o.name);
  HAUSTRA_PERSISTENT_STATE(HAUSTRA_COPY_BUFFER)
#undef HAUSTRA_COPY_BUFFER
}

void init_world_state(const WorldModel& model, WorldState& state) {
  const std::size_t n = model.node_total;
  const std::size_t segs = model.segments.size();
  size_persistent(model, state.now);
  size_persistent(model, state.frame_start);
#define HAUSTRA_SIZE_BUFFER(type, name, per, width, initial, role, meaning) \
  size_buffer(state.name, count_of(model, Per::per) * (width), initial);
  HAUSTRA_FRAME_STATE(HAUSTRA_SIZE_BUFFER)
#undef HAUSTRA_SIZE_BUFFER
  const bool newton_possible =
      model.solver.mode == SolverMode::newton || model.solver.on_instability == InstabilityPolicy::recover;
  state.newton.resize(newton_possible ? segs : 0);
  state.condense_tasks.reserve(model.solve_parts.size());
  for (std::size_t s = 0; s < state.newton.size(); ++s) {
    const SegmentModel& seg = model.segments[s];
    const std::size_t rows = seg.constraint_rows;
    // The residual, one column per constraint row, one per contact Newton couples exactly.
    const int cols = 1 + static_cast<int>(rows) + (seg.bead_count > 0 ? static_cast<int>(kMaxCoupledContacts) : 0);
    state.newton[s].allocate(seg.node_count, cols, seg.node_count <= kBandFallbackNodes, seg.split_node);
    if (seg.split_node > 0) state.newton[s].split.allocate(seg.node_count, seg.split_node, cols);
    if (model.solver.mode == SolverMode::fast && seg.split_node == 0) {
      NewtonWorkspace& ws = state.newton[s];
      ws.record.assign(kernels::condensed_record_size(seg.node_count), 0.0);
      const std::size_t pattern = seg.attachments.size() + seg.bead_count;
      ws.chord_pattern.reserve(pattern);
      ws.pattern_now.reserve(pattern);
    }
    state.newton[s].bead_start.assign(seg.bead_count, Eigen::Vector3d::Zero());
    if (model.sleep.ranges && seg.split_node == 0 && seg.node_count > kMinSleepingRange) {
      // Decision 0127 (split rods keep their ranges awake): the tip side's interface and zero start;
      // the base side's part, as a split rod's base part that may end at any node.
      NewtonWorkspace& ws = state.newton[s];
      ws.held_interface.assign(10 * static_cast<std::size_t>(kernels::condensed_width(cols)), 0.0);
      ws.held_start.assign(10 * static_cast<std::size_t>(cols), 0.0);
      ws.split.allocate(seg.node_count, seg.node_count - 1, cols);
      ws.split.joint = 0;  // not a split rod: its base part ends where a range begins
    }
  }

  std::copy(model.rest_strain.begin(), model.rest_strain.end(), state.now.strain.begin());
  for (std::size_t k = 0; k < n; ++k) {
    state.external_force.x[k] = model.initial_load[6 * k];
    state.external_force.y[k] = model.initial_load[6 * k + 1];
    state.external_force.z[k] = model.initial_load[6 * k + 2];
    state.external_moment.x[k] = model.initial_load[6 * k + 3];
    state.external_moment.y[k] = model.initial_load[6 * k + 4];
    state.external_moment.z[k] = model.initial_load[6 * k + 5];
  }
  for (const SegmentModel& seg : model.segments)
    for (std::size_t a = 0; a < seg.attachments.size(); ++a) {
      state.now.attachment[seg.attachment_offset + a].node = seg.attachments[a].initial_node;
      state.now.attachment[seg.attachment_offset + a].hold_frame = seg.attachments[a].hold_frame;
    }
  for (std::size_t a = 0; a < model.attachment_total; ++a) {
    state.now.attachment[a].active = model.initial_attachment_active[a] != 0;
    state.now.attachment[a].target = model.initial_attachment_target[a];
    state.now.attachment[a].target_rotation = model.initial_attachment_rotation[a];
  }
  for (std::size_t s = 0; s < segs; ++s) {
    state.now.base[s] = model.segments[s].initial_base;
    const SegmentViews v = segment_views(model, state, s);
    kernels::rod_forward_sweep(state.now.base[s], v.section_length, v.strain, v.poses);
  }
  state.frame_start.copy_from(state.now);
  state.mesh.ring_pose.assign(model.ring_total, kernels::RingPose{});
  state.mesh.ring_delta.assign(kernels::kRingScratchFloats * model.ring_total, 0.0f);
  state.mesh.position.resize(model.mesh_vertex_total);
  state.mesh.normal.resize(model.mesh_vertex_total);
}

SegmentViews segment_views(const WorldModel& model, WorldState& state, std::size_t segment) {
  const SegmentModel& seg = model.segments[segment];
  const std::size_t off = seg.node_offset;
  const std::size_t n = seg.node_count;
  SegmentViews v{
      .poses = {state.now.position.view().subview(off, n), state.now.rotation.view().subview(off, n),
                state.now.mid_position.view().subview(off, n - 1), state.now.mid_rotation.view().subview(off, n - 1)},
      .strain = kernels::StrainView<double>{state.now.strain}.subview(off, n),
      .strain_start = kernels::StrainView<double>{state.strain_substep_start}.subview(off, n),
      .generalized_force = kernels::StrainView<double>{state.generalized_force}.subview(off, n),
      .rest = kernels::StrainView<const double>{model.rest_strain}.subview(off, n),
      .section_length = std::span<const double>(model.section_length).subspan(off, n - 1),
      .node_mass = std::span<const double>(model.node_mass).subspan(off, n),
      .force = state.force.view().subview(off, n),
      .moment = state.moment.view().subview(off, n),
  };
  return v;
}

}  // namespace haustra::detail
