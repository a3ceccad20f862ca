#include "rod_stages.hpp"

#include <Eigen/Dense>
#include <cmath>

#include "haustra/kernels/block_tridiagonal.hpp"
#include "haustra/kernels/inertia_filter.hpp"
#include "haustra/kernels/mass_matrix.hpp"
#include "haustra/kernels/rod_backward_sweep.hpp"
#include "haustra/kernels/rod_forward_sweep.hpp"
#include "haustra/kernels/rod_loads.hpp"
#include "haustra/kernels/rod_newton.hpp"
#include "haustra/kernels/strain_update.hpp"
#include "haustra/kernels/tissue_law.hpp"
#include "collision.hpp"

namespace haustra::detail {
namespace {

constexpr int kMaxRows = static_cast<int>(kMaxConstraintRows);
using MatrixS = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxRows, kMaxRows>;
using VectorS = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxRows, 1>;
// Newton's coupled system: constraint rows and the contacts it solves as pairs.
constexpr int kMaxCoupled = kMaxRows + static_cast<int>(kMaxCoupledContacts);
using MatrixC = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxCoupled, kMaxCoupled>;
using VectorC = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxCoupled, 1>;
using Matrix6x = Eigen::Matrix<double, 6, Eigen::Dynamic, 0, 6, kMaxRows>;

// Newton steps are scaled down to stay within these per frame of iteration (a trust region):
// beyond them the linearization says little about the rod.
constexpr double kMaxNewtonAngle = 0.5;   // rad of bend or twist per section
constexpr double kMaxNewtonStretch = 0.25;
// ... and so that no contact gets deeper by more than this fraction of its bead's radius: a
// penalty's stiffness grows with depth, so the tangent at the surface lets a bead sink far too far.
// Checked on the rod's real motion (a backtracking line search): far down a long rod a step's
// rotations add up and the first-order displacement says little about where a bead goes.
constexpr double kMaxNewtonDeepening = 0.1;
constexpr int kMaxBacktracks = 8;

kernels::MassMatrixFactorView factor_of(const WorldModel& model, const SegmentModel& seg) {
  return {std::span<const double>(model.mass_inv_pivot).subspan(seg.node_offset, seg.node_count),
          std::span<const double>(model.mass_lower).subspan(seg.node_offset, seg.node_count)};
}

kernels::StrainLawCoefficients law_of(const SegmentModel& seg, double dt) {
  kernels::StrainLawCoefficients law;
  for (std::size_t c = 0; c < 4; ++c) {
    law.stiffness[c] = seg.stiffness[c];
    law.rate[c] = seg.viscosity[c] / dt;
  }
  return law;
}

std::array<double, 4> law_total(const SegmentModel& seg, double dt) {
  const kernels::StrainLawCoefficients law = law_of(seg, dt);
  return {law.stiffness[0] + law.rate[0], law.stiffness[1] + law.rate[1], law.stiffness[2] + law.rate[2],
          law.stiffness[3] + law.rate[3]};
}

kernels::NodalLaw nodal_law_of(const SegmentModel& seg, double dt) {
  const kernels::StrainLawCoefficients law = law_of(seg, dt);
  return {law.stiffness, law.rate, seg.exp2, seg.tissue, seg.tube};
}

std::span<const double> drag_of(const WorldModel& model, const SegmentModel& seg) {
  return std::span<const double>(model.node_drag).subspan(seg.node_offset, seg.node_count);
}

std::span<const double> spin_drag_of(const WorldModel& model, const SegmentModel& seg) {
  return std::span<const double>(model.node_spin_drag).subspan(seg.node_offset, seg.node_count);
}

void zero(kernels::Vec3View<double> v) {
  std::fill(v.x.begin(), v.x.end(), 0.0);
  std::fill(v.y.begin(), v.y.end(), 0.0);
  std::fill(v.z.begin(), v.z.end(), 0.0);
}

// Generalized forces of the drag that a unit base twist `axis` meets, into `out`. Uses the node
// load buffers as scratch: the backward sweep has consumed them by the time this runs.
void unit_drag_field(const WorldModel& model, const SegmentModel& seg, const SegmentViews& v, std::size_t axis,
                     kernels::StrainView<double> out) {
  zero(v.force);
  zero(v.moment);
  kernels::add_rigid_drag_loads(v.poses.node_position, drag_of(model, seg), spin_drag_of(model, seg),
                                v.poses.node_position.get(0), kernels::Vector6d::Unit(static_cast<Eigen::Index>(axis)),
                                v.force, v.moment);
  kernels::rod_backward_sweep(v.poses, v.section_length, v.force, v.moment, out);
}

// Adds the attachments' current constraint forces and moments to the node loads.
void add_attachment_loads(const SegmentModel& seg, const WorldState& state, const SegmentViews& v) {
  for (std::size_t a = 0; a < seg.attachments.size(); ++a) {
    const AttachmentState& as = state.now.attachment[seg.attachment_offset + a];
    if (!as.active) continue;
    const std::size_t k = as.node;
    v.force.set(k, v.force.get(k) + as.force);
    v.moment.set(k, v.moment.get(k) + as.moment);
  }
}

// Wrench about node 0 of a unit constraint load, and the base twist it causes through the drag.
kernels::Vector6d unit_wrench(const ConstraintRow& row, const SegmentViews& v) {
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

// The attachment's remaining error along a row, measured on the current poses.
double row_error(const ConstraintRow& row, const AttachmentState& as, const SegmentViews& v) {
  const Eigen::Vector3d e =
      row.is_moment ? kernels::rotation_log(as.target_rotation * v.poses.node_rotation.get(row.node).conjugate())
                    : Eigen::Vector3d(as.target - v.poses.node_position.get(row.node));
  return row.dir.dot(e);
}

}  // namespace

std::size_t active_constraint_rows(const SegmentModel& seg, const WorldState& state, ConstraintRows& rows) {
  std::size_t m = 0;
  for (std::size_t a = 0; a < seg.attachments.size(); ++a) {
    const AttachmentState& as = state.now.attachment[seg.attachment_offset + a];
    if (!as.active) continue;
    for (int axis = 0; axis < 3; ++axis) rows[m++] = {as.node, Eigen::Vector3d::Unit(axis), false, a};
    if (as.hold_frame)
      for (int axis = 0; axis < 3; ++axis) rows[m++] = {as.node, Eigen::Vector3d::Unit(axis), true, a};
  }
  return m;
}

kernels::Pose integrate_base(const kernels::Pose& start, const kernels::Vector6d& twist, double dt) {
  kernels::Pose p;
  p.rotation = (kernels::rotation_exp(dt * twist.head<3>()) * start.rotation).normalized();
  p.position = start.position + dt * twist.tail<3>();
  return p;
}

void stage_loads(const WorldModel& model, WorldState& state, std::size_t segment, const SubstepParameters& p) {
  const SegmentModel& seg = model.segments[segment];
  const SegmentViews v = segment_views(model, state, segment);
  kernels::assemble_node_loads(v.node_mass, model.gravity,
                               state.external_force.view().subview(seg.node_offset, seg.node_count),
                               state.external_moment.view().subview(seg.node_offset, seg.node_count), v.force,
                               v.moment);
  // Contact penalties, as the collision stage last evaluated them.
  const auto bead_force = state.collision.bead_force.view();
  for (std::size_t b = seg.bead_offset; b < seg.bead_offset + seg.bead_count; ++b) {
    const std::size_t k = model.beads.node[b] - seg.node_offset;
    v.force.set(k, v.force.get(k) + bead_force.get(b));
  }
  if (!p.newton) return;
  // Newton solves for increments of the constraint forces; their current totals are loads.
  add_attachment_loads(seg, state, v);
  if (!seg.has_drag) return;
  const auto r0 = state.position_substep_start.view().subview(seg.node_offset, seg.node_count);
  const auto q0 = state.rotation_substep_start.view().subview(seg.node_offset, seg.node_count);
  const std::span<const double> c = drag_of(model, seg);
  const std::span<const double> sd = spin_drag_of(model, seg);
  for (std::size_t k = 0; k < seg.node_count; ++k) {
    v.force.set(k, v.force.get(k) - (c[k] / p.dt) * (v.poses.node_position.get(k) - r0.get(k)));
    const Eigen::Vector3d turn = kernels::rotation_log(v.poses.node_rotation.get(k) * q0.get(k).conjugate());
    v.moment.set(k, v.moment.get(k) - (sd[k] / p.dt) * turn);
  }
}

void stage_free_base(const WorldModel& model, WorldState& state, std::size_t segment, double dt) {
  const SegmentModel& seg = model.segments[segment];
  if (seg.base_mode != BaseMode::free) return;
  const SegmentViews v = segment_views(model, state, segment);
  const Eigen::Vector3d origin = v.poses.node_position.get(0);
  // The rod moves rigidly so that the drag balances the total load, C (ω, v) = W, and the drag
  // loads join the node loads: the strains then see a self-equilibrated load, as a free body should.
  const kernels::Matrix6d c = kernels::rigid_drag_resistance(v.poses.node_position, drag_of(model, seg),
                                                             spin_drag_of(model, seg), origin);
  const kernels::Vector6d w = kernels::total_wrench(v.poses.node_position, v.force, v.moment, origin);
  const kernels::Vector6d twist = c.ldlt().solve(w);
  state.base_resistance[segment] = c;
  state.base_twist[segment] = twist;
  kernels::add_rigid_drag_loads(v.poses.node_position, drag_of(model, seg), spin_drag_of(model, seg), origin, twist,
                                v.force, v.moment);
  state.now.base[segment] = integrate_base(state.base_substep_start[segment], twist, dt);
}

void stage_backward_sweep(const WorldModel& model, WorldState& state, std::size_t segment) {
  const SegmentViews v = segment_views(model, state, segment);
  kernels::rod_backward_sweep(v.poses, v.section_length, v.force, v.moment, v.generalized_force);
}

Eigen::Vector4d stage_solve(const WorldModel& model, WorldState& state, std::size_t segment,
                            const SubstepParameters& p) {
  const SegmentModel& seg = model.segments[segment];
  const SegmentViews v = segment_views(model, state, segment);
  std::copy(v.strain.data.begin(), v.strain.data.end(),
            state.strain_before_update.begin() + static_cast<std::ptrdiff_t>(4 * seg.node_offset));
  kernels::mass_matrix_solve(factor_of(model, seg), v.generalized_force);
  const double w = model.solver.relaxation;
  return kernels::strain_update(v.generalized_force, v.rest, v.strain_start, law_of(seg, p.dt), {w, w, w, w},
                                v.strain);
}

void stage_forward_sweep(const WorldModel& model, WorldState& state, std::size_t segment) {
  const SegmentViews v = segment_views(model, state, segment);
  kernels::rod_forward_sweep(state.now.base[segment], v.section_length, v.strain, v.poses);
}

void stage_constraints(const WorldModel& model, WorldState& state, std::size_t segment,
                       const SubstepParameters& p) {
  const SegmentModel& seg = model.segments[segment];
  if (seg.constraint_rows == 0) return;
  ConstraintRows rows{};
  const std::size_t m = active_constraint_rows(seg, state, rows);
  for (std::size_t a = 0; a < seg.attachments.size(); ++a) {
    state.now.attachment[seg.attachment_offset + a].force.setZero();
    state.now.attachment[seg.attachment_offset + a].moment.setZero();
  }
  if (m == 0) return;

  const SegmentViews v = segment_views(model, state, segment);
  const std::size_t n = seg.node_count;
  const bool free_base = seg.base_mode == BaseMode::free;
  double* scratch = state.constraint_scratch.data() + seg.constraint_scratch_offset;
  auto g_row = [&](std::size_t j) { return kernels::StrainView<double>{std::span<double>(scratch + 4 * n * j, 4 * n)}; };
  auto y_row = [&](std::size_t j) {
    return kernels::StrainView<double>{std::span<double>(scratch + 4 * n * (seg.constraint_rows + j), 4 * n)};
  };
  auto h_col = [&](std::size_t i) {
    return kernels::StrainView<double>{std::span<double>(scratch + 4 * n * (2 * seg.constraint_rows + i), 4 * n)};
  };

  // Rows of J at the linearization configuration (the poses the backward sweep used).
  for (std::size_t j = 0; j < m; ++j)
    kernels::rod_unit_load_generalized_force(v.poses, v.section_length, rows[j].node, rows[j].dir, rows[j].is_moment,
                                             g_row(j));

  // Free base: a constraint force also moves the base, ν_j = C⁻¹ w_j, and the drag that motion
  // meets loads the strains too: H ν_j, with H the sweeps of the six unit-twist drag fields.
  Matrix6x nu(6, static_cast<Eigen::Index>(m));
  Matrix6x w(6, static_cast<Eigen::Index>(m));
  if (free_base) {
    const Eigen::LDLT<kernels::Matrix6d> c(state.base_resistance[segment]);
    for (std::size_t i = 0; i < 6; ++i) unit_drag_field(model, seg, v, i, h_col(i));
    for (std::size_t j = 0; j < m; ++j) {
      w.col(static_cast<Eigen::Index>(j)) = unit_wrench(rows[j], v);
      nu.col(static_cast<Eigen::Index>(j)) = c.solve(w.col(static_cast<Eigen::Index>(j)));
    }
  }

  // Y_j = ω A⁻¹ Jᵀ P e_j: the strain response to a unit constraint force.
  const kernels::StrainLawCoefficients law = law_of(seg, p.dt);
  std::array<double, 4> scale{};
  for (std::size_t c = 0; c < 4; ++c) scale[c] = model.solver.relaxation / (law.stiffness[c] + law.rate[c]);
  for (std::size_t j = 0; j < m; ++j) {
    const kernels::StrainView<double> y = y_row(j);
    const kernels::StrainView<double> g = g_row(j);
    std::copy(g.data.begin(), g.data.end(), y.data.begin());
    if (free_base)
      for (std::size_t i = 0; i < 6; ++i) {
        const double f = nu(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j));
        const kernels::StrainView<double> h = h_col(i);
        for (std::size_t e = 0; e < 4 * n; ++e) y.data[e] += f * h.data[e];
      }
    kernels::mass_matrix_solve(factor_of(model, seg), y);
    for (std::size_t k = 0; k < n; ++k)
      for (std::size_t c = 0; c < 4; ++c) y.at(k, c) *= scale[c];
  }

  // S = J Y (+ base mobility), in the linearization configuration.
  const auto mi = static_cast<Eigen::Index>(m);
  MatrixS s(mi, mi);
  for (std::size_t i = 0; i < m; ++i) {
    const std::size_t len = 4 * (rows[i].node + 1);  // G_i vanishes beyond its node
    const double* gi = g_row(i).data.data();
    for (std::size_t j = 0; j < m; ++j) {
      const double* yj = y_row(j).data.data();
      double dot = 0.0;
      for (std::size_t e = 0; e < len; ++e) dot += gi[e] * yj[e];
      if (free_base) dot += p.dt * w.col(static_cast<Eigen::Index>(i)).dot(nu.col(static_cast<Eigen::Index>(j)));
      s(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = dot;
    }
  }

  // Constraint error after the unconstrained update, measured exactly.
  kernels::rod_forward_sweep(state.now.base[segment], v.section_length, v.strain, v.poses);
  VectorS err(mi);
  for (std::size_t j = 0; j < m; ++j)
    err[static_cast<Eigen::Index>(j)] =
        row_error(rows[j], state.now.attachment[seg.attachment_offset + rows[j].attachment], v);
  const VectorS lambda = Eigen::FullPivLU<MatrixS>(s).solve(err);

  for (std::size_t j = 0; j < m; ++j) {
    const double l = lambda[static_cast<Eigen::Index>(j)];
    const kernels::StrainView<double> y = y_row(j);
    for (std::size_t e = 0; e < 4 * n; ++e) v.strain.data[e] += l * y.data[e];
    AttachmentState& as = state.now.attachment[seg.attachment_offset + rows[j].attachment];
    (rows[j].is_moment ? as.moment : as.force) += l * rows[j].dir;
  }
  if (free_base) {
    state.base_twist[segment] += nu * lambda;
    state.now.base[segment] = integrate_base(state.base_substep_start[segment], state.base_twist[segment], p.dt);
  }
}

void stage_newton_jacobian(const WorldModel& model, WorldState& state, std::size_t segment,
                           const SubstepParameters& p) {
  const SegmentModel& seg = model.segments[segment];
  const SegmentViews v = segment_views(model, state, segment);
  NewtonWorkspace& ws = state.newton[segment];
  // Loads that follow the nodes: the medium's drag on every node, contact penalties at beads.
  kernels::NewtonLoadStiffness stiffness;
  if (seg.has_drag || seg.bead_count > 0) {
    const std::span<const double> c = drag_of(model, seg);
    const std::span<const double> sd = spin_drag_of(model, seg);
    for (std::size_t k = 0; k < seg.node_count; ++k) {
      ws.force_stiffness[k] = (c[k] / p.dt) * Eigen::Matrix3d::Identity();
      ws.drag_moment_rate[k] = sd[k] / p.dt;
    }
    for (std::size_t b = seg.bead_offset; b < seg.bead_offset + seg.bead_count; ++b)
      ws.force_stiffness[model.beads.node[b] - seg.node_offset] += state.collision.bead_stiffness[b];
    stiffness = {ws.force_stiffness, ws.drag_moment_rate};
  }
  kernels::NodalLawTangent nodal;
  if (seg.exp2) {
    // The law at this iterate: its stress serves the residual (stage_newton_solve), its tangent here.
    kernels::nodal_law_evaluate(v.strain, v.rest, v.strain_start, nodal_law_of(seg, p.dt),
                                kernels::StrainView<double>{ws.law_stress}, kernels::StrainView<double>{ws.law_tangent},
                                ws.bend_coupling);
    nodal = {kernels::StrainView<const double>{ws.law_tangent}, ws.bend_coupling};
  }
  ws.base_wrench = kernels::rod_newton_assemble(v.poses, v.section_length, v.force, v.moment, law_total(seg, p.dt),
                                                stiffness, seg.base_mode == BaseMode::free, ws.distal_force.view(),
                                                ws.distal_moment.view(), ws.system(), nodal);
  kernels::block_tridiagonal_factor(ws.system());
}

Eigen::Vector4d stage_newton_solve(const WorldModel& model, WorldState& state, std::size_t segment,
                                   const SubstepParameters& p) {
  constexpr int B = kernels::kNewtonBlock;
  const SegmentModel& seg = model.segments[segment];
  const SegmentViews v = segment_views(model, state, segment);
  NewtonWorkspace& ws = state.newton[segment];
  const std::size_t n = seg.node_count;
  const std::array<double, 4> a = law_total(seg, p.dt);
  const kernels::StrainLawCoefficients law = law_of(seg, p.dt);
  const bool free_base = seg.base_mode == BaseMode::free;

  // Residual ρ = R − A (q − q*), q* = (k q̂ + (η/Δt) q_start) / a; for EXP2, ρ = R − M s(q).
  if (seg.exp2) {
    kernels::rod_stress_residual(v.generalized_force, kernels::StrainView<const double>{ws.law_stress},
                                 v.section_length, kernels::StrainView<double>{ws.residual});
  } else {
    const kernels::StrainView<double> target{ws.target};
    for (std::size_t k = 0; k < n; ++k)
      for (std::size_t c = 0; c < 4; ++c)
        target.at(k, c) = (law.stiffness[c] * v.rest.at(k, c) + law.rate[c] * v.strain_start.at(k, c)) / a[c];
    kernels::rod_strain_residual(v.generalized_force, v.strain, target, v.section_length, a,
                                 kernels::StrainView<double>{ws.residual});
  }

  ConstraintRows rows{};
  const std::size_t m = seg.constraint_rows > 0 ? active_constraint_rows(seg, state, rows) : 0;
  for (std::size_t at = 0; at < seg.attachments.size(); ++at) {
    AttachmentState& as = state.now.attachment[seg.attachment_offset + at];
    if (!as.active) {
      as.force.setZero();
      as.moment.setZero();
    }
  }
  // Right-hand sides: column 0 the residual (and, for a free base, the unbalanced wrench);
  // column 1+j the generalized force of a unit load along constraint row j; then, for each
  // contact coupled exactly, a unit pair of forces (+n on one bead's node, −n on the other's).
  const CollisionState& cs = state.collision;
  const std::size_t p0 = cs.coupled_start.empty() ? 0 : cs.coupled_start[segment];
  const std::size_t pc = cs.coupled_start.empty() ? 0 : cs.coupled_start[segment + 1] - p0;
  const int cols = 1 + static_cast<int>(m + pc);
  const auto stride = static_cast<std::size_t>(B * cols);
  auto entry = [&](std::size_t k, int row, int col) -> double& {
    return ws.rhs[k * stride + static_cast<std::size_t>(col * B + row)];
  };
  std::fill_n(ws.rhs.begin(), n * stride, 0.0);
  const kernels::StrainView<const double> residual{ws.residual};
  for (std::size_t k = 0; k < n; ++k)
    for (int c = 0; c < 4; ++c) entry(k, c, 0) = -residual.at(k, static_cast<std::size_t>(c));
  if (free_base)
    for (int i = 0; i < 6; ++i) entry(0, kernels::kNewtonRotation + i, 0) = -ws.base_wrench[i];
  const kernels::StrainView<double> unit{ws.unit};
  // A unit load (force or moment along dir, at a node) into column `col`, with `sign`.
  auto add_unit_load = [&](int col, std::size_t node, const Eigen::Vector3d& dir, bool is_moment, double sign) {
    kernels::rod_unit_load_generalized_force(v.poses, v.section_length, node, dir, is_moment, unit);
    for (std::size_t k = 0; k <= node; ++k)
      for (int c = 0; c < 4; ++c) entry(k, c, col) -= sign * unit.at(k, static_cast<std::size_t>(c));
    if (free_base) {
      // A unit load unbalances the free rod by its own wrench about node 0.
      const kernels::Vector6d w = unit_wrench({node, dir, is_moment, 0}, v);
      for (int i = 0; i < 6; ++i) entry(0, kernels::kNewtonRotation + i, col) -= sign * w[i];
    }
  };
  for (std::size_t j = 0; j < m; ++j) add_unit_load(1 + static_cast<int>(j), rows[j].node, rows[j].dir, rows[j].is_moment, 1.0);
  struct Pair {
    std::size_t a, b;       // local nodes
    Eigen::Vector3d n;      // separating direction, towards a
    double stiffness;
  };
  std::array<Pair, kMaxCoupledContacts> pairs{};
  for (std::size_t c = 0; c < pc; ++c) {
    const Contact& k = cs.candidates[cs.coupled[p0 + c]];
    pairs[c] = {model.beads.node[k.bead] - seg.node_offset, model.beads.node[k.other] - seg.node_offset, k.direction,
                std::max(k.stiffness, 1e-300)};
    const int col = 1 + static_cast<int>(m + c);
    add_unit_load(col, pairs[c].a, pairs[c].n, false, 1.0);
    add_unit_load(col, pairs[c].b, pairs[c].n, false, -1.0);
  }
  kernels::block_tridiagonal_solve(ws.system(), std::span<double>(ws.rhs.data(), n * stride), cols);

  // Displacement (or rotation) of a node along a direction in column `col`.
  auto moved = [&](std::size_t node, const Eigen::Vector3d& dir, bool rotation, int col) {
    const int first = rotation ? kernels::kNewtonRotation : kernels::kNewtonPosition;
    return dir.dot(Eigen::Vector3d(entry(node, first, col), entry(node, first + 1, col), entry(node, first + 2, col)));
  };
  auto response = [&](const ConstraintRow& row, int col) { return moved(row.node, row.dir, row.is_moment, col); };
  auto separation = [&](const Pair& pr, int col) { return moved(pr.a, pr.n, false, col) - moved(pr.b, pr.n, false, col); };

  // The coupled system: constraint rows hold their targets; each coupled contact's force change
  // follows its separation, δf = −k n·(δr_a − δr_b).
  const auto unknowns = static_cast<Eigen::Index>(m + pc);
  VectorC x = VectorC::Zero(unknowns);
  if (unknowns > 0) {
    MatrixC lhs(unknowns, unknowns);
    VectorC b(unknowns);
    for (std::size_t j = 0; j < m; ++j) {
      const AttachmentState& as = state.now.attachment[seg.attachment_offset + rows[j].attachment];
      const auto r = static_cast<Eigen::Index>(j);
      b[r] = row_error(rows[j], as, v) - response(rows[j], 0);
      for (Eigen::Index l = 0; l < unknowns; ++l) lhs(r, l) = response(rows[j], 1 + static_cast<int>(l));
    }
    for (std::size_t c = 0; c < pc; ++c) {
      const auto r = static_cast<Eigen::Index>(m + c);
      b[r] = -separation(pairs[c], 0);
      for (Eigen::Index l = 0; l < unknowns; ++l) lhs(r, l) = separation(pairs[c], 1 + static_cast<int>(l));
      lhs(r, r) += 1.0 / pairs[c].stiffness;
    }
    x = Eigen::FullPivLU<MatrixC>(lhs).solve(b);
  }
  const VectorS dlambda = x.head(static_cast<Eigen::Index>(m));
  // The full step z = z_0 + Σ x_l z_l, folded into column 0.
  for (std::size_t k = 0; k < n; ++k)
    for (int r = 0; r < B; ++r) {
      double d = entry(k, r, 0);
      for (Eigen::Index l = 0; l < unknowns; ++l) d += x[l] * entry(k, r, 1 + static_cast<int>(l));
      entry(k, r, 0) = d;
    }

  // Trust region: scale the whole step so that no section turns or stretches too far at once.
  double worst_angle = 0.0;
  double worst_stretch = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Vector3d du(entry(k, 0, 0), entry(k, 1, 0), entry(k, 2, 0));
    worst_angle = std::max(worst_angle, du.norm() * seg.mean_section);
    worst_stretch = std::max(worst_stretch, std::abs(entry(k, 3, 0)));
  }
  if (free_base) {
    const Eigen::Vector3d dphi(entry(0, kernels::kNewtonRotation, 0), entry(0, kernels::kNewtonRotation + 1, 0),
                               entry(0, kernels::kNewtonRotation + 2, 0));
    worst_angle = std::max(worst_angle, dphi.norm());
  }
  double scale = 1.0;
  if (worst_angle > kMaxNewtonAngle) scale = std::min(scale, kMaxNewtonAngle / worst_angle);
  if (worst_stretch > kMaxNewtonStretch) scale = std::min(scale, kMaxNewtonStretch / worst_stretch);
  // No step may take a section more than halfway to collapse (ε = −1, its strain the mean of its
  // nodes'): past it the rod has no length to carry a load and Newton finds a spurious, folded-up
  // solution.
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const double shrink = -0.5 * (entry(k, 3, 0) + entry(k + 1, 3, 0));
    const double room = 1.0 + 0.5 * (v.strain.at(k, 3) + v.strain.at(k + 1, 3));
    if (shrink > 0.5 * room) scale = std::min(scale, 0.5 * room / shrink);
  }
  // Take the step; back off while a contact would deepen more than it may.
  const kernels::Pose base_before = state.now.base[segment];
  const Eigen::Vector3d dphi0(entry(0, kernels::kNewtonRotation, 0), entry(0, kernels::kNewtonRotation + 1, 0),
                              entry(0, kernels::kNewtonRotation + 2, 0));
  const Eigen::Vector3d dr0(entry(0, kernels::kNewtonPosition, 0), entry(0, kernels::kNewtonPosition + 1, 0),
                            entry(0, kernels::kNewtonPosition + 2, 0));
  for (std::size_t b = 0; b < seg.bead_count; ++b)
    ws.bead_start[b] = v.poses.node_position.get(model.beads.node[seg.bead_offset + b] - seg.node_offset);
  auto apply = [&](double factor) {
    for (std::size_t k = 0; k < n; ++k)
      for (std::size_t c = 0; c < 4; ++c) v.strain.at(k, c) += factor * entry(k, static_cast<int>(c), 0);
  };
  auto worst_deepening = [&]() {  // largest excess over the allowance, in m (≤ 0: fine)
    double worst = 0.0;
    for (std::size_t b = seg.bead_offset; b < seg.bead_offset + seg.bead_count; ++b) {
      const Eigen::Vector3d moved_b =
          v.poses.node_position.get(model.beads.node[b] - seg.node_offset) - ws.bead_start[b - seg.bead_offset];
      const double allowed = kMaxNewtonDeepening * model.beads.radius[b];
      for (std::uint32_t e = cs.bead_contact_start[b]; e < cs.bead_contact_start[b + 1]; ++e) {
        const Contact& k = cs.candidates[cs.bead_contact[e] >> 1];
        const bool second = (cs.bead_contact[e] & 1U) != 0;
        Eigen::Vector3d relative = moved_b;
        if (k.coupled) {  // both beads are this segment's: their relative motion
          const std::uint32_t mate = second ? k.bead : k.other;
          relative -= v.poses.node_position.get(model.beads.node[mate] - seg.node_offset) -
                      ws.bead_start[mate - seg.bead_offset];
        }
        const double deepening = -(second ? -1.0 : 1.0) * k.direction.dot(relative);
        worst = std::max(worst, deepening - allowed - std::max(0.0, -k.depth));  // a gap may close first
      }
    }
    return worst;
  };
  const double unsearched = scale;
  double taken = 0.0;
  for (int attempt = 0;; ++attempt) {
    apply(scale - taken);
    taken = scale;
    if (free_base) {
      kernels::Pose& base = state.now.base[segment];
      base.rotation = (kernels::rotation_exp(scale * dphi0) * base_before.rotation).normalized();
      base.position = base_before.position + scale * dr0;
    }
    if (seg.bead_count == 0 || attempt == kMaxBacktracks) break;
    kernels::rod_forward_sweep(state.now.base[segment], v.section_length, v.strain, v.poses);
    if (worst_deepening() <= 0.0) break;
    scale *= 0.5;
  }

  state.segment_step_cut[segment] = scale < unsearched ? 1 : 0;
  Eigen::Vector4d change = Eigen::Vector4d::Zero();
  for (std::size_t k = 0; k < n; ++k)
    for (std::size_t c = 0; c < 4; ++c) {
      const double d = scale * std::abs(entry(k, static_cast<int>(c), 0));
      change[static_cast<Eigen::Index>(c)] = std::max(change[static_cast<Eigen::Index>(c)], d);
    }
  for (std::size_t j = 0; j < m; ++j) {
    AttachmentState& as = state.now.attachment[seg.attachment_offset + rows[j].attachment];
    (rows[j].is_moment ? as.moment : as.force) += scale * dlambda[static_cast<Eigen::Index>(j)] * rows[j].dir;
  }
  return change;
}

void stage_filter(const WorldModel& model, WorldState& state, std::size_t segment) {
  const SegmentModel& seg = model.segments[segment];
  const SegmentViews v = segment_views(model, state, segment);
  const std::span<std::uint8_t> exempt = std::span(state.filter_exempt).subspan(seg.node_offset, seg.node_count);
  std::fill(exempt.begin(), exempt.end(), std::uint8_t{0});
  if (seg.base_mode == BaseMode::clamped) exempt[0] = 1;
  for (std::size_t a = 0; a < seg.attachments.size(); ++a)
    if (state.now.attachment[seg.attachment_offset + a].active) exempt[state.now.attachment[seg.attachment_offset + a].node] = 1;
  kernels::inertia_filter(state.frame_start.position.view().subview(seg.node_offset, seg.node_count), v.node_mass,
                          exempt, seg.info.zeta, model.dt, v.poses.node_position, v.poses.mid_position);
}

namespace {

// The lagged scheme's next frame may take a step at most this much larger than this frame's. With
// the loads held, elastic strains iterate towards a fixed point: the step must shrink. Viscous
// strains flow: a steady flow repeats its step (ratio 1), a diverging one grows it by |1 + Δt λ|,
// usually far beyond the margin allowed here. A false alarm only costs a Newton frame.
constexpr double kMaxElasticContraction = 1.0;
constexpr double kMaxViscousGrowth = 1.25;

// With the frame's loads held, the next lagged step from the new strains q would be
//   ω (k (q̂ − q) + M⁻¹ R(q)) / (k + η/Δt)
// (its q* starts at q), against this frame's step q − q_b. For elastic strains the ratio is the
// fixed-point map's contraction; for viscous ones, the growth of the explicit flow. Norm: bend and
// twist as angles per section (× h), stretch as is.
struct LaggedRatios {
  double elastic = 0.0;  // over the elastic strain components
  double viscous = 0.0;  // over the viscous and Kelvin–Voigt ones
};

LaggedRatios lagged_contraction(const WorldModel& model, WorldState& state, std::size_t segment,
                                const SubstepParameters& p) {
  const SegmentModel& seg = model.segments[segment];
  const SegmentViews v = segment_views(model, state, segment);
  const std::size_t n = seg.node_count;
  // Loads at the new configuration, with the frame's constraint forces and the base's drag.
  stage_loads(model, state, segment, p);
  add_attachment_loads(seg, state, v);
  if (seg.base_mode == BaseMode::free)
    kernels::add_rigid_drag_loads(v.poses.node_position, drag_of(model, seg), spin_drag_of(model, seg),
                                  v.poses.node_position.get(0), state.base_twist[segment], v.force, v.moment);
  kernels::rod_backward_sweep(v.poses, v.section_length, v.force, v.moment, v.generalized_force);
  kernels::mass_matrix_solve(factor_of(model, seg), v.generalized_force);
  const kernels::StrainLawCoefficients law = law_of(seg, p.dt);
  const double* before = state.strain_before_update.data() + 4 * seg.node_offset;
  const double h = seg.mean_section;
  std::array<double, 2> next2{}, step2{};  // [0] elastic, [1] viscous
  for (std::size_t k = 0; k < n; ++k)
    for (std::size_t c = 0; c < 4; ++c) {
      const std::size_t group = seg.law[c] == StrainLaw::elastic ? 0 : 1;
      const double a = law.stiffness[c] + law.rate[c];
      const double q = v.strain.at(k, c);
      const double w = c < 3 ? h : 1.0;
      const double next =
          model.solver.relaxation * (law.stiffness[c] * (v.rest.at(k, c) - q) + v.generalized_force.at(k, c)) / a * w;
      const double step = (q - before[4 * k + c]) * w;
      next2[group] += next * next;
      step2[group] += step * step;
    }
  // Below this the step is rounding: a converged rod, not a verdict.
  constexpr double kNoise = 1e-12;
  auto ratio = [&](std::size_t g) {
    return step2[g] < kNoise * kNoise * static_cast<double>(n) ? 0.0 : std::sqrt(next2[g] / step2[g]);
  };
  return {ratio(0), ratio(1)};
}

}  // namespace

// A section squeezed to a tenth of its rest length has collapsed: no tissue does that.
constexpr double kCollapsedCompression = 0.9;

double attachment_miss(const WorldModel& model, const WorldState& state, std::size_t segment, std::size_t& node) {
  const SegmentModel& seg = model.segments[segment];
  const auto pos = state.now.position.view().subview(seg.node_offset, seg.node_count);
  double worst = 0.0;
  for (std::size_t a = 0; a < seg.attachments.size(); ++a) {
    const AttachmentState& as = state.now.attachment[seg.attachment_offset + a];
    if (!as.active) continue;
    const double miss = (pos.get(as.node) - as.target).norm();
    if (miss > worst) {
      worst = miss;
      node = as.node;
    }
  }
  return worst;
}

Energy segment_energy(const WorldModel& model, std::span<const double> strain, kernels::Vec3View<const double> position,
                      std::size_t segment) {
  const SegmentModel& seg = model.segments[segment];
  const std::size_t off = seg.node_offset, n = seg.node_count;
  Energy e;
  for (std::size_t c = 0; c < 4; ++c) {
    if (seg.stiffness[c] == 0.0 || (seg.exp2 && c != 2)) continue;  // EXP2's components: below
    auto dq = [&](std::size_t k) { return strain[4 * (off + k) + c] - model.rest_strain[4 * (off + k) + c]; };
    double quad = 0.0;  // Δqᵀ M Δq with the hat functions' mass matrix
    for (std::size_t k = 0; k + 1 < n; ++k) {
      const double h = model.section_length[off + k];
      quad += h / 3.0 * (dq(k) * dq(k) + dq(k + 1) * dq(k + 1)) + h / 3.0 * dq(k) * dq(k + 1);
    }
    e.elastic += 0.5 * seg.stiffness[c] * quad;
  }
  if (seg.exp2) {
    kernels::NodalLaw law;
    law.stiffness = seg.stiffness;
    law.exp2 = true;
    law.tissue = seg.tissue;
    law.tube = seg.tube;
    e.elastic += kernels::nodal_law_exp2_energy(
        kernels::StrainView<const double>{strain.subspan(4 * off, 4 * n)},
        kernels::StrainView<const double>{std::span<const double>(model.rest_strain).subspan(4 * off, 4 * n)},
        std::span<const double>(model.section_length).subspan(off, n), law);
  }
  for (std::size_t k = 0; k < n; ++k) e.gravity -= model.node_mass[off + k] * model.gravity.dot(position.get(off + k));
  return e;
}

namespace {

// What outside work the segment may have received this frame, J, or a negative value when it
// cannot be bounded (an instrument touching it, a host load, an attachment switched on or off).
// Attachments and grasps work through the motion of the node they hold: at most the larger of the
// force at the frame's start and end times the distance the node moved (and likewise for a held
// frame's moment and turn). A clamped base, the floor and other static shapes do no work; the segment's own
// flow, the medium and the filter only take energy out.
double outside_work_bound(const WorldModel& model, const WorldState& state, std::size_t segment) {
  const SegmentModel& seg = model.segments[segment];
  double work = 0.0;
  for (std::size_t a = 0; a < seg.attachments.size(); ++a) {
    const AttachmentState& now = state.now.attachment[seg.attachment_offset + a];
    const AttachmentState& start = state.frame_start.attachment[seg.attachment_offset + a];
    if (now.active != start.active || now.node != start.node) return -1.0;
    if (!now.active) continue;
    const std::size_t node = seg.node_offset + now.node;
    const double moved = (state.now.position.view().get(node) - state.frame_start.position.view().get(node)).norm();
    work += std::max(now.force.norm(), start.force.norm()) * moved;
    if (now.hold_frame) {
      const Eigen::Quaterniond turn = state.now.rotation.view().get(node) * state.frame_start.rotation.view().get(node).conjugate();
      work += std::max(now.moment.norm(), start.moment.norm()) * kernels::rotation_log(turn).norm();
    }
  }
  // The segment's own beads' contacts (the per-bead lists), not every candidate of the world.
  const CollisionState& cs = state.collision;
  for (std::size_t b = seg.bead_offset; b < seg.bead_offset + seg.bead_count && !cs.bead_contact_start.empty(); ++b)
    for (std::uint32_t e = cs.bead_contact_start[b]; e < cs.bead_contact_start[b + 1]; ++e)
      if (cs.candidates[cs.bead_contact[e] >> 1].kind == ContactKind::instrument) return -1.0;
  const auto f = state.external_force.view();
  const auto m = state.external_moment.view();
  for (std::size_t k = seg.node_offset; k < seg.node_offset + seg.node_count; ++k)
    if (f.get(k).squaredNorm() > 0.0 || m.get(k).squaredNorm() > 0.0) return -1.0;
  return work;
}

}  // namespace

GuardResult stage_guard(const WorldModel& model, WorldState& state, std::size_t segment, const SubstepParameters& p) {
  const SegmentModel& seg = model.segments[segment];
  const SolverDesc& lim = model.solver;
  const std::size_t off = seg.node_offset;
  const std::size_t n = seg.node_count;
  const double* q = state.now.strain.data() + 4 * off;
  for (std::size_t k = 0; k < n; ++k) {
    for (std::size_t c = 0; c < 4; ++c)
      if (!std::isfinite(q[4 * k + c])) return {false, k, Stage::solve, "strain (not finite)", q[4 * k + c], 0.0};
    // Node values too: a pattern alternating from node to node averages out in every section
    // (the kinematics never see it) but is the mark of a load the solve could not take.
    if (std::abs(q[4 * k + 3]) > lim.max_axial_strain)
      return {false, k, Stage::solve, "axial strain at a node", q[4 * k + 3], lim.max_axial_strain};
  }
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const double h = model.section_length[off + k];
    const Eigen::Vector3d u(0.5 * (q[4 * k] + q[4 * k + 4]), 0.5 * (q[4 * k + 1] + q[4 * k + 5]),
                            0.5 * (q[4 * k + 2] + q[4 * k + 6]));
    const double eps = 0.5 * (q[4 * k + 3] + q[4 * k + 7]);
    if (std::abs(eps) > lim.max_axial_strain)
      return {false, k, Stage::solve, "axial strain", eps, lim.max_axial_strain};
    if (-eps > kCollapsedCompression)
      return {false, k, Stage::solve, "compression (−axial strain) of a collapsing section", -eps, kCollapsedCompression};
    if (u.norm() * h > lim.max_section_angle)
      return {false, k, Stage::solve, "bend and twist angle of one section (rad)", u.norm() * h, lim.max_section_angle};
  }
  const auto pos = state.now.position.view().subview(off, n);
  const auto prev = state.frame_start.position.view().subview(off, n);
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Vector3d r = pos.get(k);
    if (!r.allFinite()) return {false, k, Stage::forward_sweep, "node position (not finite)", r.norm(), 0.0};
    const double moved = (r - prev.get(k)).norm() / seg.info.length;
    if (moved > lim.max_displacement)
      return {false, k, Stage::forward_sweep, "displacement in one frame (segment lengths)", moved, lim.max_displacement};
  }
  // A bead deeper into the environment than its own radius has passed through, not touched.
  for (const ContactCandidate& c : state.collision.candidates) {
    if (c.kind == ContactKind::bead || model.beads.segment[c.bead] != segment) continue;
    const double ratio = c.depth / model.beads.radius[c.bead];
    if (ratio > 1.0)
      return {false, model.beads.node[c.bead] - off, Stage::contacts,
              "bead's depth into the environment (bead radii)", ratio, 1.0};
  }
  std::size_t k = 0;
  const double miss = attachment_miss(model, state, segment, k) / seg.info.length;
  if (miss > lim.max_attachment_error)
    return {false, k, Stage::constraints, "attachment's distance from its target (segment lengths)", miss,
            lim.max_attachment_error};
  // A segment that flows (a viscous or Kelvin–Voigt component) cannot gain more energy in a frame
  // than the outside worked on it: its flow, the medium and the filter (first order: it stores no
  // momentum) only take energy out. One that does has jumped to a spurious equilibrium — a soft
  // rope asked to flow far in one step curls up instead of falling; a lifted pile pins a bead deep
  // in the floor and stretches a section 150 % — and the robust mode redoes the frame with more
  // substeps, which shortens the flow. (A purely elastic rod's quasi-static solution does not depend
  // on the step, so substeps could not help it; it is not checked.) Allowance: 0.1 % of the energy
  // in play (its weight over its length), for rounding and for what penalty contacts give back.
  const bool flows = std::any_of(seg.viscosity.begin(), seg.viscosity.end(), [](double eta) { return eta > 0.0; });
  if (flows) {
    const double work = outside_work_bound(model, state, segment);
    if (work >= 0.0) {
      const double before =
          segment_energy(model, state.frame_start.strain, state.frame_start.position.view(), segment).total();
      const double after = segment_energy(model, state.now.strain, state.now.position.view(), segment).total();
      double weight = 0.0;
      for (std::size_t node = off; node < off + n; ++node) weight += model.node_mass[node];
      const double allowance =
          work + 1e-3 * (std::abs(before) + weight * model.gravity.norm() * seg.info.length) + 1e-12;
      if (after - before > allowance)
        return {false, 0, Stage::solve, "energy gained beyond the work done on it in the frame (J)", after - before,
                allowance};
    }
  }
  if (!p.newton) {
    const LaggedRatios r = lagged_contraction(model, state, segment, p);
    if (r.elastic > kMaxElasticContraction)
      return {false, 0, Stage::solve,
              "ratio of the lagged iteration's next step to this one, elastic strains (it must shrink)", r.elastic,
              kMaxElasticContraction};
    if (r.viscous > kMaxViscousGrowth)
      return {false, 0, Stage::solve, "growth of the lagged viscous flow's step from one frame to the next",
              r.viscous, kMaxViscousGrowth};
  }
  return {};
}

}  // namespace haustra::detail
