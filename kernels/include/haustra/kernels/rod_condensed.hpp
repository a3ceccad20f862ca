#pragma once
// The rod's Newton system (kernels/rod_newton.hpp: the same rows, the same fixed point) solved by
// condensation instead of a banded LU of 16×16 blocks: a discrete Riccati sweep, the quasi-static
// analogue of the articulated-body method.
//
// From the tip to the base, node k's distal rod is summed up by an affine map of the 10 numbers
// y_k = (δφ_k, δr_k, δq_k) — frame rotation, position and strain of node k, the strain because the
// section carries the mean of its two nodes' strains and the mass matrix couples neighbours:
//   [δw_k; c_k] = Π_k y_k + π_k,
// δw_k = (δM_k, δF_k) the distal wrench, c_k what node k's strain rows see of the distal rod. One
// step k+1 → k writes node k+1's kinematics in terms of y_k and δq_{k+1}, transports the wrench
// across section k, linearizes the section's generalized force there (fused: no Jacobian is
// assembled), and solves node k+1's four strain rows for δq_{k+1} = U_k (y_k, 1) with one
// partially pivoted 4×4 Gauss–Jordan elimination. At the base a 4×4 (clamped) or 10×10 (free)
// system gives y_0; back-substitution from the base gives every node's step.
//
// Every quantity is a row over the columns (δφ_k 3, δr_k 3, δq_k 4, δq_{k+1} 4, right-hand sides),
// so the sweep is row operations over contiguous doubles (vectorized across columns). Right-hand
// side 0 is the residual; the others are unit loads (attachment rows, coupled contact pairs) that
// enter the wrench transport at their own node, so they cost nothing beyond it.
//
// Safety: there is no pivoting across nodes. A 4×4 pivot far below its row's scale (a distal
// sub-rod at a singular, buckled state) or a non-finite value reports failure, and the caller
// falls back to the banded LU (kernels/block_tridiagonal.hpp) for that iteration.
#include <array>
#include <cstdint>
#include <span>

#include "haustra/kernels/rod_newton.hpp"
#include "haustra/kernels/spans.hpp"

namespace haustra::kernels {

// Column layout of a condensed row: y_k, then δq_{k+1}, then the right-hand sides.
inline constexpr int kCondensedRotation = 0;
inline constexpr int kCondensedPosition = 3;
inline constexpr int kCondensedStrain = 6;
inline constexpr int kCondensedNextStrain = 10;
inline constexpr int kCondensedRhs = 14;
inline constexpr int kCondensedInterface = 10;  // y_k

// Row width (doubles) for `columns` right-hand sides: a multiple of 4 (one AVX2 register).
[[nodiscard]] constexpr int condensed_width(int columns) { return (kCondensedRhs + columns + 3) & ~3; }
inline constexpr int kMaxCondensedColumns = 96;
// Doubles of workspace per node (the gains U_k) and for the whole sweep (its running rows).
[[nodiscard]] constexpr std::size_t condensed_gain_size(std::size_t nodes, int columns) {
  return nodes * 4 * static_cast<std::size_t>(condensed_width(columns));
}
[[nodiscard]] constexpr std::size_t condensed_scratch_size(int columns) {
  return 40 * static_cast<std::size_t>(condensed_width(columns));
}

// A unit load of one right-hand side: a force (or moment) `load` at `node`, world frame.
struct UnitLoad {
  std::uint32_t node = 0;
  std::uint32_t column = 1;  // ≥ 1; column 0 is the residual
  bool is_moment = false;
  Eigen::Vector3d load = Eigen::Vector3d::Zero();
};

// The configuration the system is linearized at, and what makes the rows: as rod_newton_assemble.
struct RodLinearization {
  RodPoses<const double> poses;
  std::span<const double> section_length;
  Vec3View<const double> node_force, node_moment;  // every current load, drag and contacts included
  std::array<double, 4> law_total{};               // a_c = k_c + η_c/Δt (a linear law)
  NodalLawTangent nodal{};                         // or a nonlinear law's tangent per node
  NewtonLoadStiffness stiffness{};                 // loads that follow the nodes (may be empty)
  bool free_base = false;
  // The law's rows scaled by this (≥ 1): J − (scale − 1) A, a step towards the law-weighted
  // gradient step where the plain Newton step is not a descent direction (indefinite loads).
  double law_scale = 1.0;
};

// What a sweep keeps to replay itself on a new residual (a chord iteration: the same Jacobian, a
// new right-hand side): per step, the section's frame, the elimination of node k+1's rows and the
// interface's share of δq_{k+1}; then the base system's elimination.
inline constexpr std::size_t kCondensedRecordPerStep = 84;
inline constexpr std::size_t kCondensedRecordBase = 132;
[[nodiscard]] constexpr std::size_t condensed_record_size(std::size_t nodes) {
  return (nodes - 1) * kCondensedRecordPerStep + kCondensedRecordBase;
}

// Caller-owned memory of one condensed solve (of a rod, or of one part of a split rod).
struct CondensedSystem {
  std::span<double> gain;     // condensed_gain_size(steps, columns): the gains of the part's steps
  std::span<double> scratch;  // condensed_scratch_size(columns)
  std::span<double> base;     // 10 × columns: y_0 of each right-hand side (column-major)
  int columns = 1;
  std::span<double> record;  // optional: condensed_record_size(nodes), for rod_condensed_resweep
};

struct CondenseReport {
  bool ok = true;
  double smallest_pivot = 1.0;  // the smallest |pivot| / its row's largest entry
  std::size_t node = 0;         // where it was (or where a value stopped being finite)
};

// Below this relative pivot the sweep reports failure (the banded LU pivots across nodes).
inline constexpr double kCondensedPivotFloor = 1e-10;

// Tip → base: the gains U_k of every node and y_0 of every right-hand side. residual: ρ per node
// (column 0 solves J δz = −ρ with the free base's unbalanced wrench). loads: sorted by node,
// descending, their columns numbered in the order they first appear there (so the live columns at
// any node are a prefix). Columns whose loads all sit at node 0 of a clamped rod are zero.
CondenseReport rod_condense(const RodLinearization& rod, StrainView<const double> residual,
                            std::span<const UnitLoad> loads, CondensedSystem sys);

// Four rods of one node count condensed at once, one rod per lane of a 4-double vector (AVX2):
// what rod_condense does for each, for rods whose solve has the residual column alone (columns 1:
// no unit loads), all with load stiffness or all without. Their free or clamped bases, laws and
// loads may differ. Each rod's gains, base solution and report as rod_condense gives them.
inline constexpr int kCondensedLanes = 4;
void rod_condense_lanes(const std::array<const RodLinearization*, kCondensedLanes>& rods,
                        const std::array<StrainView<const double>, kCondensedLanes>& residuals,
                        const std::array<CondensedSystem, kCondensedLanes>& systems,
                        std::array<CondenseReport, kCondensedLanes>& reports);

// A chord iteration: the residual column (column 0) solved anew with the Jacobian a recorded
// rod_condense factored (the whole rod; sys.record filled then). Rewrites column 0 of the gains and
// of the base solutions; the other columns (unit loads) stand. The free base's unbalanced wrench
// is the current loads'. first > 0: a range swept to node `first` (rod_condense_range without a
// joint), whose y there is given: its gains alone, no base system. joint > 0: a base part swept
// from a joint at node `joint` (rod_condense_range from 0 with a joint), its base system included.
void rod_condensed_resweep(const RodLinearization& rod, StrainView<const double> residual, CondensedSystem sys,
                           std::size_t first = 0, std::size_t joint = 0);

// Base → tip: the step Σ_c weight_c · (column c's solution) at every node: δq (4 per node), δφ and
// δr (world frame). weights: one per column (weight 1 on column 0 alone: the plain Newton step).
void rod_condensed_step(const RodLinearization& rod, CondensedSystem sys, std::span<const double> weights,
                        StrainView<double> dq, Vec3View<double> dphi, Vec3View<double> dr);

// Base → the last of `nodes` (ascending): every column's δφ and δr at those nodes. out: for each
// listed node, 6 × columns, column-major (δφ 0–2, δr 3–5 of column 0, then column 1, ...).
void rod_condensed_responses(const RodLinearization& rod, CondensedSystem sys, std::span<const std::uint32_t> nodes,
                             std::span<double> out);

// ---- A rod split at a joint node m, its two parts condensed at once (two threads) ----
//
// The tip part (nodes m..N) sweeps as the whole rod does and stops at node m, leaving the
// interface [δw_m; c_m] = Π_m y_m + π_m. The base part (nodes 0..m) starts at m with that interface
// unknown: columns 1–6 carry δw_m, columns 7–10 λ_c = c_m + A_mm δq_m (its rows keep −A_mm δq_m, so
// node m's pivot is the whole rod's), and it ends in the base system. Back-substitution to m gives
// y_m = Y + Y^λ λ; the join (I − Π' Y^λ) λ = Π' Y + π (Π' = Π_m with A_mm added back) fixes λ for
// every column. Exact: the same fixed point as the whole rod's sweep, to rounding.
inline constexpr int kJointColumns = 10;

struct CondensedRange {
  std::size_t first = 0;  // the sweep ends here: 0 in the base system, else at node first's interface
  std::size_t last = 0;   // and starts here: the tip (node N), or the joint (columns 1–10 are λ)
  bool joint = false;
  std::span<double> interface;  // first > 0: Π_first, 10 rows of condensed_width(columns) doubles
};

// The part's gains (steps [first, last), stored from step `first` on).
CondenseReport rod_condense_range(const RodLinearization& rod, StrainView<const double> residual,
                                  std::span<const UnitLoad> loads, CondensedSystem sys, const CondensedRange& range);

// Back-substitution over a part from node `first`, whose y of every column (10 × columns,
// column-major) is `start`: every column's δφ and δr at `nodes` (ascending, within the part; out
// as rod_condensed_responses), and — where `at_last` is not empty — y of every column at node
// `last` (10 × columns, column-major). Columns [column_first, column_end) only (end 0: all): each
// column's arithmetic is its own, so any division of them gives the same numbers.
void rod_condensed_responses_range(const RodLinearization& rod, CondensedSystem sys, std::size_t first,
                                   std::size_t last, std::span<const double> start,
                                   std::span<const std::uint32_t> nodes, std::span<double> out,
                                   std::span<double> at_last, int column_first = 0, int column_end = 0);

// A tip part's responses made affine in its start y_m, right after its sweep and before the join
// (decision 0087): back-substitution is linear in the start, so column g's δφ, δr at a node are
// particular(g) + unit · y_m(g). particular: every column's responses from y_m = 0 with the gains'
// right-hand sides (6 × columns per listed node, as rod_condensed_responses); unit: the responses
// to the 10 unit starts e_j without right-hand sides (6 × 10 per listed node, column j after
// column j − 1). One pass over the part's gains from node `first` to the last listed node
// (ascending, all beyond `first`). Scratch: sys.scratch (10 × condensed_width(columns) doubles).
void rod_condensed_tip_responses(const RodLinearization& rod, CondensedSystem sys, std::size_t first,
                                 std::span<const std::uint32_t> nodes, std::span<double> particular,
                                 std::span<double> unit);

// The fold after the join: out = particular + unit · y_m for each of `nodes` listed nodes and
// columns [column_first, column_end) (end 0: all `columns`); out as rod_condensed_responses.
void rod_condensed_tip_fold(std::span<const double> particular, std::span<const double> unit,
                            std::span<const double> y_joint, int columns, std::size_t nodes, std::span<double> out,
                            int column_first = 0, int column_end = 0);

// The step over a part, nodes [first, last]: from y at `first` (10 numbers) and the weighted sum
// of the part's columns.
void rod_condensed_step_range(const RodLinearization& rod, CondensedSystem sys, std::size_t first, std::size_t last,
                              const double* start, std::span<const double> weights, StrainView<double> dq,
                              Vec3View<double> dphi, Vec3View<double> dr);

// The join of a split rod at node m. tip: the tip part's interface (10 rows, tip_columns wide);
// base_at_joint: y_m of every base-part column (10 × base_columns, column-major: λ's are columns
// 1–10). For every column g of the whole solve, tip_column[g] and base_column[g] are its columns
// in the parts (−1: none there). Writes λ (10 per column) and y_m (10 per column). Returns false
// when the join's 10×10 system is singular.
struct CondensedJoin {
  std::span<const double> tip;
  int tip_columns = 1;
  std::span<const double> base_at_joint;
  int base_columns = 1;
  std::span<const int> tip_column, base_column;
};
bool rod_condensed_join(const RodLinearization& rod, std::size_t m, const CondensedJoin& join, std::span<double> lambda,
                        std::span<double> y_joint);

// The parts' loads of a whole solve's `loads` (sorted and numbered as rod_condense wants): the tip
// part's are those beyond m, a prefix of the list, with the whole solve's columns; the base part's
// the rest, written to base_loads with columns numbered after λ's (11, 12, ... in the order they
// appear). tip_column[g] = g; base_column[g]: g's column in the base part, −1 where it has no load
// there (0 for the residual). Returns (tip load count, base part's column count).
std::pair<std::size_t, int> rod_condensed_split_loads(std::span<const UnitLoad> loads, int columns, std::size_t m,
                                                      std::span<UnitLoad> base_loads, std::span<int> tip_column,
                                                      std::span<int> base_column);

// A base part's responses for the whole solve's columns: its raw responses (6 × base_columns per
// node, as rod_condensed_responses_range gives them) with λ's columns folded in, 6 × columns per
// node into out.
void rod_condensed_base_responses(std::span<const double> raw, int base_columns, std::span<const int> base_column,
                                  std::span<const double> lambda, std::size_t nodes, std::span<double> out);

// The parts' start and weights of the step Σ weight_g · column_g: the base part's y_0 and weights
// (λ's columns weighted by Σ_g weight_g λ^g), the tip part's y_m (the whole solve's columns).
void rod_condensed_split_step(std::span<const double> weights, std::span<const double> lambda,
                              std::span<const double> y_joint, std::span<const int> base_column,
                              std::span<const double> base_solution, int base_columns, double* base_start,
                              std::span<double> base_weights, double* tip_start);

}  // namespace haustra::kernels
