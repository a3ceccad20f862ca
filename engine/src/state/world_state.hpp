#pragma once
// The per-frame part of a world (MuJoCo's mjData): everything a step writes. Allocated once at
// creation; a step never allocates.
#include <algorithm>
#include <span>
#include <type_traits>
#include <vector>

#include "haustra/kernels/broad_phase.hpp"
#include "haustra/kernels/cage_rings.hpp"
#include "haustra/kernels/pose.hpp"
#include "haustra/kernels/rod_condensed.hpp"
#include "haustra/kernels/rod_loads.hpp"
#include "haustra/kernels/rod_newton.hpp"
#include "haustra/kernels/skinning.hpp"
#include "haustra/kernels/spans.hpp"
#include "haustra/report_fields.h"
#include "model/world_model.hpp"

namespace haustra::detail {

// Three parallel arrays (x[], y[], z[]) in one block, x then y then z: node quantities in double,
// mesh vertices in float. One block so a host (the Python module) can see the three as one
// strided array without a copy. Copies re-seat the spans on their own block.
template <class T>
struct Vec3BufferOf {
  std::span<T> x, y, z;

  Vec3BufferOf() = default;
  Vec3BufferOf(const Vec3BufferOf& other) : block_(other.block_) { seat(); }
  Vec3BufferOf(Vec3BufferOf&& other) noexcept : block_(std::move(other.block_)) {
    seat();
    other.seat();
  }
  Vec3BufferOf& operator=(const Vec3BufferOf& other) {
    if (this != &other) {
      block_ = other.block_;  // same size: copied in place, no allocation
      seat();
    }
    return *this;
  }
  Vec3BufferOf& operator=(Vec3BufferOf&& other) noexcept {
    block_ = std::move(other.block_);
    seat();
    other.seat();
    return *this;
  }
  ~Vec3BufferOf() = default;

  void resize(std::size_t n) {
    block_.assign(3 * n, T{0});
    seat();
  }
  [[nodiscard]] kernels::Vec3View<T> view() { return {x, y, z}; }
  [[nodiscard]] kernels::Vec3View<const T> view() const { return {x, y, z}; }
  [[nodiscard]] kernels::FloatVec3Out out() requires std::is_same_v<T, float> { return {x, y, z}; }

 private:
  void seat() {
    const std::size_t n = block_.size() / 3;
    x = {block_.data(), n};
    y = {block_.data() + n, n};
    z = {block_.data() + 2 * n, n};
  }
  std::vector<T> block_;
};
using Vec3Buffer = Vec3BufferOf<double>;
using FloatVec3Buffer = Vec3BufferOf<float>;

// Unit quaternions as four parallel arrays (w[], x[], y[], z[]) in one block, w then x then y then z,
// so a host sees them as one strided n × 4 array without a copy (as Vec3BufferOf).
struct RotationBuffer {
  std::span<double> w, x, y, z;

  RotationBuffer() = default;
  RotationBuffer(const RotationBuffer& other) : block_(other.block_) { seat(); }
  RotationBuffer(RotationBuffer&& other) noexcept : block_(std::move(other.block_)) {
    seat();
    other.seat();
  }
  RotationBuffer& operator=(const RotationBuffer& other) {
    if (this != &other) {
      block_ = other.block_;  // same size: copied in place, no allocation
      seat();
    }
    return *this;
  }
  RotationBuffer& operator=(RotationBuffer&& other) noexcept {
    block_ = std::move(other.block_);
    seat();
    other.seat();
    return *this;
  }
  ~RotationBuffer() = default;

  void resize(std::size_t n) {
    block_.assign(4 * n, 0.0);
    std::fill_n(block_.begin(), n, 1.0);  // identity: w = 1
    seat();
  }
  [[nodiscard]] kernels::RotationView<double> view() { return {w, x, y, z}; }
  [[nodiscard]] kernels::RotationView<const double> view() const { return {w, x, y, z}; }

 private:
  void seat() {
    const std::size_t n = block_.size() / 4;
    w = {block_.data(), n};
    x = {block_.data() + n, n};
    y = {block_.data() + 2 * n, n};
    z = {block_.data() + 3 * n, n};
  }
  std::vector<double> block_;
};

// With the frame's loads held, the next lagged step from the new strains against this frame's step.
struct LaggedRatios {
  double elastic = 0.0;  // over the elastic strain components
  double viscous = 0.0;  // over the viscous and Kelvin–Voigt ones
};

struct AttachmentState {
  bool active = true;
  std::size_t node = 0;  // local to the segment
  bool hold_frame = false;
  Eigen::Vector3d target = Eigen::Vector3d::Zero();
  Eigen::Quaterniond target_rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d force = Eigen::Vector3d::Zero();  // on the rod, last frame
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();
};

// The world state's buffers, each listed once (decision 0116) with how many entries the model asks
// for, X(type, name, per, width, initial, role, meaning): `width` entries per `per` (a node, a rod, an
// attachment slot, an anchor, a double of the constraint scratch), starting at `initial`; role
// `kept` if a later frame reads it before writing it — checkpoints save it (in the list's order)
// and a rebuilt world carries it over rod by rod — or `scratch`. From the lists: the state's
// declarations and sizes (init_world_state), checkpoint.cpp's state, state_carry_over.cpp's
// copies, and the memory estimate's bytes per node.
enum class Per : std::uint8_t { node, segment, attachment, anchor, constraint_double };
enum class Role : std::uint8_t { kept, scratch };
struct Zeros {};       // a Vec3Buffer's initial value
struct Identities {};  // a RotationBuffer's

// What a frame carries over to the next one; copied at frame start so a failed frame can be undone.
// clang-format off
#define HAUSTRA_PERSISTENT_STATE(X)                                                                         \
  X(std::vector<double>, strain, node, 4, 0.0, kept, "the strains (κ1, κ2, τ, ε)")                          \
  X(Vec3Buffer, position, node, 1, Zeros{}, kept, "filtered node positions")                                 \
  X(RotationBuffer, rotation, node, 1, Identities{}, kept, "node frames")                                     \
  X(Vec3Buffer, mid_position, node, 1, Zeros{}, kept, "section midpoints (per node index, last unused)")     \
  X(RotationBuffer, mid_rotation, node, 1, Identities{}, kept, "section frames")                             \
  X(std::vector<kernels::Pose>, base, segment, 1, kernels::Pose{}, kept, "each rod's base")                  \
  X(std::vector<AttachmentState>, attachment, attachment, 1, AttachmentState{}, kept, "attachment slots")    \
  X(std::vector<std::uint8_t>, anchor_intact, anchor, 1, 1, kept, "1 while the anchor holds, 0 once torn or cut") \
  X(std::vector<kernels::Pose>, range_end, segment, 1, kernels::Pose{}, kept, "the base side's end (decision 0127)")
// clang-format on

#define HAUSTRA_DECLARE_BUFFER(type, name, per, width, initial, role, meaning) type name;

struct PersistentState {
  HAUSTRA_PERSISTENT_STATE(HAUSTRA_DECLARE_BUFFER)

  void copy_from(const PersistentState& o);  // no allocation: sizes already match
};

// A split rod's two parts (kernels/rod_condensed: the tip part and the base part, joined at a node):
// their gains, the tip's interface at the joint, the base's columns, and the join.
struct NewtonSplit {
  std::size_t joint = 0;  // the split node m
  std::vector<double> tip_gain, tip_scratch, tip_solution, interface;
  std::vector<double> base_gain, base_scratch, base_solution;
  std::vector<kernels::UnitLoad> base_loads;
  std::size_t tip_loads = 0;  // how many of the rod's loads (a prefix) are the tip part's
  std::size_t base_load_count = 0;
  int base_columns = 1;
  std::vector<int> tip_column, base_column;
  std::size_t base_nodes = 0;  // response nodes at or before the joint (a prefix of the rod's)
  std::vector<double> raw, at_joint, lambda, y_joint, base_weights;
  // The tip part's responses at its response nodes, made in its condense task (decision 0087):
  // every column's from y_m = 0 (6 × columns per node) and the ten unit starts' (6 × 10 per node).
  std::vector<double> tip_particular, tip_unit;
  std::array<double, 10> base_start{}, tip_start{};
  bool tip_ok = true, base_ok = true;
  // The line search's tip part: its poses relative to the joint's frame (nodes m..N, sections
  // m..N−1), before they are composed with the joint's pose.
  Vec3Buffer rel_position, rel_mid_position;
  RotationBuffer rel_rotation, rel_mid_rotation;

  void allocate(std::size_t nodes, std::size_t m, int columns);
};

// A rod's line search between the world's phases (line_search.cpp): the step's slope and the
// merit at its start, the fraction under trial, and each part's share of the potential there.
struct LineSearch {
  bool active = false;           // trials under way
  bool measuring_start = false;  // the trial under way is the start itself (α = 0)
  bool weigh = true;             // the merit decides (not on fast mode's own rung)
  double alpha = 0.0, slope = 0.0, merit0 = 0.0, rounding = 0.0, mu = 0.0, moment_work = 0.0;
  int attempt = 0, stiffened = 0;
  std::array<double, kMaxConstraintRows> lambda{};  // constraint forces after the step, per row
  std::array<double, 2> potential{};                // per part: whole or base, tip
  std::array<std::uint8_t, 2> deepens{};            // per part: a contact deepened too far
};

// The Newton workspace's buffers per node of its rod, listed once as the state's (decision 0116):
// X(type, name, width, initial, allocated, meaning), `allocated` always, or with_band only for a
// rod that keeps the banded fallback. NewtonWorkspace declares and sizes them from the list, the
// memory estimate counts their bytes per node from it.
using SwapRow = std::array<std::uint8_t, kernels::kNewtonBlock>;
enum class Allocated : std::uint8_t { always, with_band };
// clang-format off
#define HAUSTRA_NEWTON_NODE_BUFFERS(X)                                                                     \
  X(std::vector<double>, step_q, 4, 0.0, always, "the step: δq")                                            \
  X(Vec3Buffer, step_phi, 1, Zeros{}, always, "… δφ")                                                       \
  X(Vec3Buffer, step_r, 1, Zeros{}, always, "… δr")                                                         \
  X(std::vector<kernels::NewtonBlock>, lower, 1, kernels::NewtonBlock::Zero(), with_band, "the banded LU's 16×16 blocks") \
  X(std::vector<kernels::NewtonBlock>, diag, 1, kernels::NewtonBlock::Zero(), with_band, "")               \
  X(std::vector<kernels::NewtonBlock>, upper, 1, kernels::NewtonBlock::Zero(), with_band, "")              \
  X(std::vector<kernels::NewtonBlock>, fill, 1, kernels::NewtonBlock::Zero(), with_band, "the factorization's second upper block") \
  X(std::vector<SwapRow>, swaps, 1, SwapRow{}, with_band, "its row swaps")                                  \
  X(Vec3Buffer, distal_force, 1, Zeros{}, with_band, "")                                                    \
  X(Vec3Buffer, distal_moment, 1, Zeros{}, with_band, "")                                                   \
  X(std::vector<double>, unit, 4, 0.0, with_band, "")                                                       \
  X(std::vector<double>, residual, 4, 0.0, always, "the linearization")                                    \
  X(std::vector<double>, target, 4, 0.0, always, "")                                                        \
  X(std::vector<double>, law_stress, 4, 0.0, always, "a nonlinear (EXP2) law's generalized stress")        \
  X(std::vector<double>, law_tangent, 4, 0.0, always, "… and tangent")                                     \
  X(std::vector<double>, bend_coupling, 1, 0.0, always, "… and its κ1–κ2 coupling")                         \
  X(std::vector<Eigen::Matrix3d>, force_stiffness, 1, Eigen::Matrix3d::Zero(), always, "−∂f/∂r of drag and contacts") \
  X(std::vector<double>, drag_moment_rate, 1, 0.0, always, "s/Δt")                                          \
  X(std::vector<double>, strain_before, 4, 0.0, always, "the line search: the strains before the step")    \
  X(std::vector<double>, swept_poses, 14, 0.0, always, "the last step's poses before the filter moved them") \
  X(std::vector<double>, swept_strain, 4, 0.0, always, "… the strains they are the sweep of")
// clang-format on
#define HAUSTRA_DECLARE_NEWTON_BUFFER(type, name, width, initial, allocated, meaning) type name;

// Scratch of one segment's Newton solve: the condensed sweep's gains and right-hand sides, the
// step it gives, and — for rods up to kBandFallbackNodes — the banded LU it falls back to.
struct NewtonWorkspace {
  // The condensed solve (kernels/rod_condensed), of the whole rod or of its parts.
  std::vector<double> gain, scratch, base_solution;
  std::vector<double> scratch_second;  // the second half of the responses' columns runs apart
  LineSearch search;
  // Fast mode (decision 0037): the sweep's record, and when its factorization may serve again —
  // the frame and step length it was made at, the attachments' nodes and the beads touching then.
  std::vector<double> record;
  bool chord_ready = false;  // a recorded factorization at the law's own scale
  bool chord = false;        // this iteration reuses it
  std::uint64_t chord_frame = 0;
  double chord_dt = 0.0;
  std::vector<std::uint32_t> chord_pattern, pattern_now;
  std::size_t chord_from = 0, chord_first = 0;  // the sleeping range it was made around (decision 0127)
  // A sleeping range (decision 0127): the sweep stops at the range's last node, held (y = 0 there):
  // its interface rows (unused), and the zero start of every column's back-substitution.
  std::vector<double> held_interface, held_start;
  NewtonSplit split;                          // joint == 0: the rod is solved whole
  bool ok = true;                             // the whole rod's sweep held its pivots
  std::vector<kernels::UnitLoad> loads;       // this iteration's unit loads, by node descending
  std::vector<std::uint32_t> response_nodes;  // constraint and coupled-pair nodes, ascending, unique
  std::vector<double> responses;              // 6 × columns per response node (δφ, δr)
  std::vector<double> weights;                // per column: 1, then the coupled unknowns
  std::vector<std::uint32_t> column_of;       // an unknown's column (1 + its index) → the kernel's
  int live_columns = 1;                       // this iteration's: 1 + the coupled unknowns (linearize's)
  HAUSTRA_NEWTON_NODE_BUFFERS(HAUSTRA_DECLARE_NEWTON_BUFFER)
  // The banded LU (the fallback when the sweep's pivots are unsafe) is allocated only for rods up to
  // kBandFallbackNodes: its blocks take ~8 KB a node.
  bool band_available = false;
  bool band = false;                                          // this iteration is solved by the banded LU
  std::vector<double> rhs;                                    // its right-hand sides: a block row per node per column
  kernels::Vector6d base_wrench = kernels::Vector6d::Zero();  // free base: unbalanced total wrench
  std::vector<Eigen::Vector3d> bead_start;                    // the segment's bead positions before a step
  kernels::Pose base_before;                                  // the line search: the base before the step
  double potential = 0.0;  // the incremental potential at the step the line search took
  bool potential_cached = false;
  // The poses are the whole rod's sweep of its strains and base (a line search ended this substep
  // with no range asleep); swept_poses holds such poses, of swept_strain and swept_base (the
  // filter moves the positions; the next frame's start is their sweep again).
  bool poses_swept = false, swept_kept = false;
  kernels::Pose swept_base;
  int max_columns = 1;
  std::size_t singular_node = 0;  // where the condensed sweep's pivot was unsafe
  double law_scale = 1.0;         // the law's rows as condensed (stiffened where Newton's step is not a descent)
  int fallbacks = 0;              // iterations solved by the banded LU this frame
  int backtracks = 0;             // line-search halvings this frame
  int stalls = 0;                 // line searches that took none of a step that was not small, this frame
  bool stalled = false;           // this substep ended on such a line search (the guard's to report)
  int stiffenings = 0;            // re-solves with stiffened law rows this frame
  int chords = 0;                 // iterations that reused the factorization this frame

  void allocate(std::size_t nodes, int columns, bool with_band, std::size_t split_at);
};

using ContactCandidate = Contact;

// An instrument's state that a later frame reads, each field listed once, X(type, name, initial,
// meaning), in the order checkpoints write it (format 6): InstrumentState declares its fields from
// the list and checkpoint.cpp visits them from it. Where the capsule is: its commanded tip, or a
// proxy's (decision 0096), which the commanded one pulls through a capped spring–damper; the axis
// is commanded either way. The virtual coupling (coupling_stiffness > 0): the grasped node, the
// grasp point this frame and last, the coupling's force; a slip waits for the jaws to open.
// clang-format off
#define HAUSTRA_INSTRUMENT_STATE(X)                                                                  \
  X(Eigen::Vector3d, tip, Eigen::Vector3d::Zero(), "the capsule's tip")                               \
  X(Eigen::Vector3d, axis, Eigen::Vector3d::UnitZ(), "its axis")                                      \
  X(Eigen::Quaterniond, frame, Eigen::Quaterniond::Identity(), "d3 along the axis")                   \
  X(bool, closed, false, "the jaws")                                                                  \
  X(bool, cutting, false, "cuts the tissue within its cut radius every frame (decision 0095)")        \
  X(bool, scripted, true, "follows its keyframes until the host sets a pose")                         \
  X(bool, grasping, false, "holds a node")                                                            \
  X(std::size_t, grasp_segment, 0, "the grasped rod")                                                 \
  X(std::size_t, grasp_attachment, 0, "global attachment index")                                      \
  X(std::uint32_t, grasp_bead, 0, "the grasped bead")                                                 \
  X(Eigen::Vector3d, grasp_offset, Eigen::Vector3d::Zero(), "node in the instrument frame")           \
  X(Eigen::Quaterniond, grasp_rotation, Eigen::Quaterniond::Identity(), "node frame in the instrument frame") \
  X(Eigen::Vector3d, force, Eigen::Vector3d::Zero(), "N on the instrument")                           \
  X(Eigen::Vector3d, torque, Eigen::Vector3d::Zero(), "N·m on the instrument")                        \
  X(Eigen::Vector3d, filtered_force, Eigen::Vector3d::Zero(), "the force, low-passed")                \
  X(Eigen::Vector3d, filtered_torque, Eigen::Vector3d::Zero(), "the torque, low-passed")              \
  X(bool, coupled, false, "a virtual coupling holds the grasp")                                       \
  X(std::uint32_t, grasp_node, 0, "the grasped node (global index)")                                  \
  X(Eigen::Vector3d, grasp_target, Eigen::Vector3d::Zero(), "the grasp point this frame")             \
  X(Eigen::Vector3d, target_start, Eigen::Vector3d::Zero(), "… and at the frame's start")             \
  X(Eigen::Vector3d, coupling_force, Eigen::Vector3d::Zero(), "the coupling's force on the instrument") \
  X(bool, slipped, false, "a slip waits for the jaws to open")                                        \
  X(Eigen::Vector3d, command_tip, Eigen::Vector3d::Zero(), "the commanded tip")                       \
  X(Eigen::Vector3d, command_start, Eigen::Vector3d::Zero(), "… at the frame's start")                \
  X(Eigen::Vector3d, proxy_start, Eigen::Vector3d::Zero(), "the proxy's tip at the substep's start")  \
  X(Eigen::Vector3d, proxy_force, Eigen::Vector3d::Zero(), "the coupling's pull on the proxy, N")     \
  X(double, reach, 0.0, "m the proxy may still travel towards its command: its contacts' margin")
// clang-format on

struct InstrumentState {
  HAUSTRA_INSTRUMENT_STATE(HAUSTRA_DECLARE_FIELD)
  // Scratch of a frame, not carried over: what the grasp may pull with this substep, and the
  // event text's numbers of a slip.
  double grasp_limit = 0.0;  // N the grasp may pull with: the force limit less the capsule's push
  double slip_pull = 0.0;    // N: the spring's force when it slipped (for the event's text)
  double slip_strain = 0.0;  // the organ's axial strain when it tore out of the jaws (0: it slipped)
};

struct CollisionState {
  Vec3Buffer bead_center;                    // at the substep's start
  Vec3Buffer bead_position;                  // at the end of the last step, for hosts (World::bead_centres)
  std::vector<double> bead_motion;           // how far each bead moved in the last substep, m
  std::vector<double> reach_radius;          // radius + its share of the candidate margin
  std::vector<ContactCandidate> candidates;  // capacity kept between frames
  std::vector<kernels::SpherePair> pairs;
  std::vector<std::vector<kernels::SpherePair>> chunk_pairs;  // per chunk of beads
  std::vector<std::vector<ContactCandidate>> chunk_candidates;
  std::vector<std::size_t> chunk_count;
  kernels::SphereGrid grid;
  // Per bead, the candidates it takes part in: (candidate << 1) | side, side 1 for the second bead.
  std::vector<std::uint32_t> bead_contact_start;
  std::vector<std::uint32_t> bead_contact;
  std::vector<std::uint32_t> coupled_start;  // per segment (CSR): its coupled contacts
  std::vector<std::uint32_t> coupled;
  std::vector<std::uint32_t> coupled_fill;      // scratch
  Vec3Buffer bead_force;                        // sum over its contacts
  std::vector<Eigen::Matrix3d> bead_stiffness;  // −∂force/∂centre, normal part
  ContactReport report;
};

// The organ meshes' per-frame state: ring poses and how they moved, skinned vertices and normals.
struct MeshState {
  std::vector<kernels::RingPose> ring_pose;  // model.ring_total
  std::vector<float> ring_delta;             // kRingScratchFloats per ring: deltas, then screws
  FloatVec3Buffer position, normal;          // model.mesh_vertex_total
};

// A task of the condense stage: one solve part, or four whole rods of one node count in SIMD lanes.
struct CondenseTask {
  std::array<std::uint32_t, 4> part{};  // into model.solve_parts
  std::uint8_t count = 1;               // 1, or 4 (kernels::kCondensedLanes)
};

// The frame's buffers besides the persistent state's, listed as HAUSTRA_PERSISTENT_STATE.
// clang-format off
#define HAUSTRA_FRAME_STATE(X)                                                                              \
  X(std::vector<double>, strain_substep_start, node, 4, 0.0, scratch, "q^{t−1} of the strain law")          \
  X(Vec3Buffer, position_substep_start, node, 1, Zeros{}, scratch, "for the medium's drag, v = (r − r_start)/Δt") \
  X(RotationBuffer, rotation_substep_start, node, 1, Identities{}, scratch, "for the spin drag")             \
  X(std::vector<double>, generalized_force, node, 4, 0.0, scratch, "R, then M⁻¹R")                          \
  X(Vec3Buffer, force, node, 1, Zeros{}, scratch, "assembled node loads")                                    \
  X(Vec3Buffer, moment, node, 1, Zeros{}, scratch, "… and moments")                                          \
  X(Vec3Buffer, external_force, node, 1, Zeros{}, kept, "the scene's and the host's loads")                  \
  X(Vec3Buffer, external_moment, node, 1, Zeros{}, kept, "… and moments")                                    \
  X(std::vector<std::uint8_t>, filter_exempt, node, 1, 0, scratch, "held nodes the filter leaves alone")     \
  X(std::vector<kernels::Pose>, base_substep_start, segment, 1, kernels::Pose{}, scratch, "the base at the substep's start") \
  X(std::vector<kernels::Vector6d>, base_twist, segment, 1, kernels::Vector6d::Zero(), kept, "free base: (ω, v) about node 0") \
  X(std::vector<kernels::Matrix6d>, base_resistance, segment, 1, kernels::Matrix6d::Identity(), kept, "free base: its resistance") \
  X(std::vector<double>, constraint_scratch, constraint_double, 1, 0.0, scratch, "G, Y, H blocks per constrained segment") \
  X(std::vector<int>, segment_converged, segment, 1, 0, scratch, "within a substep")                         \
  X(std::vector<Eigen::Vector4d>, segment_change, segment, 1, Eigen::Vector4d::Zero(), scratch, "last strain change") \
  X(std::vector<std::uint8_t>, segment_step_cut, segment, 1, 0, scratch, "Newton's last step was scaled down") \
  X(std::vector<std::uint8_t>, segment_solving, segment, 1, 0, scratch, "Newton: this iteration's rods (active and solvable)") \
  X(std::vector<LaggedRatios>, lagged_ratios, segment, 1, LaggedRatios{}, scratch, "lagged: the contraction stage's measure, for the guard") \
  X(std::vector<std::uint8_t>, segment_solvable, segment, 1, 1, scratch, "Newton: 0 when this substep met an unsafe pivot it could not fall back from") \
  X(std::vector<double>, strain_before_update, node, 4, 0.0, kept, "lagged: the strains before the last update") \
  X(std::vector<double>, rod_calm, segment, 1, 0.0, kept, "s every node has been at rest (decision 0119)")     \
  X(std::vector<std::uint8_t>, rod_asleep, segment, 1, 0, kept, "sleeps: held where it is, not solved")       \
  X(std::vector<double>, node_calm, node, 1, 0.0, kept, "s the node has been at rest (sleeping ranges, decision 0127)") \
  X(std::vector<std::uint32_t>, range_first, segment, 1, 0u, kept, "its sleeping range's first node (decision 0127)") \
  X(std::vector<std::uint32_t>, range_last, segment, 1, 0u, kept, "… and last node; 0: no range sleeps")
// clang-format on

// A rod's sleeping range (decision 0127): nodes [first, last] held where they are; the nodes before
// it (the base side, when first > 0) are solved with node `first` held, those after it with node
// `last` held.
struct HeldRange {
  std::size_t first = 0, last = 0;
  [[nodiscard]] bool any() const { return last > 0; }
  [[nodiscard]] bool base_side() const { return any() && first > 0; }
  [[nodiscard]] bool tip_side(std::size_t nodes) const { return any() && last + 1 < nodes; }
};

struct WorldState {
  PersistentState now;
  PersistentState frame_start;  // snapshot: last good frame, and the filter's r^{t−1}

  HAUSTRA_FRAME_STATE(HAUSTRA_DECLARE_BUFFER)
  std::vector<NewtonWorkspace> newton;       // per segment; empty when Newton can never run
  std::vector<CondenseTask> condense_tasks;  // this iteration's (capacity: the solve parts)
  CollisionState collision;
  std::vector<InstrumentState> instruments;
  MeshState mesh;

  // The robust mode's rung (how frames are attempted now), the calm frames since it last climbed
  // or stepped down (at most calm_frames), and how many the rung in force needs before it halves
  // (decision 0109: the first spell is short and doubles when a rung is needed again soon). A
  // frame's outcome depends on them, so they are state, not settings.
  int robust_substeps = 1;
  bool robust_newton = false;
  int robust_good_frames = 0;
  int robust_calm_spell = 0;

  std::uint64_t frame = 0;
  double time = 0.0;

  [[nodiscard]] HeldRange held_range(std::size_t rod) const { return {range_first[rod], range_last[rod]}; }
};

void init_world_state(const WorldModel& model, WorldState& state);

// How many entries of a buffer the model asks for per `per`, and a buffer sized so (the lists' rule).
std::size_t count_of(const WorldModel& model, Per per);
template <class T, class I>
void size_buffer(std::vector<T>& v, std::size_t n, const I& initial) {
  v.assign(n, T(initial));
}
inline void size_buffer(Vec3Buffer& b, std::size_t n, Zeros /*initial*/) { b.resize(n); }
inline void size_buffer(RotationBuffer& b, std::size_t n, Identities /*initial*/) { b.resize(n); }

// Bytes a buffer takes per entry, and the state's per node, from the lists (the memory estimate).
template <class T>
inline constexpr std::size_t kEntryBytes = sizeof(typename T::value_type);
template <>
inline constexpr std::size_t kEntryBytes<Vec3Buffer> = 3 * sizeof(double);
template <>
inline constexpr std::size_t kEntryBytes<RotationBuffer> = 4 * sizeof(double);
#define HAUSTRA_NODE_BYTES(type, name, per, width, initial, role, meaning) \
  +(Per::per == Per::node ? std::size_t{width} * kEntryBytes<type> : 0)
inline constexpr std::size_t kPersistentBytesPerNode = 0 HAUSTRA_PERSISTENT_STATE(HAUSTRA_NODE_BYTES);
inline constexpr std::size_t kFrameBytesPerNode = 0 HAUSTRA_FRAME_STATE(HAUSTRA_NODE_BYTES);
#undef HAUSTRA_NODE_BYTES
// The state per node: the frame and its snapshot (PersistentState twice) and the frame's buffers.
inline constexpr std::size_t kStateBytesPerNode = 2 * kPersistentBytesPerNode + kFrameBytesPerNode;
// The Newton workspace per node of its rod: always, and the banded fallback's besides.
#define HAUSTRA_NEWTON_BYTES(type, name, width, initial, allocated, meaning) \
  +(Allocated::allocated == HAUSTRA_NEWTON_ALLOCATED ? std::size_t{width} * kEntryBytes<type> : 0)
#define HAUSTRA_NEWTON_ALLOCATED Allocated::always
inline constexpr std::size_t kNewtonBytesPerNode = 0 HAUSTRA_NEWTON_NODE_BUFFERS(HAUSTRA_NEWTON_BYTES);
#undef HAUSTRA_NEWTON_ALLOCATED
#define HAUSTRA_NEWTON_ALLOCATED Allocated::with_band
inline constexpr std::size_t kBandBytesPerNode = 0 HAUSTRA_NEWTON_NODE_BUFFERS(HAUSTRA_NEWTON_BYTES);
#undef HAUSTRA_NEWTON_ALLOCATED
#undef HAUSTRA_NEWTON_BYTES

// Views of one segment's slice.
struct SegmentViews {
  kernels::RodPoses<double> poses;
  kernels::StrainView<double> strain;
  kernels::StrainView<double> strain_start;
  kernels::StrainView<double> generalized_force;
  kernels::StrainView<const double> rest;
  std::span<const double> section_length;  // N
  std::span<const double> node_mass;
  kernels::Vec3View<double> force, moment;
};

SegmentViews segment_views(const WorldModel& model, WorldState& state, std::size_t segment);

}  // namespace haustra::detail
