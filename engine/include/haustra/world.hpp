#pragma once
// A world: an immutable model (built once from a WorldDesc) and its per-frame state, stepped
// frame by frame. Buffers are structure-of-arrays, contiguous across all segments; a segment is an
// offset+count range into them. Views returned here stay valid until the next call to step().
#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <source_location>
#include <span>
#include <string>
#include <string_view>
#include <thread>
#include <utility>
#include <vector>

#include "haustra/error.hpp"
#include "haustra/gpu_skin.hpp"
#include "haustra/kernels/cage_rings.hpp"
#include "haustra/kernels/pose.hpp"
#include "haustra/kernels/spans.hpp"
#include "haustra/profile.hpp"
#include "haustra/report_fields.h"
#include "haustra/world_desc.hpp"
#include "haustra/world_types.hpp"

namespace haustra {

namespace detail {
struct CarryMap;  // where a world's parts go when it is rebuilt (engine/src/step/state_carry_over.hpp)
}  // namespace detail

// What one frame may cost (decision 0100): the robust mode's ladder (Newton, then twice the
// substeps each time) stops at max_substeps and after max_retries redone attempts — a frame it
// cannot hold within them stops as unstable, its event naming the cap; a rung it climbed to is
// kept for a calm spell before its substeps halve again: 8 frames, doubling up to calm_frames while
// rungs are needed again within calm_frames calm frames (decision 0109).
struct FrameLimits {
  int max_substeps = 64;  // solver.max_substeps
  int max_retries = 16;   // solver.max_retries
  int calm_frames = 120;  // solver.calm_frames
};

class World {
 public:
  // Builds the model and the initial state. Throws haustra::Error naming the segment and field.
  static std::unique_ptr<World> create(const WorldDesc& desc);
  ~World();
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  // One thread at a time (decision 0100). Every call that steps the world, changes it or brings its
  // meshes up to date holds it for its duration; the same call from a second thread meanwhile
  // throws Error{busy} instead of racing it, and so does any such call made from inside a step on
  // the stepping thread (a job system's callback). A host may hold it across several calls of its
  // own (nested holds on one thread are free): the C API does, so that its readers are refused too
  // while another thread steps. Plain readers (views, counts) do not take it.
  class Use {
   public:
    explicit Use(const World& world, const std::source_location& where = std::source_location::current());
    Use(const World& world, std::string_view call);  // call: named in the error ("" for none)
    ~Use();
    Use(const Use&) = delete;
    Use& operator=(const Use&) = delete;

   private:
    void take(std::string_view call);
    const World& world_;
  };

  // One frame of dt. On an instability the state stays at the last good frame and, once the
  // robust mode (if enabled) cannot recover within the frame's limits, Error{unstable} is thrown
  // naming segment, node, stage.
  void step();

  // Segments in the order of the description, a chain's pieces one after another. Pieces of a
  // chain share their joint nodes (segment(i).nodes overlap by one), so node_count() is below the
  // sum of the segments' counts when there are chains.
  [[nodiscard]] std::size_t segment_count() const;
  [[nodiscard]] std::size_t node_count() const;  // all segments
  [[nodiscard]] const SegmentInfo& segment(std::size_t index) const;
  // The first segment of the chain a segment belongs to (itself when it is not chained).
  [[nodiscard]] std::size_t chain_of(std::size_t segment) const;
  [[nodiscard]] double dt() const;
  [[nodiscard]] std::uint64_t frame() const;
  [[nodiscard]] double time() const;

  [[nodiscard]] kernels::Vec3View<const double> node_positions() const;
  [[nodiscard]] kernels::RotationView<const double> node_rotations() const;
  [[nodiscard]] kernels::StrainView<const double> strains() const;
  [[nodiscard]] kernels::StrainView<const double> rest_strains() const;
  [[nodiscard]] std::span<const double> section_lengths() const;  // per node: section k at node k
  [[nodiscard]] kernels::Pose base_pose(std::size_t segment) const;

  // Sets a segment's configuration directly: its base pose and node strains (4 per node, κ1 κ2 τ ε),
  // then rebuilds its nodes, rings and mesh. For studies, tests and hosts that replay or drive a
  // rod themselves; the next step() continues from here. A chain is posed whole, through its first
  // segment, with 4 strains for every node of the chain.
  void pose_rod(std::size_t segment, const kernels::Pose& base, std::span<const double> strains);

  // External load on one node (global node index), world frame, held until changed.
  void set_external_load(std::size_t node, const Eigen::Vector3d& force, const Eigen::Vector3d& moment);
  // Writing state from arrays (decision 0102). A rod's configuration is its base pose and its node
  // strains; node positions and frames follow from them (the forward sweep). Each call checks all it
  // is given (sizes, finite numbers, the rod's constraints) before it writes anything, throwing
  // Error{invalid_argument} naming the node or section; then, as pose_rod, it rebuilds the nodes,
  // rings and meshes, and the finite-difference velocities read zero (as after a restore).
  // All nodes' strains, 4 per node (κ1 κ2 τ ε, as strains()); every rod rebuilt from its base pose.
  void set_strains(std::span<const double> strains);
  // All nodes' poses: node 0 of each rod becomes its base, and each section's strain is the SE(3)
  // logarithm of its nodes' relative pose over its length, split between its two nodes so that the
  // strains change least. Refused where a section would shear by more than shear_tolerance of its
  // length (the rod is unshearable) or turn back on itself.
  void set_node_poses(kernels::Vec3View<const double> positions, kernels::RotationView<const double> rotations,
                      double shear_tolerance = 1e-6);
  // All nodes' positions: the rod is placed through them with frames that turn least (no twist),
  // each section an arc to the next point; refused where a section would turn by more than 90°.
  void set_node_positions(kernels::Vec3View<const double> positions);
  // A rod's base pose (a chain's, through any of its pieces), its strains kept: the rod moves rigidly.
  void set_base_pose(std::size_t segment, const kernels::Pose& base);
  // Many nodes' loads at once (3 values per node, world frame; moments may be empty): replacing what
  // the nodes held (add = false; a node listed twice gets the sum of its entries) or added to it.
  void set_external_loads(std::span<const std::uint32_t> nodes, std::span<const double> forces,
                          std::span<const double> moments, bool add = false);
  // A load per metre of rest length along a segment (N/m and N·m/m, 3 values per node of the segment,
  // world frame; moments may be empty), lumped onto its nodes by their share of the rest length (half
  // of each section beside them): set as set_external_loads does on the segment's nodes.
  void set_distributed_load(std::size_t segment, std::span<const double> force_per_length,
                            std::span<const double> moment_per_length, bool add = false);
  // Attachments are numbered per segment in the order of SegmentDesc::attachments (then one grasp
  // slot per instrument); every piece of a chain addresses the chain's attachments.
  void set_attachment_target(std::size_t segment, std::size_t attachment, const Eigen::Vector3d& position);
  void set_attachment_target_rotation(std::size_t segment, std::size_t attachment, const Eigen::Quaterniond& rotation);
  void set_attachment_active(std::size_t segment, std::size_t attachment, bool active);
  // How many a segment addresses: its chain's SegmentDesc::attachments, then its grasp slots.
  [[nodiscard]] std::size_t attachment_count(std::size_t segment) const;
  // One attachment as it stands: its node (along the chain), whether it holds, whether it is an
  // instrument's grasp slot (and whose), its target, and its force and moment on the rod last frame.
  [[nodiscard]] AttachmentReading attachment(std::size_t segment, std::size_t attachment) const;
  // Force (and moment) the attachment exerted on the rod in the last frame, world frame.
  [[nodiscard]] Eigen::Vector3d attachment_force(std::size_t segment, std::size_t attachment) const;
  [[nodiscard]] Eigen::Vector3d attachment_moment(std::size_t segment, std::size_t attachment) const;

  // Beads, ordered by segment then node.
  [[nodiscard]] std::size_t bead_count() const;
  [[nodiscard]] Range beads(std::size_t segment) const;
  [[nodiscard]] std::span<const double> bead_radii() const;
  [[nodiscard]] std::span<const std::uint32_t> bead_nodes() const;  // global node index of each bead
  // Bead centres (their nodes' positions) at the end of the last step, or as created, posed or restored.
  [[nodiscard]] kernels::Vec3View<const double> bead_centres() const;
  [[nodiscard]] bool beads_may_collide(std::size_t a, std::size_t b) const;  // false for rest-pose neighbours
  [[nodiscard]] const ContactReport& contacts() const;
  [[nodiscard]] std::span<const Contact> contact_list() const;  // valid until the next step

  // Connective tissue (decision 0095): anchors by segment, range and node, each holding its node
  // towards where the anatomy holds it (its target) until it tears (an event) or is cut. Chains'
  // anchors belong to their rod, like attachments.
  [[nodiscard]] std::size_t anchor_count() const;
  [[nodiscard]] std::span<const std::uint32_t> anchor_nodes() const;      // global node index
  [[nodiscard]] std::span<const Eigen::Vector3d> anchor_targets() const;  // m
  [[nodiscard]] std::span<const std::uint8_t> anchors_intact() const;     // 1 while it holds
  // Each anchor's tension now, N (0 once torn or cut), into out (anchor_count() values).
  void anchor_tensions(std::span<double> out) const;
  // Dissection: cuts every intact anchor whose tissue (from the tube's wall round its node to its
  // target) passes within `radius` of `centre` (m), records a `cut` event per range, and returns how
  // many it cut.
  std::size_t cut_tissue(const Eigen::Vector3d& centre, double radius);

  // Instruments. Setting a pose hands the instrument from its script to the host for good. A proxy
  // instrument (decision 0096) follows its commanded pose through its coupling from the next step
  // (placed there at once before the first step); instrument(i).tip is where its capsule is.
  [[nodiscard]] std::size_t instrument_count() const;
  void set_instrument_pose(std::size_t instrument, const Eigen::Vector3d& tip, const Eigen::Vector3d& axis);
  void set_instrument_grasp(std::size_t instrument, bool closed);
  // While on, the instrument cuts the connective tissue within its cut_radius of its tip each frame.
  void set_instrument_cutting(std::size_t instrument, bool cutting);
  [[nodiscard]] InstrumentReading instrument(std::size_t instrument) const;

  // Organ meshes. Positions and normals are float SoA buffers over all segments' meshes, one
  // after the other (each segment's range in mesh(s).vertices, in the order of its input mesh),
  // updated at the end of every step and valid until the next one. Triangles index those buffers.
  [[nodiscard]] const MeshInfo& mesh(std::size_t segment) const;
  [[nodiscard]] std::size_t mesh_buffer_size() const;
  [[nodiscard]] kernels::Vec3View<const float> mesh_positions() const;
  [[nodiscard]] kernels::Vec3View<const float> mesh_normals() const;
  [[nodiscard]] std::span<const std::array<std::uint32_t, 3>> mesh_triangles() const;
  // Per mesh vertex (indexed as mesh_positions), the node (into node_positions) at its place along
  // its rod: the stretch of organ it moves with (decision 0117), for measures and picking. Not the
  // node nearest in space, which on the inside of a bend or beside another loop is another stretch's.
  [[nodiscard]] std::vector<std::uint32_t> mesh_vertex_nodes() const;
  // A segment's cage at the current pose (for drawing and checks) and its ring poses.
  [[nodiscard]] std::vector<Eigen::Vector3d> cage_vertices(std::size_t segment) const;
  [[nodiscard]] std::span<const std::array<std::uint32_t, 3>> cage_triangles(std::size_t segment) const;
  [[nodiscard]] std::span<const kernels::RingPose> ring_poses(std::size_t segment) const;
  // Per cage vertex, the ring that carries it (an index into ring_poses(segment)).
  [[nodiscard]] std::span<const std::uint32_t> cage_vertex_rings(std::size_t segment) const;

  // The mesh at render rate (decision 0060). With world.mesh_update = "on_read" (the default) a
  // step leaves the meshes behind; the accessors above bring them up to the current frame in the
  // caller's thread (so, like step(), not from two threads at once). A reader on another thread instead takes the ring
  // poses from the stepping thread (current_rings, cheap) and makes the mesh from them itself (mesh_from_rings, which
  // reads only the model and may run while the world steps): the same bits either way.
  [[nodiscard]] std::size_t ring_count() const;  // all segments' cage rings
  void current_rings(std::span<kernels::RingPose> out) const;
  // ring_delta: kRingScratchFloats × ring_count() floats of scratch; positions and normals:
  // mesh_buffer_size() each.
  void mesh_from_rings(std::span<const kernels::RingPose> rings, std::span<float> ring_delta,
                       kernels::Vec3View<float> positions, kernels::Vec3View<float> normals) const;
  [[nodiscard]] MeshUpdate mesh_update() const;
  // Skinning on the host's GPU (decision 0110): the binding as GPU-ready buffers (built on the first
  // call, in the caller's thread; kept until the world is rebuilt), and a frame's ring data,
  // kGpuRingDataFloats × ring_count() floats (the rings' rows, then the along-rod screws, decision
  // 0122; kGpuRingFloats × ring_count(): the rows alone, what a host before ABI 17 reads): gpu_ring_frame makes the
  // current frame's rings alone (no vertex is skinned); gpu_ring_frame_from makes them from poses another thread
  // published (current_rings), reading only the model, so it may run while the world steps.
  [[nodiscard]] const GpuSkinBinding& gpu_skin_binding() const;
  void gpu_ring_frame(std::span<float> out) const;
  void gpu_ring_frame_from(std::span<const kernels::RingPose> rings, std::span<float> out) const;

  // The deadline of a frame in seconds (world.frame_budget, decision 0061): a frame that takes
  // longer is counted in its profile (`late`) and in late_frames(). 0 turns it off.
  void set_frame_budget(double seconds);
  [[nodiscard]] double frame_budget() const;
  [[nodiscard]] std::uint64_t late_frames() const;  // since the world was created

  [[nodiscard]] Energy energy() const;

  // Run-time parameters, between frames and without a rebuild: each is checked as the scene's field
  // would be (FieldError naming it), then takes effect at the next step; desc() follows, so a
  // checkpoint, a copy or a reconfigure sees the value in force. A grasp's coupling may change its
  // stiffness, damping and force limit but not switch between rigid (0) and coupled (> 0).
  void set_gravity(const Eigen::Vector3d& gravity);
  void set_dt(double dt);
  void set_instrument_coupling(std::size_t instrument, double stiffness, double damping, double force_limit);
  [[nodiscard]] Eigen::Vector3d gravity() const;
  // The load set_external_load (or the scene) holds on a node: force, moment.
  [[nodiscard]] std::pair<Eigen::Vector3d, Eigen::Vector3d> external_load(std::size_t node) const;

  // Derived readings, computed on request into caller-owned arrays of 3 per node (x, y, z per node).
  // Velocities are finite differences over the last frame: (r − r₀)/dt and the rotation vector of
  // R·R₀ᵀ over dt (world frame); zero before the first step and after a pose or a restore.
  void node_velocities(std::span<double> linear, std::span<double> angular) const;
  // Per section (node k's section), from the tissue law at the current strains and their rate over
  // the last frame (elastic and viscous parts; the elastic part alone before the first frame): the
  // internal moment in the material frame (about d1, d2, twist about d3), N·m, and the internal
  // force in the material frame (0, 0, axial), N.
  void section_stresses(std::span<double> moments, std::span<double> forces) const;

  // Checkpoints: everything a later frame depends on, as bytes (docs/decisions/0026-checkpoints.md).
  // Restoring into a world built from the same scene and stepping on gives the same bits as never
  // having stopped. A checkpoint of another model, a damaged or truncated one, is refused with
  // Error{parse} naming `source`, and the world is left as it was. Restoring rebuilds the meshes;
  // views stay where they were. Events and the profile are not part of it.
  [[nodiscard]] std::vector<std::byte> save_checkpoint() const;
  void restore_checkpoint(std::span<const std::byte> bytes, const std::string& source = "(memory)");
  // The same through a file: written whole to a temporary beside it, then renamed over it.
  void save_checkpoint_file(const std::string& path) const;
  void restore_checkpoint_file(const std::string& path);
  // Whether restoring this checkpoint would rebuild the rods (its material is not the world's:
  // decision 0099), so a FramePublisher's reader may hold no frame meanwhile. Errors as restoring.
  [[nodiscard]] bool checkpoint_rebuilds(const std::string& path) const;

  // Between frames, a segment (or a chain: all its pieces) joins the world, or leaves it
  // (docs/decisions/0031-add-remove-segments.md). The model is rebuilt (as long as creating the
  // world took); every other segment keeps its state and steps on as if nothing had changed. A
  // description the builder refuses leaves the world as it was. Indices of the segments after a
  // removed one move down; views into the world's buffers are invalidated.
  std::size_t add_segment(const SegmentDesc& segment);  // returns the new segment's index
  void remove_segment(std::size_t segment);             // a chain goes whole, named by its first segment

  // Between frames, what a host adds to a world or takes out of it (decision 0106): instruments,
  // obstacles, a segment's attachments and its ranges of connective tissue. Each rebuilds the model
  // as add_segment does and carries every state over (an instrument's pose and grasp, which
  // attachments hold, which anchors are torn or cut), so what is left steps on exactly as if nothing
  // had changed; a description the builder refuses leaves the world as it was. Each add returns the
  // new part's index: instruments after the others, an obstacle after the others of its kind, an
  // attachment after the chain's own (its grasp slots move up by one), a range of anchors after the
  // chain's. Removing one moves those after it down by one; removing an instrument lets go of what
  // it grasped. Views into the world's buffers are invalidated. A segment names its chain (any of
  // its pieces), and an attachment's or anchors' nodes count along the whole chain.
  std::size_t add_instrument(const InstrumentDesc& instrument);
  void remove_instrument(std::size_t instrument);
  std::size_t add_obstacle(const ObstacleDesc& obstacle);
  void remove_obstacle(ObstacleKind kind, std::size_t index);
  [[nodiscard]] std::size_t obstacle_count(ObstacleKind kind) const;
  std::size_t add_attachment(std::size_t segment, const AttachmentDesc& attachment);
  void remove_attachment(std::size_t segment, std::size_t attachment);  // not a grasp slot
  std::size_t add_anchors(std::size_t segment, const AnchorsDesc& anchors);
  void remove_anchors(std::size_t segment, std::size_t range);
  [[nodiscard]] std::size_t anchor_range_count(std::size_t segment) const;  // the chain's ranges
  // The same world under a changed description (solver, filter, gravity, tissue law, beads, cage,
  // skinning; the viewer's knobs): the model is rebuilt and the state carried over. `next` keeps
  // the segments and their node counts (else Error{invalid_argument} names the first that differs,
  // and the world is left as it was). A grasp is let go when its segment's beads change.
  void reconfigure(WorldDesc next);
  [[nodiscard]] const WorldDesc& desc() const;  // the description the model was built from
  // A segment's (a chain's, through its first piece) material and relaxation time changed: the
  // rods are rebuilt and the state carried over as by reconfigure, but the organ meshes' cages and
  // bindings are kept (they depend on the rod's shape and beads, not on its material), so it costs
  // a fraction of a rebuild with a mesh. Checked as the scene's fields.
  void set_material(std::size_t segment, const MaterialDesc& material, double relaxation_time);
  // The description of a segment's chain (its first piece's entry of desc().segments).
  [[nodiscard]] const SegmentDesc& segment_desc(std::size_t segment) const;

  // Keeps the buffers behind every view above alive for as long as the handle lives: past the
  // world's destruction and past add_segment / remove_segment, which move the world to new buffers
  // and leave the old ones to the handles that still hold them. For hosts whose views outlive
  // calls (the Python module). Every Vec3View of this class is one block, x then y then z
  // (y.data() == x.data() + size()), so a host can see it as one strided 3 × n array; likewise
  // node_rotations(), w then x then y then z.
  [[nodiscard]] std::shared_ptr<const void> buffers_keeper() const;

  // The limits of a frame's cost (FrameLimits above), from the next step; checked as the scene's
  // solver fields. Lowering max_substeps lowers the rung in force to it.
  void set_frame_limits(const FrameLimits& limits);
  [[nodiscard]] FrameLimits frame_limits() const;

  [[nodiscard]] const FrameProfile& last_profile() const;
  // Whether the node (all segments' numbering) sleeps through the next frame, held where it is: its
  // rod asleep (decision 0119) or within its rod's sleeping range (decision 0127). For a viewer to
  // show what is not being solved, and for a host to know what will not move unless woken.
  [[nodiscard]] bool node_asleep(std::size_t node) const;
  // The events recorded and not yet taken, oldest first (at most 1,024 wait; later ones are
  // dropped and counted until some are taken).
  [[nodiscard]] std::span<const Event> events() const;
  // Moves the oldest waiting events into `out` (as many as fit) and returns how many; they leave
  // events(), making room for more. `dropped` (may be null) receives how many were lost since the
  // last take because the queue was full.
  std::size_t take_events(std::span<Event> out, std::uint64_t* dropped = nullptr);
  [[nodiscard]] int threads() const;

 private:
  struct Impl;  // engine/src/world_impl.hpp
  explicit World(std::unique_ptr<Impl> impl);
  void rebuild(WorldDesc next, std::span<const std::size_t> rod_map, bool carry_solver, bool keep_mesh_binding = false);
  // The world rebuilt from `next`, its state carried over, not yet in place (rebuild swaps it in).
  [[nodiscard]] std::unique_ptr<Impl> rebuilt(const WorldDesc& next, std::span<const std::size_t> rod_map,
                                              bool carry_solver, bool keep_mesh_binding) const;
  [[nodiscard]] std::unique_ptr<Impl> rebuilt(const WorldDesc& next, const detail::CarryMap& map, bool carry_solver,
                                              bool keep_mesh_binding) const;
  void rebuild(WorldDesc next, const detail::CarryMap& map, bool carry_solver);
  std::shared_ptr<Impl> impl_;  // shared with buffers_keeper()'s handles
  // Use's state: the thread holding the world (none: id{}), how many nested holds it has, and
  // whether it is inside step(). Only the holding thread reads or writes the last two.
  mutable std::atomic<std::thread::id> user_{};
  mutable int holds_ = 0;
  mutable bool stepping_ = false;
};

// What a world will hold, estimated from its description before anything is built (decision
// 0038). World::create refuses one whose total exceeds the memory available (world.memory_limit
// when set, else what the machine has free), naming what it would need.
struct MemoryEstimate {
  HAUSTRA_MEMORY_FIELDS(HAUSTRA_DECLARE_FIELD)  // total and its parts, bytes (report_fields.h)
};
[[nodiscard]] MemoryEstimate estimate_memory(const WorldDesc& desc);
// What World::create says of a description that would not fit (Error{invalid_argument}: what it
// would need, part by part, and what to lower), or nothing when it fits.
void check_fits(const WorldDesc& desc);
// Bytes the machine can give without swapping (Linux: MemAvailable).
[[nodiscard]] std::size_t available_memory();

}  // namespace haustra
