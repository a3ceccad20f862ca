#pragma once
// The constant part of a world (MuJoCo's mjModel): built once from a WorldDesc, never written while
// stepping. Per-node arrays are contiguous across segments; a segment is an offset+count range.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "haustra/kernels/pose.hpp"
#include "haustra/world.hpp"
#include "haustra/world_desc.hpp"

namespace haustra::detail {

inline constexpr std::size_t kMaxConstraintRows = 24;  // four clamps (3 position + 3 frame rows)

struct AttachmentModel {
  std::size_t node = 0;  // local to the segment
  bool hold_frame = false;
  std::size_t first_row = 0;  // within the segment's constraint rows
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
  [[nodiscard]] std::size_t sections() const { return node_count - 1; }
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
  std::vector<Eigen::Vector3d> initial_attachment_target;
  std::vector<Eigen::Quaterniond> initial_attachment_rotation;
  std::vector<std::uint8_t> initial_attachment_active;
};

// Builds the model; throws haustra::Error naming the segment and the field.
WorldModel build_world_model(const WorldDesc& desc);

}  // namespace haustra::detail
