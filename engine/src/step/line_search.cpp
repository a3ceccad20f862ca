// Newton's line search on the frame's incremental potential (decision 0036), in phases the world
// runs over all rods at once so that a split rod's parts sweep and weigh their trials in parallel:
// begin (per rod), then per trial: sweep (per part), measure (per part), decide (per rod).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include "haustra/kernels/rod_forward_sweep.hpp"
#include "sched/scheduler.hpp"
#include "step/anchors.hpp"
#include "step/collision.hpp"
#include "step/instruments.hpp"
#include "step/newton_internal.hpp"
#include "step/newton_stages.hpp"
#include "step/segment_law.hpp"

namespace haustra::detail {
namespace {

using newton::Coupled;
using newton::VectorC;

// No contact may get deeper in one step by more than this fraction of its bead's radius: a
// penalty's stiffness grows with depth, so the tangent at the surface lets a bead sink far too far.
constexpr double kMaxNewtonDeepening = 0.1;
// Sufficient decrease (Armijo) of the merit, halving the step up to this many times.
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
// A Newton step none of which the search took is a stall when it would turn a section or stretch a
// node by more than this (rad, strain): the frame was meant to move and did not.
constexpr double kStallStep = 0.05;

// A part's nodes [first, end): the whole rod, or a split rod's base part [0, m) and tip part
// [m, N]; its sections are those that start at its nodes. slot: where its measures go.
struct PartRange {
  std::size_t first = 0, end = 0;
  std::size_t slot = 0;
};

PartRange range_of(const WorldModel& model, const SolvePart& part) {
  const SegmentModel& seg = model.segments[part.rod];
  switch (part.kind) {
    case SolvePartKind::whole: return {0, seg.node_count, 0};
    case SolvePartKind::base: return {0, seg.split_node, 0};
    case SolvePartKind::tip: return {seg.split_node, seg.node_count, 1};
  }
  return {};
}

// The rod's poses from its strains. A sleeping range is not swept again (decision 0127): its tip
// side sweeps from the pose its last node stands at, its base side from the base up to the range's
// first node, whose pose stays; where the base side's strains put that node is kept for the hold.
void sweep_awake(const WorldModel& model, WorldState& state, std::size_t rod) {
  const SegmentViews v = segment_views(model, state, rod);
  const HeldRange held = state.held_range(rod);
  const std::size_t n = v.poses.node_count();
  if (!held.any()) {
    kernels::rod_forward_sweep(state.now.base[rod], v.section_length, v.strain, v.poses);
    return;
  }
  if (held.tip_side(n)) {
    const kernels::Pose start{v.poses.node_rotation.get(held.last), v.poses.node_position.get(held.last)};
    const std::size_t count = n - held.last;
    kernels::rod_forward_sweep(start, v.section_length.subspan(held.last, count - 1),
                               v.strain.subview(held.last, count), v.poses.subview(held.last, count));
  }
  if (held.base_side()) {
    const std::size_t m = held.first;
    const kernels::Pose stands{v.poses.node_rotation.get(m), v.poses.node_position.get(m)};
    kernels::rod_forward_sweep(state.now.base[rod], v.section_length.first(m), v.strain.subview(0, m + 1),
                               v.poses.subview(0, m + 1));
    state.now.range_end[rod] = {v.poses.node_rotation.get(m), v.poses.node_position.get(m)};
    v.poses.node_rotation.set(m, stands.rotation);
    v.poses.node_position.set(m, stands.position);
  }
}

// A whole rod's poses as the sweep writes them, 14 arrays: node positions and rotations (n each),
// section midpoints' positions and rotations (n − 1 each).
std::array<std::span<double>, 14> pose_arrays(const kernels::RodPoses<double>& p) {
  return {p.node_position.x, p.node_position.y, p.node_position.z, p.node_rotation.w, p.node_rotation.x,
          p.node_rotation.y, p.node_rotation.z, p.mid_position.x,  p.mid_position.y,  p.mid_position.z,
          p.mid_rotation.w,  p.mid_rotation.x,  p.mid_rotation.y,  p.mid_rotation.z};
}

bool same_bits(std::span<const double> a, std::span<const double> b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size_bytes()) == 0;
}

bool same_pose(const kernels::Pose& a, const kernels::Pose& b) {
  return same_bits({a.rotation.coeffs().data(), 4}, {b.rotation.coeffs().data(), 4}) &&
         same_bits({a.position.data(), 3}, {b.position.data(), 3});
}

// The start of a line search (α = 0) from the kept sweep where the strains and base are bit for bit
// those it was made of: the same bits as sweeping them again. False: sweep.
bool restore_swept(const WorldModel& model, WorldState& state, std::size_t rod) {
  const NewtonWorkspace& ws = state.newton[rod];
  if (!ws.swept_kept || state.held_range(rod).any() || model.segments[rod].split_node > 0) return false;
  const SegmentViews v = segment_views(model, state, rod);
  if (!same_bits(v.strain.data, ws.swept_strain) || !same_pose(state.now.base[rod], ws.swept_base)) return false;
  const std::size_t n = v.poses.node_count();
  const std::array<std::span<double>, 14> to = pose_arrays(v.poses);
  for (std::size_t i = 0; i < to.size(); ++i)
    std::copy_n(ws.swept_poses.begin() + static_cast<std::ptrdiff_t>(i * n), to[i].size(), to[i].begin());
  return true;
}

// The part's share of the frame's incremental potential at the current strains and poses: the
// law's energy (elastic and viscous: ½ Δqᵀ A Δq about its target) over its sections, and at its
// nodes weight and host forces, the medium's drag (c/2Δt |r − r_start|², s/2Δt |turn|²), the
// contact penalties of its beads (but those with a bead of the other part), the grasps' couplings
// and the connective tissue's anchors.
double part_potential(const WorldModel& model, const WorldState& state, std::size_t rod, const SubstepParameters& p,
                      const PartRange& r) {
  const SegmentModel& seg = model.segments[rod];
  const NewtonWorkspace& ws = state.newton[rod];
  const std::size_t off = seg.node_offset, n = seg.node_count;
  const double* q = state.now.strain.data() + 4 * off;
  double law = 0.0;
  const kernels::StrainLawCoefficients coefficients = law_of(seg, p.dt);
  const std::array<double, 4> a = law_total(seg, p.dt);
  const std::size_t section_end = std::min(r.end, n - 1);
  // Hooke: ½ a (q − q*)ᵀ M (q − q*) per component; EXP2 bending and stretch: their viscous part
  // here, the elastic part below. The four components in one pass over the sections, each node's
  // q − q* taken once (each component's sum in the order of its sections, as one by one).
  std::array<double, 4> weight{}, quad{}, x0{};
  std::array<const double*, 4> centre{};
  for (std::size_t comp = 0; comp < 4; ++comp) {
    const bool exp2_elastic = seg.exp2 && comp != 2;
    weight[comp] = exp2_elastic ? coefficients.rate[comp] : a[comp];
    centre[comp] = exp2_elastic ? state.strain_substep_start.data() + 4 * off : ws.target.data();
  }
  if (r.first < section_end)
    for (std::size_t comp = 0; comp < 4; ++comp) x0[comp] = q[4 * r.first + comp] - centre[comp][4 * r.first + comp];
  for (std::size_t k = r.first; k < section_end; ++k) {
    const double third = model.section_length[off + k] / 3.0;
    for (std::size_t comp = 0; comp < 4; ++comp) {
      const double x1 = q[4 * (k + 1) + comp] - centre[comp][4 * (k + 1) + comp];
      quad[comp] += third * (x0[comp] * x0[comp] + x1 * x1 + x0[comp] * x1);
      x0[comp] = x1;
    }
  }
  for (std::size_t comp = 0; comp < 4; ++comp)
    if (weight[comp] != 0.0) law += 0.5 * weight[comp] * quad[comp];
  if (seg.exp2) {  // (torsion stays Hooke's: its elastic part is in the quadratic above)
    kernels::NodalLaw nl;
    nl.stiffness = seg.stiffness;
    nl.exp2 = true;
    nl.tissue = seg.tissue;
    nl.tube = seg.tube;
    const kernels::StrainView<const double> strain{std::span<const double>(q, 4 * n)};
    const kernels::StrainView<const double> rest{std::span<const double>(model.rest_strain).subspan(4 * off, 4 * n)};
    law += kernels::nodal_law_exp2_energy(strain, rest, std::span<const double>(model.section_length).subspan(off, n),
                                          nl, r.first, r.end);
  }
  double loads = 0.0;
  const auto pos = state.now.position.view();
  const auto rot = state.now.rotation.view();
  const auto fext = state.external_force.view();
  const auto r0 = state.position_substep_start.view();
  const auto q0 = state.rotation_substep_start.view();
  const std::span<const double> drag = drag_of(model, seg), spin = spin_drag_of(model, seg);
  for (std::size_t k = r.first; k < r.end; ++k) {
    const std::size_t g = off + k;
    const Eigen::Vector3d x = pos.get(g);
    loads -= (model.node_mass[g] * model.gravity + fext.get(g)).dot(x);
    if (seg.has_drag) {
      if (spin[k] > 0.0)
        loads += 0.5 * spin[k] / p.dt * kernels::rotation_angle_squared(rot.get(g) * q0.get(g).conjugate());
      loads += 0.5 * drag[k] / p.dt * (x - r0.get(g)).squaredNorm();
    }
  }
  if (seg.bead_count > 0) loads += segment_contact_potential(model, state, rod, ws.bead_start, r.first, r.end, false);
  for_each_coupled_grasp(state, rod, [&](std::size_t i, std::size_t node) {
    if (node < off + r.first || node >= off + r.end) return;
    loads +=
        grasp_coupling(model.instruments[i], state.instruments[i], pos.get(node), r0.get(node), p.dt, model.dt).energy;
  });
  const HeldRange held = state.held_range(rod);  // a sleeping range's tissue stores what it did (0127)
  for_each_intact_anchor(model, state, rod, [&](std::size_t anchor, std::size_t node) {
    if (node < off + r.first || node >= off + r.end) return;
    if (held.any() && node - off >= held.first && node - off <= held.last) return;
    loads += anchor_response(model, state, anchor, p.dt).energy;
    if (model.anchors.turn_stiffness[anchor] > 0.0) loads += anchor_turn(model, state, anchor, p.dt).energy;
  });
  return law + loads;
}

// Whether a bead at local nodes [first, end) would sink deeper into a contact than it may since
// the iteration's start: `across` false for its contacts but those with a bead of the segment
// outside the range, true for just those.
bool deepens_too_far(const WorldModel& model, const WorldState& state, std::size_t rod, std::size_t first,
                     std::size_t end, bool across) {
  const SegmentModel& seg = model.segments[rod];
  const NewtonWorkspace& ws = state.newton[rod];
  const CollisionState& cs = state.collision;
  const auto pos = state.now.position.view();
  auto local = [&](std::uint32_t bead) { return model.beads.node[bead] - seg.node_offset; };
  auto moved = [&](std::uint32_t bead) {
    return Eigen::Vector3d(pos.get(model.beads.node[bead]) - ws.bead_start[bead - seg.bead_offset]);
  };
  for (std::size_t b = seg.bead_offset; b < seg.bead_offset + seg.bead_count; ++b) {
    const auto bead = static_cast<std::uint32_t>(b);
    if (local(bead) < first || local(bead) >= end) continue;
    const double allowed = kMaxNewtonDeepening * model.beads.radius[b];
    for (std::uint32_t e = cs.bead_contact_start[b]; e < cs.bead_contact_start[b + 1]; ++e) {
      const Contact& k = cs.candidates[cs.bead_contact[e] >> 1];
      const bool second = (cs.bead_contact[e] & 1U) != 0;
      const std::uint32_t mate = second ? k.bead : k.other;
      const bool spans = k.coupled && (local(mate) < first || local(mate) >= end);
      if (spans != across) continue;
      Eigen::Vector3d relative = moved(bead);
      if (k.coupled) relative -= moved(mate);  // both beads are this segment's: their relative motion
      const double deepening = -(second ? -1.0 : 1.0) * k.direction.dot(relative);
      if (deepening - allowed - std::max(0.0, -k.depth) > 0.0) return true;  // a gap may close first
    }
  }
  return false;
}

// The attachments' part of the merit: the Lagrangian term of the constraint forces after the step
// and an exact penalty, Σ λ_j e_j + μ |e_j|.
double attachment_merit(const WorldModel& model, const WorldState& state, std::size_t rod, const Coupled& c,
                        const LineSearch& ls) {
  const SegmentModel& seg = model.segments[rod];
  const auto pos = state.now.position.view();
  const auto rot = state.now.rotation.view();
  double merit = 0.0;
  for (std::size_t j = 0; j < c.m; ++j) {
    const ConstraintRow& row = c.rows[j];
    const AttachmentState& as = state.now.attachment[seg.attachment_offset + row.attachment];
    const double e = row_error(row, as, pos.get(seg.node_offset + row.node), rot.get(seg.node_offset + row.node));
    merit += ls.lambda[j] * e + ls.mu * std::abs(e);
  }
  return merit;
}

// The scale of the potential's terms (the segment's weight over its length), for what counts as
// rounding.
double potential_scale(const WorldModel& model, std::size_t rod) {
  const SegmentModel& seg = model.segments[rod];
  double weight = 0.0;
  for (std::size_t k = seg.node_offset; k < seg.node_offset + seg.node_count; ++k) weight += model.node_mass[k];
  return weight * model.gravity.norm() * seg.info.length + 1e-12;
}

// The coupled unknowns' changes from the solve's column weights.
VectorC coupled_changes(const Coupled& c, const NewtonWorkspace& ws) {
  VectorC x(static_cast<Eigen::Index>(c.m + c.pc));
  for (Eigen::Index l = 0; l < x.size(); ++l) x[l] = ws.weights[ws.column_of[static_cast<std::size_t>(1 + l)]];
  return x;
}

// The slope of the merit along the full step: −ρ·δq − W·δbase for the potential, and for the
// attachments −Δλ·e − μ|e| (the step meets every constraint to first order), with λ the
// constraint forces after the step and μ ≥ |λ| the exact penalty's weight.
void measure_slope(const WorldModel& model, WorldState& state, std::size_t rod, const Coupled& c) {
  const SegmentModel& seg = model.segments[rod];
  NewtonWorkspace& ws = state.newton[rod];
  LineSearch& ls = ws.search;
  const SegmentViews v = segment_views(model, state, rod);
  const VectorC x = coupled_changes(c, ws);
  double slope = 0.0;
  for (std::size_t i = 0; i < 4 * seg.node_count; ++i) slope -= ws.residual[i] * ws.step_q[i];
  if (seg.base_mode == BaseMode::free) {
    // The free base's unbalanced wrench: the total load about node 0.
    const kernels::Vector6d wrench =
        kernels::total_wrench(v.poses.node_position, v.force, v.moment, v.poses.node_position.get(0));
    slope -= wrench.head<3>().dot(ws.step_phi.view().get(0)) + wrench.tail<3>().dot(ws.step_r.view().get(0));
  }
  ls.mu = 0.0;
  for (std::size_t j = 0; j < c.m; ++j) {
    const AttachmentState& as = state.now.attachment[seg.attachment_offset + c.rows[j].attachment];
    ls.lambda[j] = c.rows[j].dir.dot(c.rows[j].is_moment ? as.moment : as.force) + x[static_cast<Eigen::Index>(j)];
    ls.mu = std::max(ls.mu, std::abs(ls.lambda[j]));
  }
  for (std::size_t j = 0; j < c.m; ++j) {
    const double e = row_error(c.rows[j], state.now.attachment[seg.attachment_offset + c.rows[j].attachment], v);
    slope -= x[static_cast<Eigen::Index>(j)] * e + ls.mu * std::abs(e);
  }
  ls.slope = slope;
  // A host's moments are dead loads without a potential (their work depends on the path; the
  // rotation's logarithm wraps past half a turn): along the step they do the work α m·δφ of its
  // linearized rotation, as the slope counts them.
  ls.moment_work = 0.0;
  const auto mext = state.external_moment.view();
  for (std::size_t k = 0; k < seg.node_count; ++k)
    ls.moment_work += mext.get(seg.node_offset + k).dot(ws.step_phi.view().get(k));
}

// The strains (and a free base's pose) a fraction α along the step; the sweep phase follows.
void set_trial(const WorldModel& model, WorldState& state, std::size_t rod, double alpha) {
  const SegmentModel& seg = model.segments[rod];
  NewtonWorkspace& ws = state.newton[rod];
  double* q = state.now.strain.data() + 4 * seg.node_offset;
  for (std::size_t i = 0; i < 4 * seg.node_count; ++i) q[i] = ws.strain_before[i] + alpha * ws.step_q[i];
  // A range asleep at the base holds the base (decision 0127).
  if (seg.base_mode == BaseMode::free && !(state.held_range(rod).any() && state.range_first[rod] == 0)) {
    kernels::Pose& base = state.now.base[rod];
    base.rotation = (kernels::rotation_exp(alpha * ws.step_phi.view().get(0)) * ws.base_before.rotation).normalized();
    base.position = ws.base_before.position + alpha * ws.step_r.view().get(0);
  }
  ws.search.alpha = alpha;
}

// Stiffens the law's rows and solves again until the step descends (or the stiffenings run out).
// The strains are back at the start; the poses are swept there. False: no solve.
bool stiffen(const WorldModel& model, WorldState& state, std::size_t rod, const SubstepParameters& p,
             const Coupled& c) {
  NewtonWorkspace& ws = state.newton[rod];
  LineSearch& ls = ws.search;
  do {
    if (ls.stiffened == kMaxStiffenings) return true;  // the last direction is searched as it is
    set_trial(model, state, rod, 0.0);
    sweep_awake(model, state, rod);
    ++ls.stiffened;
    ++ws.stiffenings;
    if (!newton::resolve(model, state, rod, p, ws.law_scale * kStiffening)) return false;
    measure_slope(model, state, rod, c);
  } while (!(ls.slope < 0.0));
  return true;
}

// Whether the whole Newton step would move the rod by more than the solver's tolerance (the
// measure iteration_converged uses): a step that small may be refused without harm.
bool step_moves(const WorldModel& model, std::size_t rod, const NewtonWorkspace& ws) {
  const SegmentModel& seg = model.segments[rod];
  double turn = 0.0, stretch = 0.0;
  for (std::size_t k = 0; k < seg.node_count; ++k) {
    for (std::size_t comp = 0; comp < 3; ++comp) turn = std::max(turn, std::abs(ws.step_q[4 * k + comp]));
    stretch = std::max(stretch, std::abs(ws.step_q[4 * k + 3]));
  }
  return std::max(turn * seg.mean_section, stretch) > kStallStep;
}

// The search is over: the fraction taken (0: none lowered the merit), the strain change, the
// attachments' forces.
void finish(const WorldModel& model, WorldState& state, std::size_t rod, const Coupled& c, bool accepted) {
  const SegmentModel& seg = model.segments[rod];
  NewtonWorkspace& ws = state.newton[rod];
  LineSearch& ls = ws.search;
  ls.active = false;
  ws.potential_cached = accepted;
  ws.poses_swept = model.segments[rod].split_node == 0 && !state.held_range(rod).any();
  double alpha = ls.alpha;
  if (!accepted) {  // stay: with no change the segment counts as converged, so the guard is told
    alpha = 0.0;
    if (step_moves(model, rod, ws)) {
      ws.stalled = true;
      ++ws.stalls;
    }
    set_trial(model, state, rod, 0.0);
    sweep_awake(model, state, rod);
  }
  state.segment_step_cut[rod] = alpha < 1.0 ? 1 : 0;
  // Fast mode: a chord step that had to be cut says the factorization no longer fits.
  if (alpha < 1.0 || ls.stiffened > 0) ws.chord_ready = false;
  Eigen::Vector4d& change = state.segment_change[rod];
  change.setZero();
  for (std::size_t k = 0; k < seg.node_count; ++k)
    for (std::size_t comp = 0; comp < 4; ++comp) {
      const double d = alpha * std::abs(ws.step_q[4 * k + comp]);
      change[static_cast<Eigen::Index>(comp)] = std::max(change[static_cast<Eigen::Index>(comp)], d);
    }
  const VectorC x = coupled_changes(c, ws);
  for (std::size_t j = 0; j < c.m; ++j) {
    AttachmentState& as = state.now.attachment[seg.attachment_offset + c.rows[j].attachment];
    (c.rows[j].is_moment ? as.moment : as.force) += alpha * x[static_cast<Eigen::Index>(j)] * c.rows[j].dir;
  }
}

// The first trial from the trust region's scale, or — where the start's merit is not known —
// the start itself first.
void first_trial(const WorldModel& model, WorldState& state, std::size_t rod, bool start_known) {
  NewtonWorkspace& ws = state.newton[rod];
  LineSearch& ls = ws.search;
  ls.attempt = 0;
  ls.measuring_start = !start_known;
  if (start_known)
    set_trial(model, state, rod, newton::trust_scale(model.segments[rod], segment_views(model, state, rod), ws));
  else
    set_trial(model, state, rod, 0.0);
}

}  // namespace

void stage_newton_search_begin(const WorldModel& model, WorldState& state, std::size_t rod,
                               const SubstepParameters& p) {
  const SegmentModel& seg = model.segments[rod];
  NewtonWorkspace& ws = state.newton[rod];
  LineSearch& ls = ws.search;
  const Coupled c = newton::coupled_unknowns(model, state, rod);
  const SegmentViews v = segment_views(model, state, rod);
  std::copy(v.strain.data.begin(), v.strain.data.end(), ws.strain_before.begin());
  ws.base_before = state.now.base[rod];
  for (std::size_t b = 0; b < seg.bead_count; ++b)
    ws.bead_start[b] = v.poses.node_position.get(model.beads.node[seg.bead_offset + b] - seg.node_offset);
  ls.active = true;
  ls.stiffened = 0;
  // Fast mode's own rung weighs no potential (decision 0037): its chord steps are checked for
  // descent and for contacts sinking, and the guard and the robust mode stand behind them.
  ls.weigh = !p.chord;
  measure_slope(model, state, rod, c);
  if (!(ls.slope < 0.0) && ws.chord) {  // a stale factorization pointed uphill: factor afresh
    ws.chord = false;
    ws.chord_ready = false;
    if (!newton::resolve(model, state, rod, p, 1.0)) {
      finish(model, state, rod, c, false);
      return;
    }
    measure_slope(model, state, rod, c);
  }
  if (!(ls.slope < 0.0) && !stiffen(model, state, rod, p, c)) {
    finish(model, state, rod, c, false);
    return;
  }
  // The start's potential: the last iterate's accepted one where nothing changed since (one rod:
  // no other segment's beads moved; the same substep, no stiffened re-sweep); otherwise measured.
  // The first iterate of a frame starts from the filtered node positions, which the strains do
  // not reproduce: its start is measured on the strains' own shape (the sweep of α = 0).
  const bool known =
      !ls.weigh || (ws.potential_cached && p.iteration > 0 && ls.stiffened == 0 && model.segments.size() == 1);
  if (known) {
    ls.merit0 = ws.potential + attachment_merit(model, state, rod, c, ls);
    ls.rounding = kPotentialRounding * (std::abs(ls.merit0) + potential_scale(model, rod));
  }
  first_trial(model, state, rod, known);
}

void stage_newton_search_sweep(const WorldModel& model, WorldState& state, const SolvePart& part) {
  const std::size_t rod = part.rod;
  if (!state.newton[rod].search.active) return;
  const SegmentViews v = segment_views(model, state, rod);
  NewtonSplit& sp = state.newton[rod].split;
  const std::size_t m = sp.joint;
  switch (part.kind) {
    case SolvePartKind::whole:
      if (!state.newton[rod].search.measuring_start || !restore_swept(model, state, rod))
        sweep_awake(model, state, rod);
      break;
    case SolvePartKind::base:
      kernels::rod_forward_sweep(state.now.base[rod], v.section_length.first(m), v.strain.subview(0, m + 1),
                                 v.poses.subview(0, m + 1));
      break;
    case SolvePartKind::tip: {
      const std::size_t count = v.poses.node_count() - m;
      const kernels::RodPoses<double> rel{sp.rel_position.view(), sp.rel_rotation.view(), sp.rel_mid_position.view(),
                                          sp.rel_mid_rotation.view()};
      kernels::rod_forward_sweep({}, v.section_length.subspan(m, count - 1), v.strain.subview(m, count), rel);
      break;
    }
  }
}

void stage_newton_search_measure(const WorldModel& model, WorldState& state, const SolvePart& part,
                                 const SubstepParameters& p) {
  const std::size_t rod = part.rod;
  NewtonWorkspace& ws = state.newton[rod];
  LineSearch& ls = ws.search;
  if (!ls.active) return;
  const PartRange r = range_of(model, part);
  if (part.kind == SolvePartKind::tip) {
    // The tip part's poses, composed with the joint's (the base part swept it).
    const SegmentViews v = segment_views(model, state, rod);
    const NewtonSplit& sp = ws.split;
    const std::size_t m = sp.joint, count = v.poses.node_count() - m;
    const Eigen::Quaterniond qm = v.poses.node_rotation.get(m);
    const Eigen::Vector3d rm = v.poses.node_position.get(m);
    for (std::size_t j = 1; j < count; ++j) {
      v.poses.node_rotation.set(m + j, (qm * sp.rel_rotation.view().get(j)).normalized());
      v.poses.node_position.set(m + j, rm + qm * sp.rel_position.view().get(j));
    }
    for (std::size_t j = 0; j + 1 < count; ++j) {
      v.poses.mid_rotation.set(m + j, qm * sp.rel_mid_rotation.view().get(j));
      v.poses.mid_position.set(m + j, rm + qm * sp.rel_mid_position.view().get(j));
    }
  }
  ls.potential[r.slot] = ls.weigh ? part_potential(model, state, rod, p, r) : 0.0;
  ls.deepens[r.slot] = model.segments[rod].bead_count > 0 && !ls.measuring_start &&
                       deepens_too_far(model, state, rod, r.first, r.end, false);
}

void stage_newton_search_decide(const WorldModel& model, WorldState& state, std::size_t rod,
                                const SubstepParameters& p) {
  const SegmentModel& seg = model.segments[rod];
  NewtonWorkspace& ws = state.newton[rod];
  LineSearch& ls = ws.search;
  if (!ls.active) return;
  const Coupled c = newton::coupled_unknowns(model, state, rod);
  const bool split = seg.split_node > 0;
  double potential = ls.potential[0] + (split ? ls.potential[1] : 0.0);
  bool deepens = ls.deepens[0] != 0 || (split && ls.deepens[1] != 0);
  if (split && seg.bead_count > 0) {  // the contacts across the joint
    if (ls.weigh) potential += segment_contact_potential(model, state, rod, ws.bead_start, 0, seg.split_node, true);
    deepens = deepens || (!ls.measuring_start && deepens_too_far(model, state, rod, 0, seg.split_node, true));
  }
  if (!ls.weigh) {  // fast mode: the step unless a contact sinks too far
    if (!deepens) {
      finish(model, state, rod, c, true);
      ws.potential_cached = false;
    } else if (ls.attempt < kMaxBacktracks) {
      ++ls.attempt;
      ++ws.backtracks;
      set_trial(model, state, rod, 0.5 * ls.alpha);
    } else {
      finish(model, state, rod, c, false);
    }
    return;
  }
  const double merit = potential - ls.alpha * ls.moment_work + attachment_merit(model, state, rod, c, ls);
  if (ls.measuring_start) {
    ls.merit0 = merit;
    ls.rounding = kPotentialRounding * (std::abs(merit) + potential_scale(model, rod));
    first_trial(model, state, rod, true);
    return;
  }
  if (!deepens && merit <= ls.merit0 + kArmijo * ls.alpha * std::min(ls.slope, 0.0) + ls.rounding) {
    ws.potential = potential;
    finish(model, state, rod, c, true);
    return;
  }
  if (ls.attempt < kMaxBacktracks) {  // halve
    ++ls.attempt;
    ++ws.backtracks;
    set_trial(model, state, rod, 0.5 * ls.alpha);
    return;
  }
  // None of the step's fractions lowered the merit: stiffen the law's rows and solve again,
  // towards the law-weighted gradient step; the start's merit is measured anew (the attachments'
  // forces after the new step weigh it).
  if (ls.stiffened == kMaxStiffenings || !stiffen(model, state, rod, p, c)) {
    finish(model, state, rod, c, false);
    return;
  }
  first_trial(model, state, rod, false);
}

void keep_swept_poses(const WorldModel& model, WorldState& state, std::size_t rod) {
  if (state.newton.empty()) return;
  NewtonWorkspace& ws = state.newton[rod];
  ws.swept_kept = ws.poses_swept;
  if (!ws.swept_kept) return;
  const SegmentViews v = segment_views(model, state, rod);
  const std::size_t n = v.poses.node_count();
  const std::array<std::span<double>, 14> from = pose_arrays(v.poses);
  for (std::size_t i = 0; i < from.size(); ++i)
    std::copy(from[i].begin(), from[i].end(), ws.swept_poses.begin() + static_cast<std::ptrdiff_t>(i * n));
  std::copy(v.strain.data.begin(), v.strain.data.end(), ws.swept_strain.begin());
  ws.swept_base = state.now.base[rod];
}

void stage_line_search(const WorldModel& model, WorldState& state, Scheduler& scheduler, const SubstepParameters& p) {
  const std::size_t segs = model.segments.size();
  scheduler.for_each(segs, [&](std::size_t s) {
    if (state.segment_converged[s] == 0 && state.segment_solvable[s] != 0)
      stage_newton_search_begin(model, state, s, p);
  });
  for (;;) {
    bool searching = false;
    for (std::size_t s = 0; s < segs; ++s) searching = searching || state.newton[s].search.active;
    if (!searching) break;
    scheduler.for_each(model.solve_parts.size(),
                       [&](std::size_t i) { stage_newton_search_sweep(model, state, model.solve_parts[i]); });
    scheduler.for_each(model.solve_parts.size(),
                       [&](std::size_t i) { stage_newton_search_measure(model, state, model.solve_parts[i], p); });
    scheduler.for_each(segs, [&](std::size_t s) { stage_newton_search_decide(model, state, s, p); });
  }
}

}  // namespace haustra::detail
