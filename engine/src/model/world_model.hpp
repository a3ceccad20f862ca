#pragma once
// The constant part of a world (MuJoCo's mjModel): built once from a WorldDesc, never written while
// stepping. Per-node arrays are contiguous across segments; a segment is an offset+count range.
#include <array>
#include <cstdint>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include <memory>

#include "haustra/embree_scene.hpp"
#include "haustra/kernels/mesh_normals.hpp"
#include "haustra/kernels/pose.hpp"
#include "haustra/kernels/tissue_law.hpp"
#include "haustra/mesh_io.hpp"
#include "haustra/rod_pose_buffer.hpp"
#include "haustra/world_desc.hpp"
#include "haustra/world_types.hpp"
#include "model/cage_builder.hpp"
#include "model/skin_binding.hpp"

namespace haustra::detail {

inline constexpr std::size_t kMaxConstraintRows = 24;  // four clamps (3 position + 3 frame rows)
// Contacts a Newton iteration couples exactly, per segment (the rest are loads): sizes its columns.
inline constexpr std::size_t kMaxCoupledContacts = 40;
// Rods up to this many nodes keep the banded LU as the condensed sweep's fallback.
inline constexpr std::size_t kBandFallbackNodes = 4096;

// The solver's constants (scene keys until decision 0108; no scene, test or host set them).
// Newton keeps iterating while an active attachment misses its target by more than this (m).
inline constexpr double kAttachmentTolerance = 1e-6;
// Fast mode: a factorization serves at most this many frames (decision 0037).
inline constexpr std::uint64_t kRefactorFrames = 8;
// The guard's limits beside solver.max_displacement: |ε|, |u| h (rad per section), and how many
// segment lengths an active attachment may miss its target by after a frame (Newton holds it
// exactly and the lagged scheme to second order, so more means a failed solve).
inline constexpr double kMaxAxialStrain = 4.0;
inline constexpr double kMaxSectionAngle = std::numbers::pi;
inline constexpr double kMaxAttachmentError = 0.01;

// What the step reads of the solver: the description's fields, checked (decision 0116). The robust
// mode's three limits are run-time settings (World::set_frame_limits, checkpoints' parameters).
struct SolverModel {
  SolverMode mode = SolverMode::newton;
  int iterations = 1;  // per substep
  int substeps = 1;    // per frame
  double relaxation = 1.0;
  double tolerance = 0.0;
  int max_iterations = 8;  // Newton: the most a segment iterates while its line search or a grasp needs it
  InstabilityPolicy on_instability = InstabilityPolicy::recover;
  int max_substeps = 64;
  int max_retries = 16;
  int calm_frames = 120;
  double max_displacement = 4.0;  // the guard: segment lengths a node may move in a frame
};

// Whether the paper's regulator runs; its ζ is each segment's (SegmentInfo::zeta).
struct FilterModel {
  bool enabled = true;
};

// The broad phase `auto` takes brute force below this many beads, the grid from it. bench_collision,
// one thread: brute force costs ~110 ns a bead at 220 beads and ~790 at 1000, the grid ~260 at any
// count; the grid's queries also spread over threads.
inline constexpr std::size_t kBruteForceBelow = 256;

// The contact response and its candidates, resolved: the margin from the beads when the scene left
// it automatic, the broad phase chosen by the bead count.
struct ContactModel {
  double coefficient = 50.0;
  double exponent = 2.0;
  double margin = 0.0;                         // m, resolved
  BroadPhase broad_phase = BroadPhase::brute;  // brute or grid, never automatic
  bool self = true;
  RestExclusions rest_exclusions = RestExclusions::segment;
};

// The static obstacles as the collision stages read them (planes' normals of unit length); the
// triangle meshes live in WorldModel::meshes (Embree), and here only whether each is a container.
struct EnvironmentModel {
  struct Plane {
    Eigen::Vector3d point, normal;
  };
  struct Sphere {
    Eigen::Vector3d center;
    double radius = 0.0;
  };
  struct Capsule {
    Eigen::Vector3d a, b;
    double radius = 0.0;
  };
  std::vector<Plane> planes;
  std::vector<Sphere> spheres;
  std::vector<Capsule> capsules;
  std::vector<std::uint8_t> mesh_container;  // per mesh obstacle: keeps beads inside it
};

// An instrument as the step reads it: checked, its axes of unit length, its keyframes in increasing
// time. The coupling's three numbers are run-time settings (World::set_instrument_coupling).
struct InstrumentModel {
  std::string name;  // for events' text
  double radius = 0.0, length = 0.0, grasp_reach = 0.0;
  bool hold_frame = false;
  double force_filter = 0.0;
  double coupling_stiffness = 0.0, coupling_damping = 0.0, force_limit = 0.0;
  bool proxy = false;  // as described; a proxy needs a coupling too (is_proxy)
  double holding_force = 0.0, cut_radius = 0.0;
  Eigen::Vector3d tip, axis;  // the pose before the host sets one, without keyframes
  std::vector<InstrumentKeyframe> keyframes;
};

// An attachment slot: scene attachments hold a fixed node; grasp slots (one per instrument and
// segment) take whichever node an instrument closes on, at run time. The node and whether the
// frame is held live in the state; the model fixes the slot's capacity in constraint rows.
struct AttachmentModel {
  std::size_t initial_node = 0;  // local to the segment
  bool hold_frame = false;       // capacity: 6 rows if the frame may be held, else 3
  std::size_t instrument = 0;    // for grasp slots
  bool grasp_slot = false;
  [[nodiscard]] std::size_t rows() const { return hold_frame ? 6 : 3; }
};

// One rod, solved as a whole: a segment, or a chain of segments (its pieces; decision 0030). The
// stages that solve and collide see rods; what the API calls a segment is a SegmentPiece.
struct SegmentModel {
  SegmentInfo info;
  std::size_t node_offset = 0;
  std::size_t node_count = 0;  // N+1
  double mean_section = 0.0;
  std::array<double, 4> stiffness{};  // k_c in the law (zero for viscous components)
  std::array<double, 4> viscosity{};  // η_c (zero for elastic components)
  std::array<StrainLaw, 4> law{};
  // EXP2 tissue in bending and stretch (kernels/tissue_law): the stress is evaluated per node and
  // the Newton system takes its tangent; false: Hooke's constant stiffness.
  bool exp2 = false;
  kernels::Exp2Tissue tissue;
  kernels::TubeSection tube;
  BaseMode base_mode = BaseMode::clamped;
  double failure_strain = 0.0;  // axial: a coupled grasp pulling past it lets go
  bool has_drag = false;
  kernels::Pose initial_base;
  std::vector<AttachmentModel> attachments;
  std::size_t constraint_rows = 0;    // capacity: all attachments active
  std::size_t attachment_offset = 0;  // into the world's attachment state arrays
  // Offsets into the world's constraint scratch (doubles), valid when constraint_rows > 0.
  std::size_t constraint_scratch_offset = 0;
  std::size_t bead_offset = 0;  // into the world's bead arrays
  std::size_t bead_count = 0;
  std::size_t anchor_offset = 0;  // into the world's anchors (connective tissue)
  std::size_t anchor_count = 0;
  // Its nodes carry a load stiffness in the Newton system: the medium's drag, beads' contacts
  // (and the grasps on them), anchors.
  bool has_load_stiffness = false;
  std::size_t first_piece = 0;  // into WorldModel::pieces
  std::size_t piece_count = 1;
  // Newton splits a long rod's solve at this node into a tip part and a base part that condense at
  // once (decision 0036); 0: solved whole. Fixed by the model, so any thread count splits alike.
  std::size_t split_node = 0;
  [[nodiscard]] std::size_t sections() const { return node_count - 1; }
};

// Rods from this many nodes are split; the base part takes this fraction of the rod. It carries the
// joint's 10 unknowns and the back-substitution to the joint; the tip part its responses, affine in
// the joint's start (its columns + 10, decision 0087). On `bowel` (641 nodes) the two condense tasks
// took 235/212, 213/250 and 190/272 µs (tip/base, one thread) at 0.48, 0.52 and 0.56: equal near 0.49.
inline constexpr std::size_t kSplitMinNodes = 256;
// Whether a rod of n nodes is solved in two parts (decision 0040). Fast mode keeps long rods whole:
// its chord iterations replay a whole rod's recorded factorization (decision 0037).
inline bool rod_is_split(std::size_t n, SolverMode mode) { return n >= kSplitMinNodes && mode != SolverMode::fast; }
inline constexpr double kSplitBaseFraction = 0.48;

// A unit of the Newton solve's parallel work: a whole rod, or one part of a split rod.
enum class SolvePartKind : std::uint8_t { whole, tip, base };
struct SolvePart {
  std::uint32_t rod = 0;
  SolvePartKind kind = SolvePartKind::whole;
};

// What the API calls a segment: a whole rod, or one piece of a chained rod. Pieces of a chain
// share their joint nodes (the tip node of one is the base node of the next), so their node ranges
// overlap by one; their beads do not (a bead on a joint node belongs to the later piece).
struct SegmentPiece {
  SegmentInfo info;             // its name, global node range and rest length; the rod's stiffnesses
  std::size_t rod = 0;          // into WorldModel::segments
  std::size_t first_node = 0;   // local to the rod
  std::size_t bead_offset = 0;  // into the world's bead arrays
  std::size_t bead_count = 0;
};

class StaticMeshes;

// Connective tissue (decision 0095): an anchor on every node of each range a segment describes,
// ordered by rod, then range, then node; a rod's anchors are [anchor_offset, + anchor_count).
// Constant; whether an anchor still holds is state (torn or cut).
struct AnchorModel {
  std::vector<std::uint32_t> node;      // global node index
  std::vector<std::uint32_t> range;     // into WorldModel::anchor_ranges
  std::vector<Eigen::Vector3d> target;  // m, where the anatomy holds the node
  std::vector<double> stiffness;        // N/m: stiffness per length × the node's share of the rod
  std::vector<double> damping;          // N·s/m, likewise
  std::vector<double> slack;            // m; a root anchor's rest distance included
  std::vector<double> strength;         // N; infinity: never tears
  std::vector<double> support;          // N/m against sinking along gravity
  std::vector<double> wall;             // m from the node to the wall, where the tissue holds the tube
  // Its hold on the node's frame towards the rest frame (a rest anchor's: stiffness and damping
  // per length × the tube's radius², as tissue fixed round the wall; a root's tether holds none).
  std::vector<Eigen::Quaterniond> rest_rotation;
  std::vector<double> turn_stiffness;  // N·m/rad
  std::vector<double> turn_damping;    // N·m·s/rad
  [[nodiscard]] std::size_t size() const { return node.size(); }
};

// A range of anchors as the description named it: for events and the API.
struct AnchorRange {
  std::string name;
  std::size_t rod = 0;
  std::size_t first = 0, count = 0;  // into AnchorModel
};

// Beads of all segments, ordered by segment then node: what the collision stages read.
struct BeadModel {
  std::vector<std::uint32_t> node;  // global node index
  std::vector<std::uint32_t> segment;
  std::vector<double> radius;   // m
  std::vector<double> modulus;  // Young's modulus of its tissue, Pa
  // Pairs of one segment that overlap or touch at rest never collide: for bead i, the excluded
  // partners j > i, ascending (CSR).
  std::vector<std::uint32_t> exclusion_start;
  std::vector<std::uint32_t> exclusion;
  [[nodiscard]] std::size_t size() const { return node.size(); }
  [[nodiscard]] bool excluded(std::uint32_t a, std::uint32_t b) const;
};

// A segment's organ mesh: its cage, its binding, and where its rings and vertices live in the
// world's buffers.
struct SegmentMesh {
  bool enabled = false;
  MeshInfo info;
  CageModel cage;
  SkinBinding binding;
  std::size_t ring_offset = 0;
  std::size_t vertex_offset = 0;  // into the world's mesh buffers
  std::size_t triangle_offset = 0;
};

// Skinning and normals run over fixed chunks of blocks, so the work splits the same way whatever
// the thread count (each vertex is computed alone: any split gives the same bits).
struct SkinChunk {
  std::uint32_t piece = 0;
  std::size_t first_block = 0;  // local to the segment's binding
  std::size_t blocks = 0;
};

struct NormalChunk {
  std::uint32_t piece = 0;
  std::size_t first_vertex = 0;  // world mesh vertex
  std::size_t vertices = 0;
  std::size_t first_block = 0;  // its whole blocks of 8 in WorldModel's normal blocks
};

// Rods at rest sleep (decision 0119): what the frame reads of the scene's [sleep].
struct SleepModel {
  bool enabled = false;
  double speed = 0.0;   // m/s
  double time = 0.0;    // s
  bool ranges = false;  // ranges within a rod too (decision 0127)
};

// A sleeping range (decision 0127) keeps this many calm nodes awake between itself and the first
// node that moves, and sleeps only when it is at least kMinSleepingRange nodes long (a shorter one
// saves less than its boundary costs).
inline constexpr std::size_t kRangeBand = 8;
inline constexpr std::size_t kMinSleepingRange = 16;

struct WorldModel {
  Eigen::Vector3d gravity;
  double dt = 0.0;
  double frame_budget = 0.0;                     // s; 0: none (decision 0061); a run-time setting
  MeshUpdate mesh_update = MeshUpdate::on_read;  // decision 0060
  SleepModel sleep;                              // decision 0119; speed and time, run-time settings
  SolverModel solver;
  FilterModel filter;
  std::vector<SegmentModel> segments;  // the rods
  std::vector<SegmentPiece> pieces;    // the API's segments, in rod order
  std::vector<SolvePart> solve_parts;  // the rods' Newton solves as parallel work, in rod order
  std::size_t node_total = 0;
  std::size_t attachment_total = 0;
  std::size_t constraint_scratch_total = 0;

  // Per node, global index. Section k of a segment is stored at its node k (the last node's
  // entry is 0), so sections share the node offsets.
  std::vector<double> section_length;
  std::vector<double> rest_strain;  // 4 per node
  std::vector<double> node_mass;
  std::vector<double> node_drag;       // N·s/m, the medium's drag on the node
  std::vector<double> node_spin_drag;  // N·m·s, on the node's rotation
  std::vector<double> mass_inv_pivot;
  std::vector<double> mass_lower;
  // Initial external loads and attachment targets, copied into the state at creation.
  std::vector<double> initial_load;  // 6 per node: force xyz, moment xyz
  BeadModel beads;
  AnchorModel anchors;
  std::vector<AnchorRange> anchor_ranges;
  ContactModel contact;
  EnvironmentModel environment;
  std::shared_ptr<const StaticMeshes> meshes;
  std::vector<InstrumentModel> instruments;

  // Organ meshes (one entry per piece, disabled where a piece has none).
  std::vector<SegmentMesh> meshes_of;
  std::size_t ring_total = 0;
  std::size_t mesh_vertex_total = 0;
  std::vector<std::array<std::uint32_t, 3>> mesh_triangles;  // world vertex indices
  // Per vertex (CSR): the other two corners of each incident triangle, and the same as slots of
  // blocks of 8 vertices (kernels/mesh_normals).
  std::vector<std::uint32_t> vertex_corner_start, vertex_corner_pairs;
  std::vector<std::uint32_t> normal_slot_start, normal_gather_pairs;
  std::vector<kernels::NormalSlot> normal_slots;
  std::vector<SkinChunk> skin_chunks;
  std::vector<NormalChunk> normal_chunks;
  // A chain's mesh from a file is cut into its pieces, each skinned on its own cage: the vertices
  // its cut copied are one point (CSR groups of world vertex indices, welded after skinning), and
  // each copy's normal sums the triangles of every piece around it.
  std::vector<std::uint32_t> seam_group_start, seam_group_members;
  bool any_mesh = false;

  std::vector<Eigen::Vector3d> initial_attachment_target;
  std::vector<Eigen::Quaterniond> initial_attachment_rotation;
  std::vector<std::uint8_t> initial_attachment_active;
};

// Builds the model; throws haustra::Error naming the segment and the field. With `binding_from`, a model
// of the same description but for the rods' material (World::set_material), its organ meshes'
// cages and bindings are taken as they are instead of being built again (the costly part).
WorldModel build_world_model(const WorldDesc& desc, const WorldModel* binding_from = nullptr);

// The beads of one segment (nodes and radii) and, with all segments placed, the world's bead
// arrays and rest-pose exclusions; the environment and the instruments. Part of the builder.
void build_beads(const WorldDesc& desc, const std::vector<Eigen::Vector3d>& initial_positions,
                 const std::vector<RodPoseBuffer>& rest_poses, const std::vector<TriangleMesh>& meshes, WorldModel& m);
void build_environment(const WorldDesc& desc, WorldModel& m);
// An instrument's model from its description, checked (check_instrument).
InstrumentModel instrument_model(const InstrumentDesc& d);

// Organ meshes: loaded or generated around each segment's rest pose before the beads (a bead may
// take its radius from the mesh), then caged and bound once the beads exist.
// A piece's mesh vertices placed along its rod once for the whole organ's surface (a mesh from a
// file; empty otherwise): each one's place (m from the piece's first node) and, in a chain, its index
// in the organ's whole mesh (the copies of one index, in two pieces, are welded after skinning).
struct PiecePlaces {
  std::vector<double> place;
  std::vector<std::uint32_t> origin;
  // The whole surface's placing (on the organ's first piece; 0 on the others): CageReport's.
  std::size_t surface_pieces = 0, closest_pieces = 0, followed = 0, fused_copies = 0;
};
std::vector<TriangleMesh> load_organ_meshes(const WorldDesc& desc, const std::vector<RodPoseBuffer>& rest_poses,
                                            const WorldModel& m, std::vector<PiecePlaces>& placed);
void bind_organ_meshes(const WorldDesc& desc, const std::vector<RodPoseBuffer>& rest_poses,
                       std::vector<TriangleMesh>& meshes, const std::vector<PiecePlaces>& placed, WorldModel& m);
// The median distance from a station to the mesh wall over a ring of rays in its (d1, d2) plane;
// wall: an Embree scene of the mesh. Throws when no ray meets the wall within `reach`.
// The median distance from a rod station to the mesh over 16 rays in its normal plane; none when
// fewer than half the rays meet the mesh within `reach` (past an open end, outside the mesh).
std::optional<double> mesh_cross_section_radius(const EmbreeScene& wall, const kernels::Pose& station, double reach);

}  // namespace haustra::detail
