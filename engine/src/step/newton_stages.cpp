// The Newton stages of a frame, one segment at a time: linearize and condense (the jacobian
// stage), then solve and step (the solve stage) and the line search on the frame's incremental
// potential (the line_search stage). Named steps, in the order a Newton iteration takes them.
#include <algorithm>
#include <cmath>

#include "haustra/kernels/block_tridiagonal.hpp"
#include "haustra/kernels/rod_backward_sweep.hpp"
#include "haustra/kernels/rod_condensed.hpp"
#include "haustra/kernels/rod_forward_sweep.hpp"
#include "haustra/kernels/rod_newton.hpp"
#include "sched/scheduler.hpp"
#include "step/anchors.hpp"
#include "step/collision.hpp"
#include "step/instruments.hpp"
#include "step/newton_internal.hpp"
#include "step/newton_stages.hpp"
#include "step/rod_stages.hpp"
#include "step/segment_law.hpp"
#include "step/sleep.hpp"

namespace haustra::detail {
namespace newton {

// Newton steps are scaled down to stay within these per iteration (a trust region): beyond them
// the linearization says little about the rod.
constexpr double kMaxNewtonAngle = 0.5;  // rad of bend or twist per section
constexpr double kMaxNewtonStretch = 0.25;

Coupled coupled_unknowns(const WorldModel& model, const WorldState& state, std::size_t segment) {
  const SegmentModel& seg = model.segments[segment];
  Coupled c;
  c.m = seg.constraint_rows > 0 ? active_constraint_rows(seg, state, c.rows) : 0;
  if (const HeldRange held = state.held_range(segment); held.any()) {
    // A sleeping range's attachments hold nodes that do not move (decision 0127): no rows of theirs.
    std::size_t kept = 0;
    for (std::size_t j = 0; j < c.m; ++j)
      if (c.rows[j].node < held.first || c.rows[j].node > held.last) c.rows[kept++] = c.rows[j];
    c.m = kept;
  }
  const CollisionState& cs = state.collision;
  const std::size_t p0 = cs.coupled_start.empty() ? 0 : cs.coupled_start[segment];
  c.pc = cs.coupled_start.empty() ? 0 : cs.coupled_start[segment + 1] - p0;
  for (std::size_t i = 0; i < c.pc; ++i) {
    const Contact& k = cs.candidates[cs.coupled[p0 + i]];
    c.pairs[i] = {model.beads.node[k.bead] - seg.node_offset, model.beads.node[k.other] - seg.node_offset, k.direction,
                  std::max(k.stiffness, 1e-300)};
  }
  return c;
}

namespace {

kernels::RodLinearization linearization_of(const SegmentModel& seg, const SegmentViews& v, NewtonWorkspace& ws,
                                           const SubstepParameters& p, bool has_stiffness) {
  kernels::RodLinearization lin;
  lin.poses = v.poses;
  lin.section_length = v.section_length;
  lin.node_force = v.force;
  lin.node_moment = v.moment;
  lin.law_total = law_total(seg, p.dt);
  if (seg.exp2) lin.nodal = {kernels::StrainView<const double>{ws.law_tangent}, ws.bend_coupling};
  if (has_stiffness) lin.stiffness = {ws.force_stiffness, ws.drag_moment_rate};
  lin.free_base = seg.base_mode == BaseMode::free;
  return lin;
}

// Step 1: the loads' stiffness (drag on every node, contact penalties at beads), the law's
// tangent and the residual ρ = R − A (q − q*) (a nonlinear law: ρ = R − M s(q)).
void linearize(const WorldModel& model, WorldState& state, std::size_t segment, const SubstepParameters& p) {
  const SegmentModel& seg = model.segments[segment];
  const SegmentViews v = segment_views(model, state, segment);
  NewtonWorkspace& ws = state.newton[segment];
  const std::size_t n = seg.node_count;
  const bool has_stiffness = seg.has_load_stiffness;
  if (has_stiffness) {
    const std::span<const double> c = drag_of(model, seg);
    const std::span<const double> sd = spin_drag_of(model, seg);
    for (std::size_t k = 0; k < n; ++k) {
      ws.force_stiffness[k] = (c[k] / p.dt) * Eigen::Matrix3d::Identity();
      ws.drag_moment_rate[k] = sd[k] / p.dt;
    }
    for (std::size_t b = seg.bead_offset; b < seg.bead_offset + seg.bead_count; ++b)
      ws.force_stiffness[model.beads.node[b] - seg.node_offset] += state.collision.bead_stiffness[b];
    const auto pos = state.now.position.view();
    const auto start = state.position_substep_start.view();
    for_each_coupled_grasp(state, segment, [&](std::size_t i, std::size_t node) {
      ws.force_stiffness[node - seg.node_offset] +=
          grasp_coupling(model.instruments[i], state.instruments[i], pos.get(node), start.get(node), p.dt, model.dt)
              .stiffness;
    });
    const HeldRange held = state.held_range(segment);  // a sleeping range's tissue enters no solve (0127)
    for_each_intact_anchor(model, state, segment, [&](std::size_t a, std::size_t node) {
      if (held.any() && node - seg.node_offset >= held.first && node - seg.node_offset <= held.last) return;
      ws.force_stiffness[node - seg.node_offset] += anchor_response(model, state, a, p.dt).stiffness;
      ws.drag_moment_rate[node - seg.node_offset] += anchor_turn(model, state, a, p.dt).stiffness;
    });
  }
  // q* = (k q̂ + (η/Δt) q_start) / a: the linear law's centre (and the line search's).
  const kernels::StrainLawCoefficients law = law_of(seg, p.dt);
  const std::array<double, 4> a = law_total(seg, p.dt);
  const kernels::StrainView<double> target{ws.target};
  for (std::size_t k = 0; k < n; ++k)
    for (std::size_t c = 0; c < 4; ++c)
      target.at(k, c) = (law.stiffness[c] * v.rest.at(k, c) + law.rate[c] * v.strain_start.at(k, c)) / a[c];
  if (seg.exp2) {
    kernels::nodal_law_evaluate(v.strain, v.rest, v.strain_start, nodal_law_of(seg, p.dt),
                                kernels::StrainView<double>{ws.law_stress}, kernels::StrainView<double>{ws.law_tangent},
                                ws.bend_coupling);
    kernels::rod_stress_residual(v.generalized_force, kernels::StrainView<const double>{ws.law_stress},
                                 v.section_length, kernels::StrainView<double>{ws.residual});
  } else {
    kernels::rod_strain_residual(v.generalized_force, v.strain, target, v.section_length, a,
                                 kernels::StrainView<double>{ws.residual});
  }
}

// Step 2: the unit loads of the coupled unknowns — one column per constraint row, one per
// coupled pair (+n at one bead's node, −n at the other's) — by node, distal first.
void unit_loads(const Coupled& c, NewtonWorkspace& ws) {
  ws.loads.clear();
  for (std::size_t j = 0; j < c.m; ++j)
    ws.loads.push_back({static_cast<std::uint32_t>(c.rows[j].node), static_cast<std::uint32_t>(1 + j),
                        c.rows[j].is_moment, c.rows[j].dir});
  for (std::size_t i = 0; i < c.pc; ++i) {
    const auto col = static_cast<std::uint32_t>(1 + c.m + i);
    ws.loads.push_back({static_cast<std::uint32_t>(c.pairs[i].a), col, false, c.pairs[i].n});
    ws.loads.push_back({static_cast<std::uint32_t>(c.pairs[i].b), col, false, -c.pairs[i].n});
  }
  // (std::sort: stable_sort may allocate, and the order is total.)
  std::sort(ws.loads.begin(), ws.loads.end(), [](const kernels::UnitLoad& x, const kernels::UnitLoad& y) {
    return x.node != y.node ? x.node > y.node : x.column < y.column;
  });
  // Columns numbered in the order the sweep meets them (the live ones are then a prefix):
  // column_of maps an unknown's column (1 + its index) to the kernel's.
  std::fill(ws.column_of.begin(), ws.column_of.end(), 0u);
  std::uint32_t next = 1;
  for (kernels::UnitLoad& l : ws.loads) {
    if (ws.column_of[l.column] == 0) ws.column_of[l.column] = next++;
    l.column = ws.column_of[l.column];
  }
  ws.response_nodes.clear();
  for (const kernels::UnitLoad& l : ws.loads) ws.response_nodes.push_back(l.node);
  std::sort(ws.response_nodes.begin(), ws.response_nodes.end());
  ws.response_nodes.erase(std::unique(ws.response_nodes.begin(), ws.response_nodes.end()), ws.response_nodes.end());
}

// The fallback: the assembled block system, banded LU, unit loads as generalized-force columns of
// the strain rows. Fills the responses and, after the coupled solve, the step (band_step).
void band_solve(const WorldModel& model, WorldState& state, std::size_t segment, const SubstepParameters& p,
                const Coupled& c, bool has_stiffness, double law_scale) {
  constexpr int B = kernels::kNewtonBlock;
  const SegmentModel& seg = model.segments[segment];
  const SegmentViews v = segment_views(model, state, segment);
  NewtonWorkspace& ws = state.newton[segment];
  const std::size_t n = seg.node_count;
  const bool free_base = seg.base_mode == BaseMode::free;
  kernels::NewtonLoadStiffness stiffness;
  if (has_stiffness) stiffness = {ws.force_stiffness, ws.drag_moment_rate};
  kernels::NodalLawTangent nodal;
  if (seg.exp2) nodal = {kernels::StrainView<const double>{ws.law_tangent}, ws.bend_coupling};
  const kernels::NewtonSystem system{ws.lower, ws.diag, ws.upper, ws.fill, ws.swaps};
  std::array<double, 4> a = law_total(seg, p.dt);
  for (double& x : a) x *= law_scale;
  auto scale_nodal = [&](double f) {
    if (!seg.exp2 || f == 1.0) return;
    for (double& x : ws.law_tangent) x *= f;
    for (double& x : ws.bend_coupling) x *= f;
  };
  scale_nodal(law_scale);
  ws.base_wrench = kernels::rod_newton_assemble(v.poses, v.section_length, v.force, v.moment, a, stiffness, free_base,
                                                ws.distal_force.view(), ws.distal_moment.view(), system, nodal);
  scale_nodal(1.0 / law_scale);
  kernels::block_tridiagonal_factor(system);
  const int cols = c.columns();
  const auto stride = static_cast<std::size_t>(B * cols);
  auto entry = [&](std::size_t k, int row, int col) -> double& {
    return ws.rhs[k * stride + static_cast<std::size_t>(col * B + row)];
  };
  std::fill_n(ws.rhs.begin(), n * stride, 0.0);
  const kernels::StrainView<const double> residual{ws.residual};
  for (std::size_t k = 0; k < n; ++k)
    for (int i = 0; i < 4; ++i) entry(k, i, 0) = -residual.at(k, static_cast<std::size_t>(i));
  if (free_base)
    for (int i = 0; i < 6; ++i) entry(0, kernels::kNewtonRotation + i, 0) = -ws.base_wrench[i];
  const kernels::StrainView<double> unit{ws.unit};
  for (const kernels::UnitLoad& l : ws.loads) {
    const auto col = static_cast<int>(l.column);
    const double size = l.load.norm();
    kernels::rod_unit_load_generalized_force(v.poses, v.section_length, l.node, l.load / size, l.is_moment, unit);
    for (std::size_t k = 0; k <= l.node; ++k)
      for (int i = 0; i < 4; ++i) entry(k, i, col) -= size * unit.at(k, static_cast<std::size_t>(i));
    if (free_base) {
      const kernels::Vector6d w = unit_wrench({l.node, l.load, l.is_moment, 0}, v);
      for (int i = 0; i < 6; ++i) entry(0, kernels::kNewtonRotation + i, col) -= w[i];
    }
  }
  kernels::block_tridiagonal_solve(system, std::span<double>(ws.rhs.data(), n * stride), cols);
  for (std::size_t r = 0; r < ws.response_nodes.size(); ++r)
    for (int col = 0; col < cols; ++col)
      for (int i = 0; i < 6; ++i)
        ws.responses[(r * static_cast<std::size_t>(cols) + static_cast<std::size_t>(col)) * 6 +
                     static_cast<std::size_t>(i)] = entry(ws.response_nodes[r], kernels::kNewtonRotation + i, col);
}

// Step 4 for the banded path: the step Σ weight_c column_c into the step buffers.
void band_step(NewtonWorkspace& ws, std::size_t n, int cols) {
  constexpr int B = kernels::kNewtonBlock;
  const auto stride = static_cast<std::size_t>(B * cols);
  for (std::size_t k = 0; k < n; ++k) {
    double z[B] = {};
    for (int col = 0; col < cols; ++col)
      for (int r = 0; r < B; ++r)
        z[r] += ws.weights[static_cast<std::size_t>(col)] * ws.rhs[k * stride + static_cast<std::size_t>(col * B + r)];
    for (std::size_t i = 0; i < 4; ++i) ws.step_q[4 * k + i] = z[i];
    ws.step_phi.view().set(
        k, {z[kernels::kNewtonRotation], z[kernels::kNewtonRotation + 1], z[kernels::kNewtonRotation + 2]});
    ws.step_r.view().set(
        k, {z[kernels::kNewtonPosition], z[kernels::kNewtonPosition + 1], z[kernels::kNewtonPosition + 2]});
  }
}

// Step 3: the coupled unknowns. Constraint rows hold their targets; each coupled contact's force
// change follows its separation, δf = −k n·(δr_a − δr_b). Writes the column weights (1, then the
// unknowns) and returns the constraint rows' force changes through `dlambda`.
void coupled_multipliers(const WorldModel& model, const WorldState& state, std::size_t segment, const Coupled& c,
                         const SegmentViews& v, NewtonWorkspace& ws, VectorC& x) {
  const SegmentModel& seg = model.segments[segment];
  const auto cols = static_cast<std::size_t>(c.columns());
  // A node's responses: 6 × columns (δφ, δr of each column), found once per row.
  auto responses_at = [&](std::size_t node) {
    const auto i = static_cast<std::size_t>(std::lower_bound(ws.response_nodes.begin(), ws.response_nodes.end(), node) -
                                            ws.response_nodes.begin());
    return ws.responses.data() + i * cols * 6;
  };
  auto along = [](const double* r, const Eigen::Vector3d& dir) {
    return dir.x() * r[0] + dir.y() * r[1] + dir.z() * r[2];
  };
  auto column = [&](Eigen::Index l) { return static_cast<std::size_t>(ws.column_of[static_cast<std::size_t>(1 + l)]); };
  const auto unknowns = static_cast<Eigen::Index>(c.m + c.pc);
  x = VectorC::Zero(unknowns);
  std::fill(ws.weights.begin(), ws.weights.end(), 0.0);
  ws.weights[0] = 1.0;
  if (unknowns == 0) return;
  MatrixC lhs(unknowns, unknowns);
  VectorC b(unknowns);
  for (std::size_t j = 0; j < c.m; ++j) {
    const ConstraintRow& row = c.rows[j];
    const AttachmentState& as = state.now.attachment[seg.attachment_offset + row.attachment];
    const auto r = static_cast<Eigen::Index>(j);
    const double* at = responses_at(row.node) + (row.is_moment ? 0 : 3);
    b[r] = row_error(row, as, v) - along(at, row.dir);
    for (Eigen::Index l = 0; l < unknowns; ++l) lhs(r, l) = along(at + 6 * column(l), row.dir);
  }
  for (std::size_t i = 0; i < c.pc; ++i) {
    const Pair& pr = c.pairs[i];
    const auto r = static_cast<Eigen::Index>(c.m + i);
    const double* at_a = responses_at(pr.a) + 3;
    const double* at_b = responses_at(pr.b) + 3;
    b[r] = -(along(at_a, pr.n) - along(at_b, pr.n));
    for (Eigen::Index l = 0; l < unknowns; ++l) {
      const std::size_t col = 6 * column(l);
      lhs(r, l) = along(at_a + col, pr.n) - along(at_b + col, pr.n);
    }
    lhs(r, r) += 1.0 / pr.stiffness;
  }
  // Partial pivoting (a third of full pivoting's cost at ~45 unknowns); full pivoting where the
  // rows are dependent (two grasps on one node, a held frame at a clamp).
  const Eigen::PartialPivLU<MatrixC> lu(lhs);
  if (lu.rcond() > 1e-12)
    x = lu.solve(b);
  else
    x = Eigen::FullPivLU<MatrixC>(lhs).solve(b);
  for (Eigen::Index l = 0; l < unknowns; ++l) ws.weights[column(l)] = x[l];
}

}  // namespace

// Step 5: the largest fraction of the step the trust region allows: no section turns or stretches
// too far at once, none goes more than halfway to collapse (ε = −1: past it the rod has no length
// to carry a load and Newton finds a spurious, folded-up solution).
double trust_scale(const SegmentModel& seg, const SegmentViews& v, const NewtonWorkspace& ws) {
  const std::size_t n = seg.node_count;
  double worst_angle = 0.0, worst_stretch = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Vector3d du(ws.step_q[4 * k], ws.step_q[4 * k + 1], ws.step_q[4 * k + 2]);
    worst_angle = std::max(worst_angle, du.norm() * seg.mean_section);
    worst_stretch = std::max(worst_stretch, std::abs(ws.step_q[4 * k + 3]));
  }
  if (seg.base_mode == BaseMode::free) worst_angle = std::max(worst_angle, ws.step_phi.view().get(0).norm());
  double scale = 1.0;
  if (worst_angle > kMaxNewtonAngle) scale = std::min(scale, kMaxNewtonAngle / worst_angle);
  if (worst_stretch > kMaxNewtonStretch) scale = std::min(scale, kMaxNewtonStretch / worst_stretch);
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const double shrink = -0.5 * (ws.step_q[4 * k + 3] + ws.step_q[4 * k + 7]);
    const double room = 1.0 + 0.5 * (v.strain.at(k, 3) + v.strain.at(k + 1, 3));
    if (shrink > 0.5 * room) scale = std::min(scale, 0.5 * room / shrink);
  }
  return scale;
}

// The parts a rod's solve is done in, and the kernels' view of each part's memory.
std::span<const SolvePart> parts_of(const WorldModel& model, std::size_t rod) {
  const std::span<const SolvePart> all(model.solve_parts);
  std::size_t first = 0;
  while (all[first].rod != rod) ++first;
  return all.subspan(first, model.segments[rod].split_node > 0 ? 2 : 1);
}

namespace {

kernels::CondensedSystem whole_system(NewtonWorkspace& ws, int cols) {
  return {ws.gain, ws.scratch, ws.base_solution, cols, ws.record};
}
kernels::CondensedSystem tip_system(NewtonWorkspace& ws, int cols) {
  return {ws.split.tip_gain, ws.split.tip_scratch, ws.split.tip_solution, cols, {}};
}
kernels::CondensedSystem base_system(NewtonWorkspace& ws) {
  return {ws.split.base_gain, ws.split.base_scratch, ws.split.base_solution, ws.split.base_columns, {}};
}

kernels::RodLinearization linearization_at(const WorldModel& model, WorldState& state, std::size_t rod,
                                           const SubstepParameters& p) {
  const SegmentModel& seg = model.segments[rod];
  NewtonWorkspace& ws = state.newton[rod];
  kernels::RodLinearization lin =
      linearization_of(seg, segment_views(model, state, rod), ws, p, seg.has_load_stiffness);
  lin.law_scale = ws.law_scale;
  return lin;
}

// ---- A rod around its sleeping range (decision 0127) ----
// Nodes [first, last] are held. The tip side (after `last`) sweeps from the tip to `last` and starts
// its back-substitutions there from y = 0; the base side (before `first`) is a split rod's base
// part ending at `first`: its 10 interface columns λ are fixed by y_first = the gap between where
// its strains put node `first` and where the range holds it (0 for the unit loads' columns).

void condense_around_range(WorldState& state, std::size_t rod, const kernels::RodLinearization& lin, int cols,
                           double dt) {
  NewtonWorkspace& ws = state.newton[rod];
  NewtonSplit& sp = ws.split;
  const HeldRange held = state.held_range(rod);
  const std::size_t last = lin.poses.node_count() - 1;
  const kernels::StrainView<const double> residual{ws.residual};
  const bool chord = ws.chord && ws.law_scale == 1.0;
  // Fast mode's record serves both sides: the tip side's steps lie after the range, the base
  // side's before it (and its base system in the record's last slot, which the tip side leaves).
  kernels::CondensedSystem base = base_system(ws);
  base.record = ws.record;
  ws.ok = sp.base_ok = true;
  if (held.tip_side(last + 1)) {
    if (chord)
      kernels::rod_condensed_resweep(lin, residual, whole_system(ws, cols), held.last);
    else
      ws.ok = kernels::rod_condense_range(lin, residual, std::span(ws.loads).first(sp.tip_loads),
                                          whole_system(ws, cols), {held.last, last, false, ws.held_interface})
                  .ok;
  }
  if (held.base_side()) {
    const std::span<const std::uint32_t> nodes = std::span(ws.response_nodes).first(sp.base_nodes);
    if (chord) {  // the residual's column anew; the unit and joint columns stand
      kernels::rod_condensed_resweep(lin, residual, base, 0, held.first);
      kernels::rod_condensed_responses_range(lin, base, 0, held.first, sp.base_solution, nodes, sp.raw, sp.at_joint, 0,
                                             1);
    } else {
      const std::span<const kernels::UnitLoad> loads = std::span(sp.base_loads).first(sp.base_load_count);
      sp.base_ok = kernels::rod_condense_range(lin, residual, loads, base, {0, held.first, true, {}}).ok;
      if (sp.base_ok)
        kernels::rod_condensed_responses_range(lin, base, 0, held.first, sp.base_solution, nodes, sp.raw, sp.at_joint);
    }
  }
  if (chord) {
    ++ws.chords;
    return;
  }
  ws.chord_ready = !ws.record.empty() && ws.ok && sp.base_ok && ws.law_scale == 1.0;
  if (ws.chord_ready) {
    ws.chord_frame = state.frame;
    ws.chord_dt = dt;
    ws.chord_pattern = ws.pattern_now;
    ws.chord_from = held.last;
    ws.chord_first = held.first;
  }
}

// The base side's 10 interface unknowns per column: y_first = target (column 0: the gap to the held
// node; the unit loads' columns: 0). False when the base side cannot hold its end (singular).
bool hold_base_side(const WorldModel& model, WorldState& state, std::size_t rod, int cols) {
  NewtonSplit& sp = state.newton[rod].split;
  using Matrix10 = Eigen::Matrix<double, 10, 10>;
  using Vector10 = Eigen::Matrix<double, 10, 1>;
  Matrix10 a;
  for (Eigen::Index j = 0; j < 10; ++j)
    for (Eigen::Index i = 0; i < 10; ++i) a(i, j) = sp.at_joint[static_cast<std::size_t>(10 * (1 + j) + i)];
  const Eigen::FullPivLU<Matrix10> lu(a);
  if (lu.rank() < 10) return false;
  const std::size_t g = model.segments[rod].node_offset + state.range_first[rod];
  const kernels::Pose& end = state.now.range_end[rod];
  const Eigen::AngleAxisd turn(state.now.rotation.view().get(g) * end.rotation.conjugate());
  Vector10 gap = Vector10::Zero();
  gap.head<3>() = turn.angle() * turn.axis();
  gap.segment<3>(3) = state.now.position.view().get(g) - end.position;
  for (std::size_t col = 0; col < static_cast<std::size_t>(cols); ++col) {
    Vector10 rhs = col == 0 ? gap : Vector10::Zero();
    if (const int b = sp.base_column[col]; b >= 0)
      for (Eigen::Index i = 0; i < 10; ++i)
        rhs[i] -= sp.at_joint[10 * static_cast<std::size_t>(b) + static_cast<std::size_t>(i)];
    const Vector10 lambda = lu.solve(rhs);
    for (std::size_t i = 0; i < 10; ++i) {
      sp.lambda[10 * col + i] = lambda[static_cast<Eigen::Index>(i)];
      sp.y_joint[10 * col + i] = 0.0;
    }
  }
  return true;
}

// The coupled unknowns' responses: the tip side's back-substituted from y = 0 at `last` (half 0),
// the base side's folded with λ (half 1).
void responses_around_range(WorldState& state, std::size_t rod, const kernels::RodLinearization& lin, int cols,
                            int half) {
  NewtonWorkspace& ws = state.newton[rod];
  NewtonSplit& sp = ws.split;
  const auto c = static_cast<std::size_t>(cols);
  if (half == 0 && ws.response_nodes.size() > sp.base_nodes)
    kernels::rod_condensed_responses_range(lin, whole_system(ws, cols), state.range_last[rod], ws.response_nodes.back(),
                                           ws.held_start, std::span(ws.response_nodes).subspan(sp.base_nodes),
                                           std::span(ws.responses).subspan(sp.base_nodes * 6 * c), {});
  if (half == 1 && sp.base_nodes > 0)
    kernels::rod_condensed_base_responses(sp.raw, sp.base_columns, std::span(sp.base_column).first(c),
                                          std::span(sp.lambda).first(10 * c), sp.base_nodes, ws.responses);
}

// The step: none over the range; the tip side's from y = 0 at `last`, the base side's from its
// base with λ folded into its start and weights.
void step_around_range(const WorldModel& model, WorldState& state, std::size_t rod,
                       const kernels::RodLinearization& lin, int cols) {
  NewtonWorkspace& ws = state.newton[rod];
  NewtonSplit& sp = ws.split;
  const HeldRange held = state.held_range(rod);
  const std::size_t last = model.segments[rod].node_count - 1;
  const kernels::StrainView<double> dq{ws.step_q};
  for (std::size_t k = held.base_side() ? held.first : 0; k <= held.last; ++k) {
    dq.set(k, Eigen::Vector4d::Zero());
    ws.step_phi.view().set(k, Eigen::Vector3d::Zero());
    ws.step_r.view().set(k, Eigen::Vector3d::Zero());
  }
  if (held.tip_side(last + 1))
    kernels::rod_condensed_step_range(lin, whole_system(ws, cols), held.last, last, ws.held_start.data(), ws.weights,
                                      dq, ws.step_phi.view(), ws.step_r.view());
  if (held.base_side()) {
    const auto c = static_cast<std::size_t>(cols);
    kernels::rod_condensed_split_step(std::span(ws.weights).first(c), sp.lambda, sp.y_joint,
                                      std::span(sp.base_column).first(c), sp.base_solution, sp.base_columns,
                                      sp.base_start.data(), sp.base_weights, sp.tip_start.data());
    kernels::rod_condensed_step_range(lin, base_system(ws), 0, held.first - 1, sp.base_start.data(), sp.base_weights,
                                      dq, ws.step_phi.view(), ws.step_r.view());
  }
}

// Step 3, one part: condensed (the whole rod; the tip part to its interface at the joint; the
// base part from the joint, then back-substituted to it for the join).
void condense_part(const WorldModel& model, WorldState& state, const SolvePart& part, const SubstepParameters& p) {
  const std::size_t rod = part.rod;
  NewtonWorkspace& ws = state.newton[rod];
  NewtonSplit& sp = ws.split;
  const kernels::RodLinearization lin = linearization_at(model, state, rod, p);
  const kernels::StrainView<const double> residual{ws.residual};
  const int cols = state.newton[rod].live_columns;
  const std::size_t last = model.segments[rod].node_count - 1;
  switch (part.kind) {
    case SolvePartKind::whole:
      if (state.held_range(rod).any()) {
        condense_around_range(state, rod, lin, cols, p.dt);
      } else if (ws.chord && ws.law_scale == 1.0) {
        kernels::rod_condensed_resweep(lin, residual, whole_system(ws, cols));
        ws.ok = true;
        ++ws.chords;
      } else {
        ws.ok = kernels::rod_condense(lin, residual, ws.loads, whole_system(ws, cols)).ok;
        // A factorization recorded at the law's own scale serves chord iterations until the rod's
        // contacts, attachments or step length change (decision 0037).
        ws.chord_ready = !ws.record.empty() && ws.ok && ws.law_scale == 1.0;
        if (ws.chord_ready) {
          ws.chord_frame = state.frame;
          ws.chord_dt = p.dt;
          ws.chord_pattern = ws.pattern_now;
          ws.chord_from = ws.chord_first = 0;
        }
      }
      break;
    case SolvePartKind::tip: {
      const kernels::CondensedSystem sys = tip_system(ws, cols);
      sp.tip_ok = kernels::rod_condense_range(lin, residual, std::span(ws.loads).first(sp.tip_loads), sys,
                                              {sp.joint, last, false, sp.interface})
                      .ok;
      // Its responses while its gains are in this core's cache: affine in the joint's y_m, folded
      // after the join (decision 0087).
      if (sp.tip_ok)
        kernels::rod_condensed_tip_responses(lin, sys, sp.joint, std::span(ws.response_nodes).subspan(sp.base_nodes),
                                             sp.tip_particular, sp.tip_unit);
      break;
    }
    case SolvePartKind::base: {
      const kernels::CondensedSystem sys = base_system(ws);
      const std::span<const kernels::UnitLoad> loads = std::span(sp.base_loads).first(sp.base_load_count);
      sp.base_ok = kernels::rod_condense_range(lin, residual, loads, sys, {0, sp.joint, true, {}}).ok;
      if (sp.base_ok)
        kernels::rod_condensed_responses_range(lin, sys, 0, sp.joint, sp.base_solution,
                                               std::span(ws.response_nodes).first(sp.base_nodes), sp.raw, sp.at_joint);
      break;
    }
  }
}

// Step 3, the rod: the split rod's parts joined; where a sweep's pivots were unsafe, the banded LU
// instead. False: neither can solve this iteration.
bool join(const WorldModel& model, WorldState& state, std::size_t rod, const SubstepParameters& p) {
  const SegmentModel& seg = model.segments[rod];
  NewtonWorkspace& ws = state.newton[rod];
  NewtonSplit& sp = ws.split;
  if (state.held_range(rod).any()) {
    const bool held =
        ws.ok && sp.base_ok &&
        (!state.held_range(rod).base_side() || hold_base_side(model, state, rod, state.newton[rod].live_columns));
    if (held) {
      ws.band = false;
      return true;
    }
    // A side of a sleeping range met an unsafe pivot: the range wakes and the whole rod is solved
    // afresh (the banded fallback solves whole rods; decision 0127), with the loads the range's
    // nodes left out while it slept (its tissue and drag) and the residual they make.
    wake_rod(model, state, rod);
    stage_loads(model, state, rod, p);
    stage_backward_sweep(model, state, rod);
    stage_newton_linearize(model, state, rod, p);
    condense_part(model, state, parts_of(model, rod).front(), p);
  }
  const Coupled c = coupled_unknowns(model, state, rod);
  bool ok = sp.joint > 0 ? sp.tip_ok && sp.base_ok : ws.ok;
  if (ok && sp.joint > 0) {
    const kernels::RodLinearization lin = linearization_at(model, state, rod, p);
    ok = kernels::rod_condensed_join(
        lin, sp.joint, {sp.interface, c.columns(), sp.at_joint, sp.base_columns, sp.tip_column, sp.base_column},
        sp.lambda, sp.y_joint);
  }
  ws.band = !ok;
  if (ok) return true;
  ws.chord_ready = false;
  ws.singular_node = 0;
  if (!ws.band_available) return false;
  ++ws.fallbacks;
  band_solve(model, state, rod, p, c, seg.has_load_stiffness, ws.law_scale);
  return true;
}

// Step 4, half of a rod's responses at the coupled unknowns' nodes. A whole rod: half of its
// columns, back-substituted. A split rod: its parts' responses were made in their condense tasks;
// here they are folded with the join's result — the tip part's with y_m (half 0), the base part's
// with λ (half 1), 6 × 10 multiply-adds per node and column.
void responses_half(const WorldModel& model, WorldState& state, std::size_t rod, int half, const SubstepParameters& p) {
  NewtonWorkspace& ws = state.newton[rod];
  NewtonSplit& sp = ws.split;
  if (ws.band || ws.response_nodes.empty()) return;
  const int cols = state.newton[rod].live_columns;
  const auto per_node = 6 * static_cast<std::size_t>(cols);
  if (sp.joint == 0) {
    const kernels::RodLinearization lin = linearization_at(model, state, rod, p);
    int middle = cols / 2, first = half == 0 ? 0 : middle, end = half == 0 ? middle : cols;
    if (ws.chord && ws.law_scale == 1.0) {  // the unit loads' responses stand: the residual's alone
      first = 0;
      end = half == 0 ? 1 : 0;
    }
    if (state.held_range(rod).any()) {
      responses_around_range(state, rod, lin, cols, half);
      return;
    }
    kernels::CondensedSystem sys = whole_system(ws, cols);
    sys.scratch = half == 0 ? std::span<double>(ws.scratch) : std::span<double>(ws.scratch_second);
    if (end > first)
      kernels::rod_condensed_responses_range(lin, sys, 0, ws.response_nodes.back(), sys.base, ws.response_nodes,
                                             ws.responses, {}, first, end);
    return;
  }
  const auto c = static_cast<std::size_t>(cols);
  if (half == 0)
    kernels::rod_condensed_tip_fold(sp.tip_particular, sp.tip_unit, std::span(sp.y_joint).first(10 * c), cols,
                                    ws.response_nodes.size() - sp.base_nodes,
                                    std::span(ws.responses).subspan(sp.base_nodes * per_node));
  else
    kernels::rod_condensed_base_responses(sp.raw, sp.base_columns, std::span(sp.base_column).first(c),
                                          std::span(sp.lambda).first(10 * c), sp.base_nodes, ws.responses);
}

// Step 4, the rod: the coupled unknowns' multipliers (the column weights), and where the rod is
// split, each part's start and weights; the banded path's step.
void multipliers(const WorldModel& model, WorldState& state, std::size_t rod) {
  const SegmentModel& seg = model.segments[rod];
  NewtonWorkspace& ws = state.newton[rod];
  NewtonSplit& sp = ws.split;
  for (std::size_t at = 0; at < seg.attachments.size(); ++at) {
    AttachmentState& as = state.now.attachment[seg.attachment_offset + at];
    if (!as.active) {
      as.force.setZero();
      as.moment.setZero();
    }
  }
  const Coupled c = coupled_unknowns(model, state, rod);
  VectorC x;
  coupled_multipliers(model, state, rod, c, segment_views(model, state, rod), ws, x);
  const auto cols = static_cast<std::size_t>(c.columns());
  if (ws.band) {
    band_step(ws, seg.node_count, c.columns());
  } else if (sp.joint > 0) {
    kernels::rod_condensed_split_step(std::span(ws.weights).first(cols), sp.lambda, sp.y_joint,
                                      std::span(sp.base_column).first(cols), sp.base_solution, sp.base_columns,
                                      sp.base_start.data(), sp.base_weights, sp.tip_start.data());
  }
}

// Step 4, one part: the step at its nodes.
void step_part(const WorldModel& model, WorldState& state, const SolvePart& part, const SubstepParameters& p) {
  const std::size_t rod = part.rod;
  NewtonWorkspace& ws = state.newton[rod];
  NewtonSplit& sp = ws.split;
  if (ws.band) return;
  const kernels::RodLinearization lin = linearization_at(model, state, rod, p);
  const int cols = state.newton[rod].live_columns;
  const kernels::StrainView<double> dq{ws.step_q};
  switch (part.kind) {
    case SolvePartKind::whole:
      if (state.held_range(rod).any()) {
        step_around_range(model, state, rod, lin, cols);
      } else {
        kernels::rod_condensed_step(lin, whole_system(ws, cols), ws.weights, dq, ws.step_phi.view(), ws.step_r.view());
      }
      break;
    case SolvePartKind::tip:
      kernels::rod_condensed_step_range(lin, tip_system(ws, cols), sp.joint, model.segments[rod].node_count - 1,
                                        sp.tip_start.data(), ws.weights, dq, ws.step_phi.view(), ws.step_r.view());
      break;
    case SolvePartKind::base:  // up to the node before the joint: the tip part writes the joint's
      kernels::rod_condensed_step_range(lin, base_system(ws), 0, sp.joint - 1, sp.base_start.data(), sp.base_weights,
                                        dq, ws.step_phi.view(), ws.step_r.view());
      break;
  }
}

}  // namespace

// The whole solve of one rod at a law scale, its parts one after another (the line search's
// stiffened re-solves): what the condense and solve stages do over all rods at once.
bool resolve(const WorldModel& model, WorldState& state, std::size_t rod, const SubstepParameters& p,
             double law_scale) {
  state.newton[rod].law_scale = law_scale;
  const std::span<const SolvePart> parts = parts_of(model, rod);
  for (const SolvePart& part : parts) condense_part(model, state, part, p);
  if (!join(model, state, rod, p)) return false;
  for (int half = 0; half < 2; ++half) responses_half(model, state, rod, half, p);
  multipliers(model, state, rod);
  for (const SolvePart& part : parts) step_part(model, state, part, p);
  return true;
}

}  // namespace newton

using namespace newton;

void stage_newton_linearize(const WorldModel& model, WorldState& state, std::size_t rod, const SubstepParameters& p) {
  NewtonWorkspace& ws = state.newton[rod];
  ws.law_scale = 1.0;
  linearize(model, state, rod, p);
  const Coupled c = coupled_unknowns(model, state, rod);
  ws.live_columns = c.columns();
  unit_loads(c, ws);
  ws.chord = false;
  if (!ws.record.empty()) {
    // Fast mode: the last factorization serves while the attachments hold the same nodes, the same
    // beads touch, the step length stands and it is young enough.
    const SegmentModel& seg = model.segments[rod];
    ws.pattern_now.clear();
    for (std::size_t a = 0; a < seg.attachments.size(); ++a) {
      const AttachmentState& as = state.now.attachment[seg.attachment_offset + a];
      // A coupled grasp holds through its slot too (as a load, the slot inactive).
      bool coupled = false;
      for (const InstrumentState& in : state.instruments)
        coupled = coupled || (in.grasping && in.coupled && in.grasp_attachment == seg.attachment_offset + a);
      ws.pattern_now.push_back(as.active || coupled
                                   ? static_cast<std::uint32_t>(2 * as.node + (as.hold_frame && !coupled ? 1 : 0))
                                   : 0xFFFFFFFFu);
    }
    const CollisionState& cs = state.collision;
    for (std::size_t b = seg.bead_offset; b < seg.bead_offset + seg.bead_count; ++b) {
      std::uint32_t touching = 0;
      for (std::uint32_t e = cs.bead_contact_start[b]; e < cs.bead_contact_start[b + 1]; ++e)
        touching |= cs.candidates[cs.bead_contact[e] >> 1].depth > 0.0 ? 1u : 0u;
      ws.pattern_now.push_back(touching);
    }
    // A contact that lets go leaves the factorization stiffer than the rod (a shorter step); only a
    // new one is unaccounted for.
    bool same = ws.pattern_now.size() == ws.chord_pattern.size();
    for (std::size_t i = 0; same && i < ws.pattern_now.size(); ++i)
      same = i < seg.attachments.size() ? ws.pattern_now[i] == ws.chord_pattern[i]
                                        : ws.pattern_now[i] <= ws.chord_pattern[i];
    ws.chord = p.chord && ws.chord_ready && state.frame - ws.chord_frame < kRefactorFrames && ws.chord_dt == p.dt &&
               same && ws.chord_from == state.held_range(rod).last && ws.chord_first == state.held_range(rod).first;
  }
  NewtonSplit& sp = ws.split;
  const HeldRange held = state.held_range(rod);
  if (sp.joint == 0 && !held.base_side()) {
    sp.tip_loads = ws.loads.size();  // a range's tip side takes every load (none sits on the range)
    sp.base_nodes = 0;
    return;
  }
  const std::size_t joint = sp.joint > 0 ? sp.joint : held.first;
  const auto cols = static_cast<std::size_t>(c.columns());
  const auto [tip_loads, base_columns] =
      kernels::rod_condensed_split_loads(ws.loads, c.columns(), joint, sp.base_loads,
                                         std::span(sp.tip_column).first(cols), std::span(sp.base_column).first(cols));
  sp.tip_loads = tip_loads;
  sp.base_load_count = ws.loads.size() - tip_loads;
  sp.base_columns = base_columns;
  sp.base_nodes = static_cast<std::size_t>(
      std::upper_bound(ws.response_nodes.begin(), ws.response_nodes.end(), static_cast<std::uint32_t>(joint)) -
      ws.response_nodes.begin());
}

void plan_newton_condense(const WorldModel& model, WorldState& state, std::span<const std::uint8_t> solving) {
  std::vector<CondenseTask>& tasks = state.condense_tasks;
  tasks.clear();
  // Batches being filled, by (node count, load stiffness); a full one becomes a lanes task.
  struct Batch {
    std::size_t nodes = 0;
    bool stiffness = false;
    CondenseTask task;
  };
  constexpr std::size_t kOpen = 8;
  std::array<Batch, kOpen> open{};
  std::size_t opened = 0;
  for (std::size_t i = 0; i < model.solve_parts.size(); ++i) {
    const SolvePart& part = model.solve_parts[i];
    if (solving[part.rod] == 0) continue;
    const SegmentModel& seg = model.segments[part.rod];
    const NewtonWorkspace& ws = state.newton[part.rod];
    // The lanes take whole rods with the residual column alone, neither reusing a factorization
    // nor recording one (fast mode's).
    const bool lanes =
        part.kind == SolvePartKind::whole && ws.loads.empty() && ws.record.empty() && !state.held_range(part.rod).any();
    if (!lanes) {
      tasks.push_back({{static_cast<std::uint32_t>(i), 0, 0, 0}, 1});
      continue;
    }
    const bool stiffness = seg.has_load_stiffness;
    std::size_t b = 0;
    while (b < opened && !(open[b].nodes == seg.node_count && open[b].stiffness == stiffness)) ++b;
    if (b == opened) {
      if (opened == kOpen) {  // more kinds of rod than batches: this one alone
        tasks.push_back({{static_cast<std::uint32_t>(i), 0, 0, 0}, 1});
        continue;
      }
      open[opened++] = {seg.node_count, stiffness, {{}, 0}};
    }
    CondenseTask& t = open[b].task;
    t.part[t.count++] = static_cast<std::uint32_t>(i);
    if (t.count == kernels::kCondensedLanes) {
      tasks.push_back(t);
      t.count = 0;
    }
  }
  for (std::size_t b = 0; b < opened; ++b)  // what did not fill a batch, one by one
    for (std::uint8_t j = 0; j < open[b].task.count; ++j) tasks.push_back({{open[b].task.part[j], 0, 0, 0}, 1});
}

namespace {

// Four whole rods of one node count, the residual column alone, condensed together in SIMD lanes
// (kernels/rod_condense_lanes: the same bits as one by one).
void condense_lanes(const WorldModel& model, WorldState& state, const CondenseTask& task, const SubstepParameters& p) {
  std::array<kernels::RodLinearization, kernels::kCondensedLanes> lin;
  std::array<const kernels::RodLinearization*, kernels::kCondensedLanes> rods{};
  std::array<kernels::StrainView<const double>, kernels::kCondensedLanes> residuals{};
  std::array<kernels::CondensedSystem, kernels::kCondensedLanes> systems{};
  for (std::size_t l = 0; l < kernels::kCondensedLanes; ++l) {
    const std::size_t rod = model.solve_parts[task.part[l]].rod;
    NewtonWorkspace& ws = state.newton[rod];
    lin[l] = linearization_at(model, state, rod, p);
    rods[l] = &lin[l];
    residuals[l] = kernels::StrainView<const double>{ws.residual};
    systems[l] = whole_system(ws, 1);
  }
  std::array<kernels::CondenseReport, kernels::kCondensedLanes> reports{};
  kernels::rod_condense_lanes(rods, residuals, systems, reports);
  for (std::size_t l = 0; l < kernels::kCondensedLanes; ++l) {
    NewtonWorkspace& ws = state.newton[model.solve_parts[task.part[l]].rod];
    ws.ok = reports[l].ok;
    ws.chord_ready = false;
  }
}

}  // namespace

// The stages over the whole world, as frame.cpp runs them in each Newton iteration: each spreads its
// steps over the scheduler (per rod, per solve part, per task), for the rods still iterating.

void stage_condense(const WorldModel& model, WorldState& state, Scheduler& scheduler, const SubstepParameters& p) {
  const std::size_t segs = model.segments.size();
  const auto active = [&](std::size_t s) { return state.segment_converged[s] == 0; };
  scheduler.for_each(segs, [&](std::size_t s) {
    if (active(s)) stage_newton_linearize(model, state, s, p);
  });
  for (std::size_t s = 0; s < segs; ++s) state.segment_solving[s] = active(s) && state.segment_solvable[s] != 0;
  plan_newton_condense(model, state, state.segment_solving);
  scheduler.for_each(state.condense_tasks.size(), [&](std::size_t i) {
    const CondenseTask& task = state.condense_tasks[i];
    if (task.count == 1)
      condense_part(model, state, model.solve_parts[task.part[0]], p);
    else
      condense_lanes(model, state, task, p);
  });
  scheduler.for_each(segs, [&](std::size_t s) {
    if (active(s)) state.segment_solvable[s] = join(model, state, s, p) ? 1 : 0;
  });
}

void stage_newton_solve(const WorldModel& model, WorldState& state, Scheduler& scheduler, const SubstepParameters& p) {
  const std::size_t segs = model.segments.size();
  const auto solving = [&](std::size_t s) { return state.segment_converged[s] == 0 && state.segment_solvable[s] != 0; };
  scheduler.for_each(2 * segs, [&](std::size_t i) {
    const std::size_t s = i / 2;
    if (solving(s)) responses_half(model, state, s, static_cast<int>(i % 2), p);
  });
  scheduler.for_each(segs, [&](std::size_t s) {
    if (solving(s)) multipliers(model, state, s);
  });
  scheduler.for_each(model.solve_parts.size(), [&](std::size_t i) {
    if (solving(model.solve_parts[i].rod)) step_part(model, state, model.solve_parts[i], p);
  });
}

void end_unsolvable(const WorldModel& model, WorldState& state) {
  for (std::size_t s = 0; s < model.segments.size(); ++s)
    if (state.segment_converged[s] == 0 && state.segment_solvable[s] == 0) {
      state.segment_change[s].setZero();
      state.segment_converged[s] = 1;
    }
}

}  // namespace haustra::detail
