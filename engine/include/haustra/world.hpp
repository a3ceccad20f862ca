#pragma once
// A world: an immutable model (built once from a WorldDesc) and its per-frame state, stepped
// frame by frame. Buffers are structure-of-arrays, contiguous across all segments; a segment is an
// offset+count range into them. Views returned here stay valid until the next call to step().
#include <array>
#include <cstddef>
#include <cstdint>
#include <string_view>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "haustra/error.hpp"
#include "haustra/kernels/cage_rings.hpp"
#include "haustra/kernels/pose.hpp"
#include "haustra/kernels/spans.hpp"
#include "haustra/profile.hpp"
#include "haustra/world_desc.hpp"

namespace haustra {

struct Range {
  std::size_t offset = 0;
  std::size_t count = 0;
};

// What the model builder derived for one segment: stiffnesses, masses, and how well the rest
// shape reproduces its source.
struct SegmentInfo {
  std::string name;
  Range nodes;
  double length = 0.0;                  // m, rest
  double bending_stiffness = 0.0;       // B = π E R³ h_w, N·m²
  double torsion_stiffness = 0.0;       // T = 2π G R³ h_w, N·m²
  double axial_stiffness = 0.0;         // EA, A = 2π R h_w, N
  std::array<double, 4> viscosity{};    // η per component, zero for elastic ones
  double linear_density = 0.0;          // kg/m
  double zeta = 0.0;                    // inertia filter regulator, 1/N
  // Rest shape from a centreline: largest distance of the rod's interpolation nodes from the
  // resampled polyline (reproduction error of the construction itself), and of the source
  // polyline's vertices from the rod's curve (includes the resampling to N+1 nodes). Metres.
  double rest_node_deviation = 0.0;
  double rest_polyline_deviation = 0.0;
};

// How the cage around a segment's organ mesh came out (docs/decisions/0017-cage-builder.md).
struct CageReport {
  std::size_t rings = 0, bead_rings = 0, middle_rings = 0;
  std::size_t dropped_rings = 0;          // middle rings taken out where longer quads were needed
  std::size_t ring_vertices = 0;          // m per ring
  std::size_t vertices = 0, triangles = 0;
  double clearance = 0.0;                 // m asked between mesh and cage
  // How far ring vertices went beyond their template (the bead's radius), m; negative: inside it.
  double inflation_min = 0.0, inflation_mean = 0.0, inflation_max = 0.0;
  int iterations = 0;                     // inflation passes
  double tightest_bend = 0.0;             // m: the smallest bend radius of the rest rod at a ring
  // Embree's final verification in the binding pose, where the weights are computed: all zero for
  // a cage that embeds the mesh.
  std::size_t mesh_vertices_outside = 0, crossing_edges = 0, self_intersections = 0;
  // The same cage at the curved rest pose: mesh vertices outside it where the organ bends more
  // tightly than its own radius or its loops touch (for the record; the binding does not use it).
  std::size_t rest_pose_outside = 0;
  double seconds = 0.0;
};

// The binding of the mesh to the cage: mean value coordinates (or linear-blend weights) per mesh
// vertex, grouped by ring, localized to the rings of largest weight.
struct SkinReport {
  SkinningMethod method = SkinningMethod::mean_value;
  std::size_t rings_per_vertex = 0;       // slots per vertex (all rings when not localized)
  double min_weight = 0.0;                // most negative MVC weight of any vertex
  double max_negative_mass = 0.0;         // Σ|w| of negative weights, worst vertex
  double mean_negative_mass = 0.0;
  std::size_t negative_vertices = 0;      // vertices with any negative weight
  std::size_t on_face = 0, on_vertex = 0; // vertices found on the cage (exact branches)
  double max_dropped_mass = 0.0;          // Σ|w| of the rings left out by localization, worst vertex
  double mean_dropped_mass = 0.0;
  double rest_error = 0.0;                // m: skinned rest pose vs the input mesh (float rounding)
  // m: how far the binding-pose weights, carried to the rings' curved rest poses, would put a
  // vertex from where it is; taken up by the binding so the rest pose is exact (worst vertex).
  double max_rest_correction = 0.0;
  double seconds = 0.0;                   // to compute the weights
};

// A segment's organ mesh: where its vertices are in the world's mesh buffers, and how it was bound.
struct MeshInfo {
  bool enabled = false;
  std::string source;                     // file, or "procedural"
  Range vertices;                         // into mesh_positions()
  Range triangles;                        // into mesh_triangles()
  CageReport cage;
  SkinReport skin;
};

enum class ContactKind : std::uint8_t { bead, plane, sphere, capsule, mesh, instrument };

// A contact of the last substep: a bead and what it may touch (another bead, or the shape's index
// among planes, spheres, capsules, meshes or instruments), listed at the substep's start within a
// margin, with the penalty evaluated at the positions of the solve's last iteration. A mesh
// contact keeps the tangent plane found at the start.
struct Contact {
  std::uint32_t bead = 0;
  std::uint32_t other = 0;
  ContactKind kind = ContactKind::bead;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   // mesh: on the plane
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ(); // mesh: the plane's free side
  Eigen::Vector3d force = Eigen::Vector3d::Zero();   // N, on `bead`; a second bead gets the opposite
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();  // separating direction
  double stiffness = 0.0;   // of the linearization, N/m
  double depth = 0.0;       // m; > 0 overlapping
  bool coupled = false;     // two beads of one segment, solved as a pair by Newton (not node by node)
};

// Contacts of the last frame, measured at its final positions.
struct ContactReport {
  std::size_t candidates = 0;   // pairs and bead–shape pairs within the margin at the frame's start
  std::size_t touching = 0;     // of those, overlapping at its end
  double max_environment_depth = 0.0;        // m: deepest bead into a plane, obstacle, mesh or instrument
  double max_environment_depth_ratio = 0.0;  // the same over that bead's radius
  double max_bead_overlap = 0.0;             // m: deepest overlap of two beads that may collide
  double max_bead_overlap_ratio = 0.0;       // the same over the smaller radius
};

// An instrument's state after the last frame. Force and torque are what the tissue exerts on the
// instrument (the negative of what the instrument exerts on the rod), torque about the tip.
struct InstrumentReading {
  Eigen::Vector3d tip = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  bool closed = false;
  bool grasping = false;
  std::size_t grasped_segment = 0;
  std::size_t grasped_node = 0;  // local to the segment
  // The segment's attachment that holds the grasp (for attachment_force), and where the grasp
  // wants the node: the tip plus the offset the node had from it at the moment of grasping.
  std::size_t grasp_attachment = 0;
  Eigen::Vector3d grasp_target = Eigen::Vector3d::Zero();
  Eigen::Vector3d force = Eigen::Vector3d::Zero();
  Eigen::Vector3d torque = Eigen::Vector3d::Zero();
  Eigen::Vector3d filtered_force = Eigen::Vector3d::Zero();   // low-passed (InstrumentDesc::force_filter)
  Eigen::Vector3d filtered_torque = Eigen::Vector3d::Zero();
};

// Energies of the current configuration, J: what the elastic strain components store
// (½ Σ k_c Δqᵀ M Δq over elastic and Kelvin–Voigt components; viscous ones store none) and the
// potential of the rod's weight (−Σ m_k g·r_k, zero at the origin).
struct Energy {
  double elastic = 0.0;
  double gravity = 0.0;
  [[nodiscard]] double total() const { return elastic + gravity; }
};

struct Event {
  enum class Kind : std::uint8_t { recovered, unstable };
  Kind kind = Kind::recovered;
  std::uint64_t frame = 0;
  std::size_t segment = 0;
  std::size_t node = 0;
  Stage stage = Stage::guard;
  int substeps = 1;
  // The message lives in place, so recording an event inside a step allocates nothing.
  std::array<char, 512> text{};
  [[nodiscard]] std::string_view message() const { return {text.data()}; }
};

class World {
 public:
  // Builds the model and the initial state. Throws haustra::Error naming the segment and field.
  static std::unique_ptr<World> create(const WorldDesc& desc);
  ~World();
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  // One frame of dt. On an instability the state stays at the last good frame and, once the
  // robust mode (if enabled) cannot recover, Error{unstable} is thrown naming segment, node, stage.
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
  void set_external_load(std::size_t node, const Eigen::Vector3d& force,
                         const Eigen::Vector3d& moment);
  // Attachments are numbered per segment in the order of SegmentDesc::attachments (then one grasp
  // slot per instrument); every piece of a chain addresses the chain's attachments.
  void set_attachment_target(std::size_t segment, std::size_t attachment,
                             const Eigen::Vector3d& position);
  void set_attachment_target_rotation(std::size_t segment, std::size_t attachment,
                                      const Eigen::Quaterniond& rotation);
  void set_attachment_active(std::size_t segment, std::size_t attachment, bool active);
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

  // Instruments. Setting a pose hands the instrument from its script to the host for good.
  [[nodiscard]] std::size_t instrument_count() const;
  void set_instrument_pose(std::size_t instrument, const Eigen::Vector3d& tip, const Eigen::Vector3d& axis);
  void set_instrument_grasp(std::size_t instrument, bool closed);
  [[nodiscard]] InstrumentReading instrument(std::size_t instrument) const;

  // Organ meshes. Positions and normals are float SoA buffers over all segments' meshes, one
  // after the other (each segment's range in mesh(s).vertices, in the order of its input mesh),
  // updated at the end of every step and valid until the next one. Triangles index those buffers.
  [[nodiscard]] const MeshInfo& mesh(std::size_t segment) const;
  [[nodiscard]] std::size_t mesh_buffer_size() const;
  [[nodiscard]] kernels::Vec3View<const float> mesh_positions() const;
  [[nodiscard]] kernels::Vec3View<const float> mesh_normals() const;
  [[nodiscard]] std::span<const std::array<std::uint32_t, 3>> mesh_triangles() const;
  // A segment's cage at the current pose (for drawing and checks) and its ring poses.
  [[nodiscard]] std::vector<Eigen::Vector3d> cage_vertices(std::size_t segment) const;
  [[nodiscard]] std::span<const std::array<std::uint32_t, 3>> cage_triangles(std::size_t segment) const;
  [[nodiscard]] std::span<const kernels::RingPose> ring_poses(std::size_t segment) const;
  // Per cage vertex, the ring that carries it (an index into ring_poses(segment)).
  [[nodiscard]] std::span<const std::uint32_t> cage_vertex_rings(std::size_t segment) const;

  [[nodiscard]] Energy energy() const;

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

  // Between frames, a segment (or a chain: all its pieces) joins the world, or leaves it
  // (docs/decisions/0031-add-remove-segments.md). The model is rebuilt (as long as creating the
  // world took); every other segment keeps its state and steps on as if nothing had changed. A
  // description the builder refuses leaves the world as it was. Indices of the segments after a
  // removed one move down; views into the world's buffers are invalidated.
  std::size_t add_segment(const SegmentDesc& segment);  // returns the new segment's index
  void remove_segment(std::size_t segment);  // a chain goes whole, named by its first segment

  // Keeps the buffers behind every view above alive for as long as the handle lives: past the
  // world's destruction and past add_segment / remove_segment, which move the world to new buffers
  // and leave the old ones to the handles that still hold them. For hosts whose views outlive
  // calls (the Python module). Every Vec3View of this class is one block, x then y then z
  // (y.data() == x.data() + size()), so a host can see it as one strided 3 × n array.
  [[nodiscard]] std::shared_ptr<const void> buffers_keeper() const;

  [[nodiscard]] const FrameProfile& last_profile() const;
  [[nodiscard]] std::span<const Event> events() const;
  [[nodiscard]] int threads() const;

 private:
  struct Impl;  // engine/src/world_impl.hpp
  explicit World(std::unique_ptr<Impl> impl);
  void rebuild(WorldDesc next, std::span<const std::size_t> rod_map);
  std::shared_ptr<Impl> impl_;  // shared with buffers_keeper()'s handles
};

// What a world will hold, estimated from its description before anything is built (decision
// 0038). World::create refuses one whose total exceeds the memory available (world.memory_limit
// when set, else what the machine has free), naming what it would need.
struct MemoryEstimate {
  std::size_t total = 0;         // bytes
  std::size_t nodes = 0;
  std::size_t rod_bytes = 0;     // the rods' model and state (and what building them takes)
  std::size_t solver_bytes = 0;  // the Newton solves' workspace
  std::size_t bead_bytes = 0;
  std::size_t mesh_bytes = 0;    // procedural organ meshes (a mesh file's size is checked as it loads)
};
[[nodiscard]] MemoryEstimate estimate_memory(const WorldDesc& desc);
// Bytes the machine can give without swapping (Linux: MemAvailable).
[[nodiscard]] std::size_t available_memory();

}  // namespace haustra
