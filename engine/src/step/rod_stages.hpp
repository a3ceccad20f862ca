#pragma once
// The rod stages of a frame, one segment at a time. Each reads the constant model and writes only
// its own segment's slice of the state, so segments can run in parallel in any order and give the
// same bits.
#include <array>
#include <string>

#include "haustra/profile.hpp"
#include "model/world_model.hpp"
#include "state/world_state.hpp"

namespace haustra::detail {

struct SubstepParameters {
  double dt = 0.0;      // substep length
  bool newton = false;  // Newton iterations rather than the lagged update
  int iteration = 0;    // within the substep
  bool chord = false;   // fast mode: Newton may reuse its last factorization
};

// The active constraint rows of a segment: one per held axis of each active attachment.
struct ConstraintRow {
  std::size_t node = 0;
  Eigen::Vector3d dir = Eigen::Vector3d::Zero();
  bool is_moment = false;
  std::size_t attachment = 0;
};
using ConstraintRows = std::array<ConstraintRow, kMaxConstraintRows>;
std::size_t active_constraint_rows(const SegmentModel& seg, const WorldState& state, ConstraintRows& rows);

// A substep's start: the strains, poses and base its drag and potential measure from; the segment
// iterates again.
void stage_snapshot(const WorldModel& model, WorldState& state, std::size_t segment, bool newton);
// Gravity and external loads; in Newton mode also the attachments' accumulated constraint forces and
// the medium's drag on the motion since the substep began.
void stage_loads(const WorldModel& model, WorldState& state, std::size_t segment, const SubstepParameters& p);
void stage_free_base(const WorldModel& model, WorldState& state, std::size_t segment, double dt);
void stage_backward_sweep(const WorldModel& model, WorldState& state, std::size_t segment);
// Returns the largest strain change of the update (per component).
Eigen::Vector4d stage_solve(const WorldModel& model, WorldState& state, std::size_t segment,
                            const SubstepParameters& p);
void stage_constraints(const WorldModel& model, WorldState& state, std::size_t segment, const SubstepParameters& p);
void stage_forward_sweep(const WorldModel& model, WorldState& state, std::size_t segment);
void stage_filter(const WorldModel& model, WorldState& state, std::size_t segment);

// A segment's potential energy in a configuration (strains 4 per node and node positions, the
// world's arrays): what its elastic and Kelvin–Voigt components store, ½ Σ k_c Δqᵀ M Δq, its
// weight's −Σ m_k g·r_k, and what its intact anchors' springs store (state: which hold).
Energy segment_energy(const WorldModel& model, const WorldState& state, std::span<const double> strain,
                      kernels::Vec3View<const double> position, kernels::RotationView<const double> rotation,
                      std::size_t segment);

struct GuardResult {
  bool ok = true;
  std::size_t node = 0;
  Stage stage = Stage::guard;
  // What failed, with its value and limit; formatted only on failure.
  const char* quantity = "";
  double value = 0.0;
  double limit = 0.0;
};

// For a frame of the lagged scheme, the fixed-point iteration's local contraction: one more
// backward sweep at the new configuration gives the step the scheme would take next
// (state.lagged_ratios), and a next step larger than this one means the iteration diverges, even
// while every value is still within bounds (it oscillates or wanders instead of blowing up).
void stage_lagged_contraction(const WorldModel& model, WorldState& state, std::size_t segment,
                              const SubstepParameters& p);

// The largest distance (m) of an active attachment from its target, and its node (local).
double attachment_miss(const WorldModel& model, const WorldState& state, std::size_t segment, std::size_t& node);
// After an iteration: the segment moved less than the solver's tolerance, or, once the fixed
// iteration count is past, nothing holds Newton back (no contact cut its step, every attachment
// on target).
[[nodiscard]] bool iteration_converged(const WorldModel& model, const WorldState& state, std::size_t segment,
                                       bool past_fixed_count);
// The guard: finite values and bounds, energy, and for the lagged scheme the contraction measured
// just before it.
GuardResult stage_guard(const WorldModel& model, WorldState& state, std::size_t segment, const SubstepParameters& p);

// Twist (ω, v) about node 0 applied for dt to a base pose.
kernels::Pose integrate_base(const kernels::Pose& start, const kernels::Vector6d& twist, double dt);

}  // namespace haustra::detail
