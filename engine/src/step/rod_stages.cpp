// Rod stages of the lagged scheme and the guard: loads, sweeps, the solve, constraints, filter, checks.
#include "step/rod_stages.hpp"

#include <Eigen/Dense>
#include <cmath>

#include "haustra/kernels/inertia_filter.hpp"
#include "haustra/kernels/mass_matrix.hpp"
#include "haustra/kernels/rod_backward_sweep.hpp"
#include "haustra/kernels/rod_forward_sweep.hpp"
#include "haustra/kernels/rod_loads.hpp"
#include "haustra/kernels/strain_update.hpp"
#include "haustra/kernels/tissue_law.hpp"
#include "step/anchors.hpp"
#include "step/collision.hpp"
#include "step/instruments.hpp"
#include "step/segment_law.hpp"

namespace haustra::detail {
namespace {

constexpr int kMaxRows = static_cast<int>(kMaxConstraintRows);
using MatrixS = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxRows, kMaxRows>;
using VectorS = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxRows, 1>;
using Matrix6x = Eigen::Matrix<double, 6, Eigen::Dynamic, 0, 6, kMaxRows>;

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
  kernels::assemble_node_loads(
      v.node_mass, model.gravity, state.external_force.view().subview(seg.node_offset, seg.node_count),
      state.external_moment.view().subview(seg.node_offset, seg.node_count), v.force, v.moment);
  // Contact penalties, as the collision stage last evaluated them.
  const auto bead_force = state.collision.bead_force.view();
  for (std::size_t b = seg.bead_offset; b < seg.bead_offset + seg.bead_count; ++b) {
    const std::size_t k = model.beads.node[b] - seg.node_offset;
    v.force.set(k, v.force.get(k) + bead_force.get(b));
  }
  // Coupled grasps pull their nodes towards the grasp point (at the current iterate: Newton takes
  // the coupling's stiffness too; the lagged scheme applies it as it is).
  const auto pos = state.now.position.view();
  const auto start = state.position_substep_start.view();
  for_each_coupled_grasp(state, segment, [&](std::size_t i, std::size_t node) {
    const kernels::CouplingResponse c =
        grasp_coupling(model.instruments[i], state.instruments[i], pos.get(node), start.get(node), p.dt, model.dt);
    const std::size_t k = node - seg.node_offset;
    v.force.set(k, v.force.get(k) + c.force);
  });
  // Connective tissue pulls its nodes towards where the anatomy holds them (likewise). A sleeping
  // range's nodes are held: their tissue and drag enter no solve (decision 0127).
  const HeldRange held = state.held_range(segment);
  auto asleep = [&](std::size_t k) { return held.any() && k >= held.first && k <= held.last; };
  for_each_intact_anchor(model, state, segment, [&](std::size_t a, std::size_t node) {
    const std::size_t k = node - seg.node_offset;
    if (asleep(k)) return;
    v.force.set(k, v.force.get(k) + anchor_response(model, state, a, p.dt).force);
    if (model.anchors.turn_stiffness[a] > 0.0)
      v.moment.set(k, v.moment.get(k) + anchor_turn(model, state, a, p.dt).moment);
  });
  if (!p.newton) return;
  // Newton solves for increments of the constraint forces; their current totals are loads.
  add_attachment_loads(seg, state, v);
  if (!seg.has_drag) return;
  const auto r0 = state.position_substep_start.view().subview(seg.node_offset, seg.node_count);
  const auto q0 = state.rotation_substep_start.view().subview(seg.node_offset, seg.node_count);
  const std::span<const double> c = drag_of(model, seg);
  const std::span<const double> sd = spin_drag_of(model, seg);
  for (std::size_t k = 0; k < seg.node_count; ++k) {
    if (asleep(k)) k = held.last + 1;
    if (k == seg.node_count) break;
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
  const kernels::Matrix6d c =
      kernels::rigid_drag_resistance(v.poses.node_position, drag_of(model, seg), spin_drag_of(model, seg), origin);
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
  return kernels::strain_update(v.generalized_force, v.rest, v.strain_start, law_of(seg, p.dt), {w, w, w, w}, v.strain);
}

void stage_forward_sweep(const WorldModel& model, WorldState& state, std::size_t segment) {
  const SegmentViews v = segment_views(model, state, segment);
  kernels::rod_forward_sweep(state.now.base[segment], v.section_length, v.strain, v.poses);
}

// One function of ~100 lines on purpose: one Schur-complement solve whose steps (J's rows, the free
// base's mobility, the responses Y, S = J Y, the error, λ, and the update) share the rows and the
// scratch blocks; each step is marked below.
void stage_constraints(const WorldModel& model, WorldState& state, std::size_t segment, const SubstepParameters& p) {
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
  auto g_row = [&](std::size_t j) {
    return kernels::StrainView<double>{std::span<double>(scratch + 4 * n * j, 4 * n)};
  };
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

void stage_filter(const WorldModel& model, WorldState& state, std::size_t segment) {
  const SegmentModel& seg = model.segments[segment];
  const SegmentViews v = segment_views(model, state, segment);
  const std::span<std::uint8_t> exempt = std::span(state.filter_exempt).subspan(seg.node_offset, seg.node_count);
  std::fill(exempt.begin(), exempt.end(), std::uint8_t{0});
  if (seg.base_mode == BaseMode::clamped) exempt[0] = 1;
  if (const HeldRange held = state.held_range(segment); held.any())  // a sleeping range (decision 0127)
    std::fill(exempt.begin() + static_cast<std::ptrdiff_t>(held.first),
              exempt.begin() + static_cast<std::ptrdiff_t>(held.last + 1), std::uint8_t{1});
  for (std::size_t a = 0; a < seg.attachments.size(); ++a)
    if (state.now.attachment[seg.attachment_offset + a].active)
      exempt[state.now.attachment[seg.attachment_offset + a].node] = 1;
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

void stage_lagged_contraction(const WorldModel& model, WorldState& state, std::size_t segment,
                              const SubstepParameters& p) {
  state.lagged_ratios[segment] = lagged_contraction(model, state, segment, p);
}

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

Energy segment_energy(const WorldModel& model, const WorldState& state, std::span<const double> strain,
                      kernels::Vec3View<const double> position, kernels::RotationView<const double> rotation,
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
  e.tissue = anchor_energy(model, state, position, rotation, segment);
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
      const Eigen::Quaterniond turn =
          state.now.rotation.view().get(node) * state.frame_start.rotation.view().get(node).conjugate();
      work += std::max(now.moment.norm(), start.moment.norm()) * kernels::rotation_log(turn).norm();
    }
  }
  // A coupled grasp pulls with at most its force limit along the node's way.
  for (std::size_t i = 0; i < state.instruments.size(); ++i) {
    const InstrumentState& s = state.instruments[i];
    if (!s.grasping || !s.coupled || s.grasp_segment != segment) continue;
    const double moved =
        (state.now.position.view().get(s.grasp_node) - state.frame_start.position.view().get(s.grasp_node)).norm();
    work += model.instruments[i].force_limit * moved;
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

// A Newton frame whose condensed sweep met a singular pivot on a rod too long for the fallback.
GuardResult guard_solvable(const WorldModel& /*model*/, const WorldState& state, std::size_t segment,
                           const SubstepParameters& p) {
  if (p.newton && state.segment_solvable[segment] == 0)
    return {false,
            state.newton[segment].singular_node,
            Stage::condense,
            "pivot of the condensed Newton sweep too small relative to its row (a singular, buckled state), on a "
            "rod longer than the banded fallback holds (4096 nodes)",
            0.0,
            0.0};
  return {};
}

// Every strain finite; axial strain, compression and the angle of each section within limits.
GuardResult guard_strains(const WorldModel& model, const WorldState& state, std::size_t segment,
                          const SubstepParameters& /*p*/) {
  const SegmentModel& seg = model.segments[segment];
  const std::size_t off = seg.node_offset;
  const std::size_t n = seg.node_count;
  const double* q = state.now.strain.data() + 4 * off;
  for (std::size_t k = 0; k < n; ++k) {
    for (std::size_t c = 0; c < 4; ++c)
      if (!std::isfinite(q[4 * k + c])) return {false, k, Stage::solve, "strain (not finite)", q[4 * k + c], 0.0};
    // Node values too: a pattern alternating from node to node averages out in every section
    // (the kinematics never see it) but is the mark of a load the solve could not take.
    if (std::abs(q[4 * k + 3]) > kMaxAxialStrain)
      return {false, k, Stage::solve, "axial strain at a node", q[4 * k + 3], kMaxAxialStrain};
  }
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const double h = model.section_length[off + k];
    const Eigen::Vector3d u(0.5 * (q[4 * k] + q[4 * k + 4]), 0.5 * (q[4 * k + 1] + q[4 * k + 5]),
                            0.5 * (q[4 * k + 2] + q[4 * k + 6]));
    const double eps = 0.5 * (q[4 * k + 3] + q[4 * k + 7]);
    if (std::abs(eps) > kMaxAxialStrain) return {false, k, Stage::solve, "axial strain", eps, kMaxAxialStrain};
    if (-eps > kCollapsedCompression)
      return {
          false, k, Stage::solve, "compression (−axial strain) of a collapsing section", -eps, kCollapsedCompression};
    if (u.norm() * h > kMaxSectionAngle)
      return {false, k, Stage::solve, "bend and twist angle of one section (rad)", u.norm() * h, kMaxSectionAngle};
  }
  return {};
}

// Every node finite and moved less than the limit in the frame.
GuardResult guard_positions(const WorldModel& model, const WorldState& state, std::size_t segment,
                            const SubstepParameters& /*p*/) {
  const SegmentModel& seg = model.segments[segment];
  const SolverModel& lim = model.solver;
  const std::size_t off = seg.node_offset;
  const std::size_t n = seg.node_count;
  const auto pos = state.now.position.view().subview(off, n);
  const auto prev = state.frame_start.position.view().subview(off, n);
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Vector3d r = pos.get(k);
    if (!r.allFinite()) return {false, k, Stage::forward_sweep, "node position (not finite)", r.norm(), 0.0};
    const double moved = (r - prev.get(k)).norm() / seg.info.length;
    if (moved > lim.max_displacement)
      return {
          false, k, Stage::forward_sweep, "displacement in one frame (segment lengths)", moved, lim.max_displacement};
  }
  return {};
}

GuardResult guard_bead_depths(const WorldModel& model, const WorldState& state, std::size_t segment,
                              const SubstepParameters& /*p*/) {
  const SegmentModel& seg = model.segments[segment];
  const std::size_t off = seg.node_offset;
  // A bead deeper into the environment than its own radius has passed through, not touched.
  // (Through the segment's own beads' lists: every candidate of the world per segment would be
  // quadratic in segments.)
  const CollisionState& cs = state.collision;
  for (std::size_t b = seg.bead_offset; b < seg.bead_offset + seg.bead_count && !cs.bead_contact_start.empty(); ++b)
    for (std::uint32_t e = cs.bead_contact_start[b]; e < cs.bead_contact_start[b + 1]; ++e) {
      const ContactCandidate& c = cs.candidates[cs.bead_contact[e] >> 1];
      if (c.kind == ContactKind::bead) continue;
      const double ratio = c.depth / model.beads.radius[c.bead];
      // A bead a container holds that was already out at the frame's start (however far) is
      // being pushed back: it passed through nothing in this frame unless it went deeper.
      if (ratio > 1.0 && held_by_container(model, c) && c.depth <= depth_at_frame_start(model, state, c)) continue;
      if (ratio > 1.0)  // an instrument's capsule is named as such, not as the environment
        return {false,
                model.beads.node[c.bead] - off,
                Stage::contacts,
                c.kind == ContactKind::instrument ? "bead's depth into an instrument's capsule (bead radii)"
                                                  : "bead's depth into the environment (bead radii)",
                ratio,
                1.0};
    }
  return {};
}

GuardResult guard_attachments(const WorldModel& model, const WorldState& state, std::size_t segment,
                              const SubstepParameters& /*p*/) {
  const SegmentModel& seg = model.segments[segment];
  std::size_t k = 0;
  const double miss = attachment_miss(model, state, segment, k) / seg.info.length;
  if (miss > kMaxAttachmentError)
    return {false,
            k,
            Stage::constraints,
            "attachment's distance from its target (segment lengths)",
            miss,
            kMaxAttachmentError};
  return {};
}

GuardResult guard_energy(const WorldModel& model, const WorldState& state, std::size_t segment,
                         const SubstepParameters& /*p*/) {
  const SegmentModel& seg = model.segments[segment];
  const std::size_t off = seg.node_offset;
  const std::size_t n = seg.node_count;
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
    double work = outside_work_bound(model, state, segment);
    if (work >= 0.0) {
      work += container_release(model, state, segment);  // pushing a bead back in works on the rod
      const double before = segment_energy(model, state, state.frame_start.strain, state.frame_start.position.view(),
                                           state.frame_start.rotation.view(), segment)
                                .total();
      const double after =
          segment_energy(model, state, state.now.strain, state.now.position.view(), state.now.rotation.view(), segment)
              .total();
      double weight = 0.0;
      for (std::size_t node = off; node < off + n; ++node) weight += model.node_mass[node];
      const double allowance =
          work + 1e-3 * (std::abs(before) + weight * model.gravity.norm() * seg.info.length) + 1e-12;
      if (after - before > allowance)
        return {false,          0,        Stage::solve, "energy gained beyond the work done on it in the frame (J)",
                after - before, allowance};
    }
  }
  return {};
}

// Newton's line search took nothing of a step that was not small: the frame made no progress
// towards its solution, though with no change it looks converged (a load the solve cannot carry).
GuardResult guard_newton_progress(const WorldModel& /*model*/, const WorldState& state, std::size_t segment,
                                  const SubstepParameters& p) {
  if (p.newton && state.newton[segment].stalled)
    return {false,
            0,
            Stage::line_search,
            "no progress: no fraction of the Newton step lowered the frame's potential, even with the law stiffened",
            0.0,
            0.0};
  return {};
}

// The lagged iteration contracting: its next step smaller than this one, its flow not growing.
GuardResult guard_lagged_iteration(const WorldModel& /*model*/, const WorldState& state, std::size_t segment,
                                   const SubstepParameters& p) {
  if (!p.newton) {
    const LaggedRatios& r = state.lagged_ratios[segment];
    if (r.elastic > kMaxElasticContraction)
      return {false,        0,
              Stage::solve, "ratio of the lagged iteration's next step to this one, elastic strains (it must shrink)",
              r.elastic,    kMaxElasticContraction};
    if (r.viscous > kMaxViscousGrowth)
      return {false,        0,
              Stage::solve, "growth of the lagged viscous flow's step from one frame to the next",
              r.viscous,    kMaxViscousGrowth};
  }
  return {};
}

}  // namespace

GuardResult stage_guard(const WorldModel& model, WorldState& state, std::size_t segment, const SubstepParameters& p) {
  for (const auto check : {guard_solvable, guard_strains, guard_positions, guard_bead_depths, guard_attachments,
                           guard_energy, guard_newton_progress, guard_lagged_iteration}) {
    const GuardResult r = check(model, state, segment, p);
    if (!r.ok) return r;
  }
  return {};
}

void stage_snapshot(const WorldModel& model, WorldState& state, std::size_t segment, bool newton) {
  const SegmentModel& seg = model.segments[segment];
  const auto off = static_cast<std::ptrdiff_t>(seg.node_offset);
  const auto cnt = static_cast<std::ptrdiff_t>(seg.node_count);
  std::copy_n(state.now.strain.begin() + 4 * off, 4 * cnt, state.strain_substep_start.begin() + 4 * off);
  const auto copy = [&](std::span<const double> from, std::span<double> to) {
    std::copy_n(from.begin() + off, cnt, to.begin() + off);
  };
  // Every velocity of a substep is measured from here: the medium's drag, but also the dampers of
  // grasps and anchors, which a rod without drag has as well.
  copy(state.now.position.x, state.position_substep_start.x);
  copy(state.now.position.y, state.position_substep_start.y);
  copy(state.now.position.z, state.position_substep_start.z);
  if (seg.has_drag || seg.anchor_count > 0) {  // the spin drag's and the anchors' turn dampers
    copy(state.now.rotation.w, state.rotation_substep_start.w);
    copy(state.now.rotation.x, state.rotation_substep_start.x);
    copy(state.now.rotation.y, state.rotation_substep_start.y);
    copy(state.now.rotation.z, state.rotation_substep_start.z);
  }
  state.base_substep_start[segment] = state.now.base[segment];
  state.segment_converged[segment] = state.rod_asleep[segment];  // a sleeping rod is not solved (0119)
  if (newton) state.newton[segment].stalled = false;
  if (!state.newton.empty()) state.newton[segment].poses_swept = false;  // until a line search sweeps
  state.segment_solvable[segment] = 1;
}

bool iteration_converged(const WorldModel& model, const WorldState& state, std::size_t segment, bool past_fixed_count) {
  const Eigen::Vector4d& d = state.segment_change[segment];
  const double moved = std::max(d.head<3>().maxCoeff() * model.segments[segment].mean_section, d[3]);
  if (moved <= model.solver.tolerance) return true;
  // Past the fixed count, Newton goes on only where a contact cut its step short or an attachment
  // is still off target.
  std::size_t node = 0;
  return past_fixed_count && state.segment_step_cut[segment] == 0 &&
         attachment_miss(model, state, segment, node) <= kAttachmentTolerance;
}

}  // namespace haustra::detail
