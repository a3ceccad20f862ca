#pragma once
// The constant part of a world (MuJoCo's mjModel): built once from a WorldDesc, never written while
// stepping. Per-node arrays are contiguous across segments; a segment is an offset+count range.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <memory>

#include "haustra/kernels/pose.hpp"
#include "haustra/world.hpp"
#include "haustra/world_desc.hpp"

namespace haustra::detail {

inline constexpr std::size_t kMaxConstraintRows = 24;  // four clamps (3 position + 3 frame rows)

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

struct SegmentModel {
  SegmentInfo info;
  std::size_t node_offset = 0;
  std::size_t node_count = 0;  // N+1
  double mean_section = 0.0;
  std::array<double, 4> stiffness{};      // k_c in the law (zero for viscous components)
  std::array<double, 4> viscosity{};      // η_c (zero for elastic components)
  std::array<StrainLaw, 4> law{};
  BaseMode base_mode = BaseMode::clamped;
  bool has_drag = false;
  kernels::Pose initial_base;
  std::vector<AttachmentModel> attachments;
  std::size_t constraint_rows = 0;        // capacity: all attachments active
  std::size_t attachment_offset = 0;      // into the world's attachment state arrays
  // Offsets into the world's constraint scratch (doubles), valid when constraint_rows > 0.
  std::size_t constraint_scratch_offset = 0;
  std::size_t bead_offset = 0;   // into the world's bead arrays
  std::size_t bead_count = 0;
  [[nodiscard]] std::size_t sections() const { return node_count - 1; }
};

class StaticMeshes;

// Beads of all segments, ordered by segment then node: what the collision stages read.
struct BeadModel {
  std::vector<std::uint32_t> node;      // global node index
  std::vector<std::uint32_t> segment;
  std::vector<double> radius;           // m
  std::vector<double> modulus;          // Young's modulus of its tissue, Pa
  // Pairs of one segment that overlap or touch at rest never collide: for bead i, the excluded
  // partners j > i, ascending (CSR).
  std::vector<std::uint32_t> exclusion_start;
  std::vector<std::uint32_t> exclusion;
  [[nodiscard]] std::size_t size() const { return node.size(); }
  [[nodiscard]] bool excluded(std::uint32_t a, std::uint32_t b) const;
};

struct WorldModel {
  Eigen::Vector3d gravity;
  double dt = 0.0;
  SolverDesc solver;
  FilterDesc filter;
  std::vector<SegmentModel> segments;
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
  ContactDesc contact;
  double contact_margin = 0.0;  // resolved
  EnvironmentDesc environment;   // normals unit length
  std::shared_ptr<const StaticMeshes> meshes;
  std::vector<InstrumentDesc> instruments;  // keyframes sorted, axes unit length

  std::vector<Eigen::Vector3d> initial_attachment_target;
  std::vector<Eigen::Quaterniond> initial_attachment_rotation;
  std::vector<std::uint8_t> initial_attachment_active;
};

// Builds the model; throws haustra::Error naming the segment and the field.
WorldModel build_world_model(const WorldDesc& desc);

// The beads of one segment (nodes and radii) and, with all segments placed, the world's bead
// arrays and rest-pose exclusions; the environment and the instruments. Part of the builder.
void build_beads(const WorldDesc& desc, const std::vector<Eigen::Vector3d>& initial_positions, WorldModel& m);
void build_environment(const WorldDesc& desc, WorldModel& m);

}  // namespace haustra::detail
