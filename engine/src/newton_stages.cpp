// The Newton stages of a frame, one segment at a time: linearize and condense (the jacobian
// stage), then solve and step (the solve stage) and the line search on the frame's incremental
// potential (the line_search stage). Named steps, in the order a Newton iteration takes them.
#include <algorithm>
#include <cmath>

#include "collision.hpp"
#include "haustra/kernels/block_tridiagonal.hpp"
#include "haustra/kernels/rod_backward_sweep.hpp"
#include "haustra/kernels/rod_condensed.hpp"
#include "haustra/kernels/rod_forward_sweep.hpp"
#include "haustra/kernels/rod_newton.hpp"
#include "newton_stages.hpp"
#include "segment_law.hpp"

namespace haustra::detail {
namespace {

constexpr int kMaxCoupled = static_cast<int>(kMaxConstraintRows + kMaxCoupledContacts);
using MatrixC = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxCoupled, kMaxCoupled>;
using VectorC = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxCoupled, 1>;

// Newton steps are scaled down to stay within these per iteration (a trust region): beyond them
// the linearization says little about the rod.
constexpr double kMaxNewtonAngle = 0.5;  // rad of bend or twist per section
constexpr double kMaxNewtonStretch = 0.25;
// ... and so that no contact gets deeper by more than this fraction of its bead's radius: a
// penalty's stiffness grows with depth, so the tangent at the surface lets a bead sink far too far.
constexpr double kMaxNewtonDeepening = 0.1;
// The line search: sufficient decrease (Armijo) of the incremental potential, halving the step.
constexpr double kArmijo = 1e-4;
constexpr int kMaxBacktracks = 10;
// Where the Newton step is not a descent direction, the law's rows are stiffened by this factor
// and the system solved again, up to this many times (8⁶ ≈ 2.6·10⁵ × the law: a small
// law-weighted gradient step).
constexpr double kStiffening = 8.0;
constexpr int kMaxStiffenings = 6;
// A potential is a sum of large terms (weight × height); differences below this fraction of their
// magnitude are rounding, and the O(h²) difference between the backward sweep's generalized forces
// and the exact gradient: such a step is taken as not raising the potential.
constexpr double kPotentialRounding = 1e-10;

// A coupled contact pair: two beads of the segment, solved as one unknown force.
struct Pair {
  std::size_t a = 0, b = 0;  // local nodes
  Eigen::Vector3d n = Eigen::Vector3d::UnitZ();  // separating direction, towards a
  double stiffness = 0.0;
};

struct Coupled {
  ConstraintRows rows{};
  std::size_t m = 0;  // constraint rows
  std::array<Pair, kMaxCoupledContacts> pairs{};
  std::size_t pc = 0;  // coupled pairs
  [[nodiscard]] int columns() const { return 1 + static_cast<int>(m + pc); }
};

Coupled coupled_unknowns(const WorldModel& model, const WorldState& state, std::size_t segment) {
  const SegmentModel& seg = model.segments[segment];
  Coupled c;
  c.m = seg.constraint_rows > 0 ? active_constraint_rows(seg, state, c.rows) : 0;
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
  const bool has_stiffness = seg.has_drag || seg.bead_count > 0;
  if (has_stiffness) {
    const std::span<const double> c = drag_of(model, seg);
    const std::span<const double> sd = spin_drag_of(model, seg);
    for (std::size_t k = 0; k < n; ++k) {
      ws.force_stiffness[k] = (c[k] / p.dt) * Eigen::Matrix3d::Identity();
      ws.drag_moment_rate[k] = sd[k] / p.dt;
    }
    for (std::size_t b = seg.bead_offset; b < seg.bead_offset + seg.bead_count; ++b)
      ws.force_stiffness[model.beads.node[b] - seg.node_offset] += state.collision.bead_stiffness[b];
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
    ws.loads.push_back({static_cast<std::uint32_t>(c.rows[j].node), static_cast<std::uint32_t>(1 + j), c.rows[j].is_moment,
                        c.rows[j].dir});
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
        ws.responses[(r * static_cast<std::size_t>(cols) + static_cast<std::size_t>(col)) * 6 + static_cast<std::size_t>(i)] =
            entry(ws.response_nodes[r], kernels::kNewtonRotation + i, col);
}

// Step 4 for the banded path: the step Σ weight_c column_c into the step buffers.
void band_step(NewtonWorkspace& ws, std::size_t n, int cols) {
  constexpr int B = kernels::kNewtonBlock;
  const auto stride = static_cast<std::size_t>(B * cols);
  for (std::size_t k = 0; k < n; ++k) {
    double z[B] = {};
    for (int col = 0; col < cols; ++col)
      for (int r = 0; r < B; ++r) z[r] += ws.weights[static_cast<std::size_t>(col)] * ws.rhs[k * stride + static_cast<std::size_t>(col * B + r)];
    for (std::size_t i = 0; i < 4; ++i) ws.step_q[4 * k + i] = z[i];
    ws.step_phi.view().set(k, {z[kernels::kNewtonRotation], z[kernels::kNewtonRotation + 1], z[kernels::kNewtonRotation + 2]});
    ws.step_r.view().set(k, {z[kernels::kNewtonPosition], z[kernels::kNewtonPosition + 1], z[kernels::kNewtonPosition + 2]});
  }
}

// Step 3: the coupled unknowns. Constraint rows hold their targets; each coupled contact's force
// change follows its separation, δf = −k n·(δr_a − δr_b). Writes the column weights (1, then the
// unknowns) and returns the constraint rows' force changes through `dlambda`.
void coupled_multipliers(const WorldModel& model, const WorldState& state, std::size_t segment, const Coupled& c,
                         const SegmentViews& v, NewtonWorkspace& ws, VectorC& x) {
  const SegmentModel& seg = model.segments[segment];
  const int cols = c.columns();
  auto at = [&](std::size_t node) {
    return static_cast<std::size_t>(std::lower_bound(ws.response_nodes.begin(), ws.response_nodes.end(), node) -
                                    ws.response_nodes.begin());
  };
  auto moved = [&](std::size_t node, const Eigen::Vector3d& dir, bool rotation, int col) {
    const double* r = ws.responses.data() + (at(node) * static_cast<std::size_t>(cols) + static_cast<std::size_t>(col)) * 6 +
                      (rotation ? 0 : 3);
    return dir.x() * r[0] + dir.y() * r[1] + dir.z() * r[2];
  };
  auto separation = [&](const Pair& pr, int col) { return moved(pr.a, pr.n, false, col) - moved(pr.b, pr.n, false, col); };
  auto column = [&](Eigen::Index l) { return static_cast<int>(ws.column_of[static_cast<std::size_t>(1 + l)]); };
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
    b[r] = row_error(row, as, v) - moved(row.node, row.dir, row.is_moment, 0);
    for (Eigen::Index l = 0; l < unknowns; ++l) lhs(r, l) = moved(row.node, row.dir, row.is_moment, column(l));
  }
  for (std::size_t i = 0; i < c.pc; ++i) {
    const auto r = static_cast<Eigen::Index>(c.m + i);
    b[r] = -separation(c.pairs[i], 0);
    for (Eigen::Index l = 0; l < unknowns; ++l) lhs(r, l) = separation(c.pairs[i], column(l));
    lhs(r, r) += 1.0 / c.pairs[i].stiffness;
  }
  x = Eigen::FullPivLU<MatrixC>(lhs).solve(b);
  for (Eigen::Index l = 0; l < unknowns; ++l) ws.weights[static_cast<std::size_t>(column(l))] = x[l];
}

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

// Step 3: the system condensed (or, where the sweep's pivots are unsafe, factored by the banded
// LU) at the law's scale. False: neither can solve it.
bool condense(const WorldModel& model, WorldState& state, std::size_t segment, const SubstepParameters& p,
              const Coupled& c, double law_scale) {
  const SegmentModel& seg = model.segments[segment];
  NewtonWorkspace& ws = state.newton[segment];
  const bool has_stiffness = seg.has_drag || seg.bead_count > 0;
  const SegmentViews v = segment_views(model, state, segment);
  kernels::RodLinearization lin = linearization_of(seg, v, ws, p, has_stiffness);
  lin.law_scale = law_scale;
  const kernels::CondensedSystem sys{ws.gain, ws.scratch, ws.base_solution, c.columns()};
  const kernels::CondenseReport report =
      kernels::rod_condense(lin, kernels::StrainView<const double>{ws.residual}, ws.loads, sys);
  ws.band = !report.ok;
  ws.law_scale = law_scale;
  if (report.ok) return true;
  ws.singular_node = report.node;
  if (!ws.band_available) return false;
  ++ws.fallbacks;
  band_solve(model, state, segment, p, c, has_stiffness, law_scale);
  return true;
}

// Step 4: responses at the coupled unknowns' nodes, the coupled system, then the combined step.
void solve_step(const WorldModel& model, WorldState& state, std::size_t segment, const SubstepParameters& p,
                const Coupled& c, VectorC& x) {
  const SegmentModel& seg = model.segments[segment];
  const SegmentViews v = segment_views(model, state, segment);
  NewtonWorkspace& ws = state.newton[segment];
  const int cols = c.columns();
  kernels::RodLinearization lin = linearization_of(seg, v, ws, p, seg.has_drag || seg.bead_count > 0);
  lin.law_scale = ws.law_scale;
  const kernels::CondensedSystem sys{ws.gain, ws.scratch, ws.base_solution, cols};
  if (!ws.band && !ws.response_nodes.empty())
    kernels::rod_condensed_responses(lin, sys, ws.response_nodes, ws.responses);
  coupled_multipliers(model, state, segment, c, v, ws, x);
  if (ws.band)
    band_step(ws, seg.node_count, cols);
  else
    kernels::rod_condensed_step(lin, sys, ws.weights, kernels::StrainView<double>{ws.step_q}, ws.step_phi.view(),
                                ws.step_r.view());
}

}  // namespace

bool stage_newton_jacobian(const WorldModel& model, WorldState& state, std::size_t segment, const SubstepParameters& p) {
  NewtonWorkspace& ws = state.newton[segment];
  linearize(model, state, segment, p);
  const Coupled c = coupled_unknowns(model, state, segment);
  unit_loads(c, ws);
  return condense(model, state, segment, p, c, 1.0);
}

namespace {

// The incremental potential of the frame's implicit step at the current strains and poses: the
// law's energy (elastic and viscous: ½ Δqᵀ A Δq about its target), weight and host forces, the
// medium's drag (c/2Δt |r − r_start|², s/2Δt |turn|²) and the contact penalties.
double incremental_potential(const WorldModel& model, const WorldState& state, std::size_t segment,
                             const SubstepParameters& p) {
  const SegmentModel& seg = model.segments[segment];
  const NewtonWorkspace& ws = state.newton[segment];
  const std::size_t off = seg.node_offset, n = seg.node_count;
  const double* q = state.now.strain.data() + 4 * off;
  double law = 0.0;
  const kernels::StrainLawCoefficients coefficients = law_of(seg, p.dt);
  const std::array<double, 4> a = law_total(seg, p.dt);
  for (std::size_t comp = 0; comp < 4; ++comp) {
    const bool exp2_elastic = seg.exp2 && comp != 2;
    // Hooke: ½ a (q − q*)ᵀ M (q − q*); EXP2 bending and stretch: their viscous part here, the
    // elastic part below.
    const double weight = exp2_elastic ? coefficients.rate[comp] : a[comp];
    if (weight == 0.0) continue;
    auto dq = [&](std::size_t k) {
      const double centre = exp2_elastic ? state.strain_substep_start[4 * (off + k) + comp] : ws.target[4 * k + comp];
      return q[4 * k + comp] - centre;
    };
    double quad = 0.0;
    for (std::size_t k = 0; k + 1 < n; ++k) {
      const double h = model.section_length[off + k];
      const double x0 = dq(k), x1 = dq(k + 1);
      quad += h / 3.0 * (x0 * x0 + x1 * x1 + x0 * x1);
    }
    law += 0.5 * weight * quad;
  }
  if (seg.exp2) {
    kernels::NodalLaw nl;
    nl.stiffness = seg.stiffness;
    nl.exp2 = true;
    nl.tissue = seg.tissue;
    nl.tube = seg.tube;
    const kernels::StrainView<const double> strain{std::span<const double>(q, 4 * n)};
    const kernels::StrainView<const double> rest{std::span<const double>(model.rest_strain).subspan(4 * off, 4 * n)};
    law += kernels::nodal_law_exp2_energy(strain, rest, std::span<const double>(model.section_length).subspan(off, n), nl);
    // (Torsion stays Hooke's: its elastic part is in the quadratic above through a[2].)
  }
  double loads = 0.0;
  const auto pos = state.now.position.view();
  const auto rot = state.now.rotation.view();
  const auto fext = state.external_force.view();
  const auto r0 = state.position_substep_start.view();
  const auto q0 = state.rotation_substep_start.view();
  const std::span<const double> drag = drag_of(model, seg), spin = spin_drag_of(model, seg);
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t g = off + k;
    const Eigen::Vector3d r = pos.get(g);
    loads -= (model.node_mass[g] * model.gravity + fext.get(g)).dot(r);
    if (seg.has_drag) {
      if (spin[k] > 0.0)
        loads += 0.5 * spin[k] / p.dt * kernels::rotation_angle_squared(rot.get(g) * q0.get(g).conjugate());
      loads += 0.5 * drag[k] / p.dt * (r - r0.get(g)).squaredNorm();
    }
  }
  if (seg.bead_count > 0) loads += segment_contact_potential(model, state, segment, ws.bead_start);
  return law + loads;
}

// The attachments' part of the merit: the Lagrangian term of the constraint forces after the step
// and an exact penalty, Σ λ_j e_j + μ |e_j|.
double attachment_merit(const WorldModel& model, const WorldState& state, std::size_t segment, const Coupled& c,
                        const VectorC& lambda, double mu) {
  const SegmentModel& seg = model.segments[segment];
  const auto pos = state.now.position.view();
  const auto rot = state.now.rotation.view();
  double merit = 0.0;
  for (std::size_t j = 0; j < c.m; ++j) {
    const ConstraintRow& row = c.rows[j];
    const AttachmentState& as = state.now.attachment[seg.attachment_offset + row.attachment];
    const double e = row_error(row, as, pos.get(seg.node_offset + row.node), rot.get(seg.node_offset + row.node));
    merit += lambda[static_cast<Eigen::Index>(j)] * e + mu * std::abs(e);
  }
  return merit;
}

// The scale of the potential's terms (the segment's weight over its length), for what counts as
// rounding.
double potential_scale(const WorldModel& model, std::size_t segment) {
  const SegmentModel& seg = model.segments[segment];
  double weight = 0.0;
  for (std::size_t k = seg.node_offset; k < seg.node_offset + seg.node_count; ++k) weight += model.node_mass[k];
  return weight * model.gravity.norm() * seg.info.length + 1e-12;
}

}  // namespace

void stage_newton_solve(const WorldModel& model, WorldState& state, std::size_t segment, const SubstepParameters& p) {
  const SegmentModel& seg = model.segments[segment];
  for (std::size_t at = 0; at < seg.attachments.size(); ++at) {
    AttachmentState& as = state.now.attachment[seg.attachment_offset + at];
    if (!as.active) {
      as.force.setZero();
      as.moment.setZero();
    }
  }
  VectorC x;
  solve_step(model, state, segment, p, coupled_unknowns(model, state, segment), x);
}

void stage_newton_line_search(const WorldModel& model, WorldState& state, std::size_t segment,
                              const SubstepParameters& p) {
  const SegmentModel& seg = model.segments[segment];
  const SegmentViews v = segment_views(model, state, segment);
  NewtonWorkspace& ws = state.newton[segment];
  const std::size_t n = seg.node_count;
  const bool free_base = seg.base_mode == BaseMode::free;
  const Coupled c = coupled_unknowns(model, state, segment);
  VectorC x(static_cast<Eigen::Index>(c.m + c.pc));
  for (Eigen::Index l = 0; l < x.size(); ++l) x[l] = ws.weights[ws.column_of[static_cast<std::size_t>(1 + l)]];
  // The free base's unbalanced wrench (for the slope): the total load about node 0.
  kernels::Vector6d wrench = kernels::Vector6d::Zero();
  if (free_base) wrench = kernels::total_wrench(v.poses.node_position, v.force, v.moment, v.poses.node_position.get(0));

  // The first iterate of a frame starts from the filtered node positions, which the strains do not
  // reproduce: weigh the start on the strains' own shape.
  if (p.iteration == 0 && model.filter.enabled)
    kernels::rod_forward_sweep(state.now.base[segment], v.section_length, v.strain, v.poses);
  std::copy(v.strain.data.begin(), v.strain.data.end(), ws.strain_before.begin());
  ws.base_before = state.now.base[segment];
  for (std::size_t b = 0; b < seg.bead_count; ++b)
    ws.bead_start[b] = v.poses.node_position.get(model.beads.node[seg.bead_offset + b] - seg.node_offset);
  auto take = [&](double alpha) {
    for (std::size_t i = 0; i < 4 * n; ++i) v.strain.data[i] = ws.strain_before[i] + alpha * ws.step_q[i];
    if (free_base) {
      kernels::Pose& base = state.now.base[segment];
      base.rotation = (kernels::rotation_exp(alpha * ws.step_phi.view().get(0)) * ws.base_before.rotation).normalized();
      base.position = ws.base_before.position + alpha * ws.step_r.view().get(0);
    }
    kernels::rod_forward_sweep(state.now.base[segment], v.section_length, v.strain, v.poses);
  };
  const CollisionState& cs = state.collision;
  auto deepens_too_far = [&]() {
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
        if (deepening - allowed - std::max(0.0, -k.depth) > 0.0) return true;  // a gap may close first
      }
    }
    return false;
  };

  double alpha = 0.0;
  bool accepted = false;
  VectorC lambda;
  for (int stiffened = 0;; ++stiffened) {
    // The slope of the merit along the full step: −ρ·δq − W·δbase for the potential, and for the
    // attachments −Δλ·e − μ|e| (the step meets every constraint to first order), with λ the
    // constraint forces after the step and μ ≥ |λ| the exact penalty's weight.
    lambda = VectorC::Zero(static_cast<Eigen::Index>(c.m));
    double mu = 0.0, slope = 0.0;
    for (std::size_t i = 0; i < 4 * n; ++i) slope -= ws.residual[i] * ws.step_q[i];
    if (free_base) slope -= wrench.head<3>().dot(ws.step_phi.view().get(0)) + wrench.tail<3>().dot(ws.step_r.view().get(0));
    for (std::size_t j = 0; j < c.m; ++j) {
      const AttachmentState& as = state.now.attachment[seg.attachment_offset + c.rows[j].attachment];
      const auto r = static_cast<Eigen::Index>(j);
      lambda[r] = c.rows[j].dir.dot(c.rows[j].is_moment ? as.moment : as.force) + x[r];
      mu = std::max(mu, std::abs(lambda[r]));
    }
    for (std::size_t j = 0; j < c.m; ++j) {
      const double e = row_error(c.rows[j], state.now.attachment[seg.attachment_offset + c.rows[j].attachment], v);
      slope -= x[static_cast<Eigen::Index>(j)] * e + mu * std::abs(e);
    }
    const bool last_try = stiffened == kMaxStiffenings;
    if (slope < 0.0 || last_try) {
      // From the trust region's scale, halve until the merit decreases enough and no contact
      // deepens more than it may. A host's moments are dead loads without a potential (their
      // work depends on the path; the rotation's logarithm wraps past half a turn): along the
      // step they do the work α m·δφ of its linearized rotation, as the slope counts them. The
      // potential at the start is the last iterate's accepted one where nothing else changed
      // since (one rod: no other segment's beads moved; the same substep).
      double moment_work = 0.0;
      const auto mext = state.external_moment.view();
      for (std::size_t k = 0; k < n; ++k) moment_work += mext.get(seg.node_offset + k).dot(ws.step_phi.view().get(k));
      const bool cached = ws.potential_cached && p.iteration > 0 && stiffened == 0 && model.segments.size() == 1;
      const double potential0 = cached ? ws.potential : incremental_potential(model, state, segment, p);
      const double merit0 = potential0 + attachment_merit(model, state, segment, c, lambda, mu);
      const double rounding = kPotentialRounding * (std::abs(merit0) + potential_scale(model, segment));
      alpha = trust_scale(seg, v, ws);
      for (int attempt = 0; attempt <= kMaxBacktracks; ++attempt) {
        take(alpha);
        if (seg.bead_count == 0 || !deepens_too_far()) {
          const double potential = incremental_potential(model, state, segment, p);
          const double merit = potential - alpha * moment_work + attachment_merit(model, state, segment, c, lambda, mu);
          if (merit <= merit0 + kArmijo * alpha * std::min(slope, 0.0) + rounding) {
            accepted = true;
            ws.potential = potential;
            break;
          }
        }
        if (attempt < kMaxBacktracks) {
          alpha *= 0.5;
          ++ws.backtracks;
        }
      }
      if (accepted || last_try) break;
      take(0.0);
    }
    // Not a descent direction (the loads make the potential indefinite), or none of its fractions
    // lowered the merit: stiffen the law's rows and solve again, towards the law-weighted
    // gradient step.
    ++ws.stiffenings;
    if (!condense(model, state, segment, p, c, ws.law_scale * kStiffening)) break;
    solve_step(model, state, segment, p, c, x);
  }
  ws.potential_cached = accepted;
  if (!accepted) {  // nothing lowers the merit: stay (the next iteration relinearizes)
    alpha = 0.0;
    take(0.0);
  }
  state.segment_step_cut[segment] = alpha < 1.0 ? 1 : 0;
  Eigen::Vector4d& change = state.segment_change[segment];
  change.setZero();
  for (std::size_t k = 0; k < n; ++k)
    for (std::size_t comp = 0; comp < 4; ++comp) {
      const double d = alpha * std::abs(ws.step_q[4 * k + comp]);
      change[static_cast<Eigen::Index>(comp)] = std::max(change[static_cast<Eigen::Index>(comp)], d);
    }
  for (std::size_t j = 0; j < c.m; ++j) {
    AttachmentState& as = state.now.attachment[seg.attachment_offset + c.rows[j].attachment];
    (c.rows[j].is_moment ? as.moment : as.force) += alpha * x[static_cast<Eigen::Index>(j)] * c.rows[j].dir;
  }
}

}  // namespace haustra::detail
