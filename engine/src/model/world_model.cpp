// build_world_model: a world description checked and turned into the immutable model (mjModel).
#include "model/world_model.hpp"

#include <fmt/format.h>
#include <oneapi/tbb/task_arena.h>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <set>

#include "haustra/error.hpp"
#include "haustra/kernels/contact_geometry.hpp"
#include "haustra/kernels/mass_matrix.hpp"
#include "haustra/kernels/rod_forward_sweep.hpp"
#include "haustra/rest_shape.hpp"
#include "haustra/rod_pose_buffer.hpp"
#include "model/field_checks.hpp"
#include "model/world_desc_checks.hpp"

namespace haustra::detail {
namespace {

std::size_t resolve_node(const std::string& field, int node, std::size_t node_count) {
  const auto n = static_cast<long long>(node_count);
  const long long k = node < 0 ? n + node : node;
  if (k < 0 || k >= n)
    fail(field,
         fmt::format("expected a node index in [{}, {}] (negative counts from the tip), got {}", -n, n - 1, node));
  return static_cast<std::size_t>(k);
}

RestShape build_rest_shape(const SegmentDesc& d, const std::string& where) {
  const kernels::Pose base{kernels::frame_from_tangent(d.base_tangent, d.base_normal), d.base_position};
  switch (d.rest.kind) {
    case RestShapeKind::straight:
      return rest_shape_constant_strain(d.nodes, d.rest.length, Eigen::Vector3d::Zero(), base);
    case RestShapeKind::constant_strain:
      check_vector(where + ".rest.curvature", d.rest.curvature_torsion, false);
      return rest_shape_constant_strain(d.nodes, d.rest.length, d.rest.curvature_torsion, base);
    case RestShapeKind::centreline:
      if (d.rest.centreline.size() < 2)
        fail(where + ".rest.file", fmt::format("expected at least 2 points, got {}", d.rest.centreline.size()));
      return rest_shape_from_centreline(
          d.rest.centreline, d.nodes, d.base_normal,
          d.rest.centreline_source.empty() ? where + ".rest.file" : d.rest.centreline_source);
  }
  fail(where + ".rest.shape", "unknown rest shape");
}

// Paper §4.2: a thin-walled tube of radius R and wall h_w — its stiffnesses, density, the law's
// elastic and viscous parts and the inertia filter's ζ.
void set_material(const WorldDesc& desc, const SegmentDesc& d, SegmentModel& seg) {
  const double e = d.material.youngs_modulus;
  const double r = d.cross_section.radius;
  const double hw = d.cross_section.wall_thickness;
  const double g = e / (2.0 * (1.0 + d.material.poisson_ratio));
  const double area = 2.0 * std::numbers::pi * r * hw;
  seg.info.bending_stiffness = std::numbers::pi * e * r * r * r * hw;
  seg.info.torsion_stiffness = 2.0 * std::numbers::pi * g * r * r * r * hw;
  seg.info.axial_stiffness = e * area;
  seg.info.linear_density = d.linear_density.value_or(d.material.density * area);
  seg.info.zeta = desc.filter.zeta_scale * std::numbers::pi / (16.0 * seg.info.axial_stiffness);
  const std::array<double, 4> k = {seg.info.bending_stiffness, seg.info.bending_stiffness, seg.info.torsion_stiffness,
                                   seg.info.axial_stiffness};
  seg.law = d.law;
  for (std::size_t c = 0; c < 4; ++c) {
    seg.stiffness[c] = d.law[c] == StrainLaw::viscous ? 0.0 : k[c];
    seg.viscosity[c] = d.law[c] == StrainLaw::elastic ? 0.0 : k[c] * d.relaxation_time;
  }
  seg.info.viscosity = seg.viscosity;
  seg.exp2 = d.material.response == TissueResponse::exp2;
  seg.tissue = {d.material.exp2_alpha, d.material.exp2_beta, d.material.exp2_gamma};
  seg.tube = {r, hw};
  seg.failure_strain = d.material.failure_strain;
}

// The rod's per-node arrays: sections, rest strains, lumped masses and drags, the mass matrix's
// factors.
void append_node_arrays(const RestShape& rest, const SegmentModel& seg, double drag, double radius, WorldModel& m) {
  const std::size_t n = seg.node_count;
  m.section_length.resize(m.node_total + n, 0.0);
  m.rest_strain.insert(m.rest_strain.end(), rest.strain.begin(), rest.strain.end());
  for (std::size_t kk = 0; kk + 1 < n; ++kk) m.section_length[m.node_total + kk] = rest.section_length[kk];
  for (std::size_t kk = 0; kk < n; ++kk) {
    const double h_prev = kk > 0 ? rest.section_length[kk - 1] : 0.0;
    const double h_next = kk + 1 < n ? rest.section_length[kk] : 0.0;
    const double share = 0.5 * (h_prev + h_next);
    m.node_mass.push_back(seg.info.linear_density * share);
    m.node_drag.push_back(drag * share);
    // Spinning a tube of radius R through the medium: drag × R² per length, which also keeps the
    // rigid resistance invertible for a straight rod.
    m.node_spin_drag.push_back(drag * radius * radius * share);
  }
  m.mass_inv_pivot.resize(m.node_total + n);
  m.mass_lower.resize(m.node_total + n);
  kernels::mass_matrix_factor(rest.section_length, std::span(m.mass_inv_pivot).subspan(m.node_total, n),
                              std::span(m.mass_lower).subspan(m.node_total, n));
}

void append_loads(const SegmentDesc& d, const std::string& where, std::size_t n, std::span<const double> section_length,
                  WorldModel& m) {
  m.initial_load.resize(6 * (m.node_total + n), 0.0);
  for (std::size_t li = 0; li < d.loads.size(); ++li) {
    const std::string lw = fmt::format("{}.load[{}]", where, li);
    const std::size_t node = resolve_node(lw + ".node", d.loads[li].node, n);
    check_vector(lw + ".force", d.loads[li].force, false);
    check_vector(lw + ".moment", d.loads[li].moment, false);
    for (int j = 0; j < 3; ++j) {
      m.initial_load[6 * (m.node_total + node) + static_cast<std::size_t>(j)] += d.loads[li].force[j];
      m.initial_load[6 * (m.node_total + node) + 3 + static_cast<std::size_t>(j)] += d.loads[li].moment[j];
    }
  }
  // Loads per metre (decision 0102): each node of the range takes half of each section beside it.
  for (std::size_t li = 0; li < d.distributed_loads.size(); ++li) {
    const DistributedLoadDesc& l = d.distributed_loads[li];
    const std::string lw = fmt::format("{}.distributed_load[{}]", where, li);
    const std::size_t first = resolve_node(lw + ".from", l.from, n), last = resolve_node(lw + ".to", l.to, n);
    if (first > last)
      fail(lw + ".to", fmt::format("node {} comes before from = node {}: expected from <= to", last, first));
    check_vector(lw + ".force", l.force, false);
    check_vector(lw + ".moment", l.moment, false);
    for (std::size_t k = first; k <= last; ++k) {
      const double share = 0.5 * ((k > first ? section_length[k - 1] : 0.0) + (k < last ? section_length[k] : 0.0));
      for (int j = 0; j < 3; ++j) {
        m.initial_load[6 * (m.node_total + k) + static_cast<std::size_t>(j)] += share * l.force[j];
        m.initial_load[6 * (m.node_total + k) + 3 + static_cast<std::size_t>(j)] += share * l.moment[j];
      }
    }
  }
}

// The segment's attachments (targets by default where their nodes rest), then one grasp slot per
// instrument on a segment with beads (closing an instrument attaches the node of the bead it closes
// on); the constraint rows they take and the scratch their solves need.
void append_attachments(const WorldDesc& desc, const SegmentDesc& d, const std::string& where,
                        const kernels::RodPoses<double>& poses, SegmentModel& seg, WorldModel& m) {
  const std::size_t n = seg.node_count;
  std::set<std::size_t> held;
  seg.attachment_offset = m.attachment_total;
  for (std::size_t ai = 0; ai < d.attachments.size(); ++ai) {
    const AttachmentDesc& a = d.attachments[ai];
    const std::string aw = fmt::format("{}.attachment[{}]", where, ai);
    AttachmentModel am;
    am.initial_node = resolve_node(aw + ".node", a.node, n);
    am.hold_frame = a.hold_frame;
    if (!held.insert(am.initial_node).second)
      fail(aw + ".node", fmt::format("node {} is already attached", am.initial_node));
    if (am.initial_node == 0 && d.base == BaseMode::clamped)
      fail(aw + ".node", "node 0 of a clamped segment is already held by its base");
    seg.constraint_rows += am.rows();
    if (seg.constraint_rows > kMaxConstraintRows)
      fail(aw, fmt::format("too many attachments: at most {} constraint rows per segment (3 per pin, 6 per clamp)",
                           kMaxConstraintRows));
    Eigen::Vector3d target = poses.node_position.get(am.initial_node);
    if (a.target) {
      check_vector(aw + ".target", *a.target, false);
      target = *a.target;
    }
    m.initial_attachment_target.push_back(target);
    m.initial_attachment_rotation.push_back(poses.node_rotation.get(am.initial_node));
    m.initial_attachment_active.push_back(a.active ? 1 : 0);
    seg.attachments.push_back(am);
  }
  if (d.beads.enabled)
    for (std::size_t i = 0; i < desc.instruments.size(); ++i) {
      AttachmentModel am;
      am.grasp_slot = true;
      am.instrument = i;
      am.hold_frame = desc.instruments[i].hold_frame;
      seg.constraint_rows += am.rows();
      if (seg.constraint_rows > kMaxConstraintRows)
        fail(fmt::format("instrument[{}]", i),
             fmt::format("segment '{}' would need more than {} constraint rows with a grasp slot per instrument",
                         d.name, kMaxConstraintRows));
      m.initial_attachment_target.push_back(Eigen::Vector3d::Zero());
      m.initial_attachment_rotation.push_back(Eigen::Quaterniond::Identity());
      m.initial_attachment_active.push_back(0);
      seg.attachments.push_back(am);
    }
  m.attachment_total += seg.attachments.size();
  if (seg.constraint_rows > 0) {
    // G (unit-load generalized forces), Y (their solved responses) per row, and H (six
    // rigid-drag fields) for a free base: 4 doubles per node each.
    seg.constraint_scratch_offset = m.constraint_scratch_total;
    m.constraint_scratch_total += 4 * n * (2 * seg.constraint_rows + (d.base == BaseMode::free ? 6 : 0));
  }
}

// The nearest point of a polyline to p.
Eigen::Vector3d nearest_on_polyline(const std::vector<Eigen::Vector3d>& line, const Eigen::Vector3d& p) {
  Eigen::Vector3d best = line.front();
  for (std::size_t i = 0; i + 1 < line.size(); ++i) {
    const Eigen::Vector3d c = kernels::closest_point_on_segment(p, line[i], line[i + 1]);
    if ((c - p).squaredNorm() < (best - p).squaredNorm()) best = c;
  }
  return best;
}

// The segment's connective tissue: an anchor on every node whose rest arc length lies in a range,
// holding the node's share of the rod (half of each section beside it) with the range's stiffness,
// damping and strength per length, towards its rest place (and rest frame) or the nearest point of
// the root line.
void append_anchors(const SegmentDesc& d, const std::string& where, const RestShape& rest,
                    const kernels::RodPoses<double>& poses, SegmentModel& seg, WorldModel& m) {
  const std::size_t n = seg.node_count;
  seg.anchor_offset = m.anchors.size();
  std::vector<double> arc(n, 0.0);
  for (std::size_t k = 1; k < n; ++k) arc[k] = arc[k - 1] + rest.section_length[k - 1];
  const double tolerance = 1e-9 * rest.length;  // a range ending on a node includes it
  for (std::size_t ri = 0; ri < d.anchors.size(); ++ri) {
    const AnchorsDesc& a = d.anchors[ri];
    AnchorRange range{a.name.empty() ? fmt::format("{}.anchors[{}]", where, ri) : a.name, m.segments.size(),
                      m.anchors.size(), 0};
    for (std::size_t k = 0; k < n; ++k) {
      if (arc[k] < a.from * rest.length - tolerance || arc[k] > a.to * rest.length + tolerance) continue;
      const double share =
          0.5 * ((k > 0 ? rest.section_length[k - 1] : 0.0) + (k + 1 < n ? rest.section_length[k] : 0.0));
      const Eigen::Vector3d at = poses.node_position.get(k);
      const Eigen::Vector3d target = a.target == AnchorTarget::root ? nearest_on_polyline(a.root, at) : at;
      m.anchors.node.push_back(static_cast<std::uint32_t>(seg.node_offset + k));
      m.anchors.range.push_back(static_cast<std::uint32_t>(m.anchor_ranges.size()));
      m.anchors.target.push_back(target);
      m.anchors.stiffness.push_back(a.stiffness * share);
      m.anchors.damping.push_back(a.damping * share);
      m.anchors.slack.push_back(a.slack + (target - at).norm());
      m.anchors.strength.push_back(a.strength > 0.0 ? a.strength * share : std::numeric_limits<double>::infinity());
      m.anchors.support.push_back(a.support * share);
      m.anchors.wall.push_back(d.cross_section.radius);
      // Held round the wall: a turn of the tube by θ stretches the tissue by R θ.
      const double lever2 = a.target == AnchorTarget::rest ? d.cross_section.radius * d.cross_section.radius : 0.0;
      m.anchors.rest_rotation.push_back(poses.node_rotation.get(k));
      m.anchors.turn_stiffness.push_back(a.stiffness * share * lever2);
      m.anchors.turn_damping.push_back(a.damping * share * lever2);
      range.count += 1;
    }
    if (range.count == 0)
      fail(where + fmt::format(".anchors[{}]", ri),
           fmt::format("the range {} to {} of the organ holds no node (its nodes are {:.3g} m apart)", a.from, a.to,
                       seg.mean_section));
    m.anchor_ranges.push_back(std::move(range));
  }
  seg.anchor_count = m.anchors.size() - seg.anchor_offset;
}

// The API's segments on the rod: the rod itself, or a chain's pieces, each `nodes` long and
// sharing its joint nodes with its neighbours (decision 0030).
void append_pieces(const SegmentDesc& d, std::size_t si, const RestShape& rest, SegmentModel& seg, WorldModel& m) {
  const auto pieces = static_cast<std::size_t>(d.chain_pieces);
  seg.first_piece = m.pieces.size();
  seg.piece_count = pieces;
  const auto piece_nodes = static_cast<std::size_t>(d.nodes);
  for (std::size_t p = 0; p < pieces; ++p) {
    SegmentPiece piece;
    piece.info = seg.info;
    piece.rod = si;
    if (pieces > 1) {
      piece.info.name = fmt::format("{}-{}", d.name, p + 1);  // unique: check_world_desc saw to it
      piece.first_node = p * (piece_nodes - 1);
      piece.info.nodes = {seg.node_offset + piece.first_node, piece_nodes};
      piece.info.length = 0.0;
      for (std::size_t kk = 0; kk + 1 < piece_nodes; ++kk)
        piece.info.length += rest.section_length[piece.first_node + kk];
    }
    m.pieces.push_back(std::move(piece));
  }
}

// One segment (a chain is one rod of its pieces): its rest shape, stiffnesses, masses, loads,
// attachments, pieces and solve parts appended to the model, and its nodes' initial positions and
// rest poses to the lists the beads and meshes are built from.
void build_rod(const WorldDesc& desc, std::size_t si, WorldModel& m, std::vector<Eigen::Vector3d>& initial_positions,
               std::vector<RodPoseBuffer>& rest_poses) {
  const SegmentDesc& d = desc.segments[si];
  const std::string where = fmt::format("segment[{}]", si);
  const double drag = d.drag.value_or(d.base == BaseMode::free ? 4.0 : 0.0);

  // A chain is one rod of K·(nodes − 1) + 1 nodes.
  SegmentDesc whole = d;
  whole.nodes = d.chain_pieces * (d.nodes - 1) + 1;
  const RestShape rest = build_rest_shape(whole, where);

  SegmentModel seg;
  seg.info.name = d.name;
  seg.node_offset = m.node_total;
  seg.node_count = static_cast<std::size_t>(whole.nodes);
  seg.info.nodes = {seg.node_offset, seg.node_count};
  seg.info.length = rest.length;
  seg.mean_section = rest.length / static_cast<double>(seg.sections());
  seg.info.rest_node_deviation = rest.node_deviation;
  seg.info.rest_polyline_deviation = rest.polyline_deviation;
  set_material(desc, d, seg);
  seg.base_mode = d.base;
  seg.has_drag = drag > 0.0;
  seg.initial_base = rest.base;
  append_node_arrays(rest, seg, drag, d.cross_section.radius, m);

  // Initial poses, for default attachment targets.
  const std::size_t n = seg.node_count;
  rest_poses.emplace_back(n);
  const kernels::RodPoses<double> poses = rest_poses.back().view();
  kernels::rod_forward_sweep(rest.base, rest.section_length, kernels::StrainView<const double>{rest.strain}, poses);
  for (std::size_t i = 0; i < n; ++i) initial_positions.push_back(poses.node_position.get(i));

  append_loads(d, where, n, rest.section_length, m);
  append_attachments(desc, d, where, poses, seg, m);
  append_anchors(d, where, rest, poses, seg, m);
  append_pieces(d, si, rest, seg, m);
  m.node_total += n;
  const auto rod = static_cast<std::uint32_t>(m.segments.size());
  if (rod_is_split(n, desc.solver.mode)) {
    seg.split_node = static_cast<std::size_t>(std::lround(kSplitBaseFraction * static_cast<double>(n - 1)));
    m.solve_parts.push_back({rod, SolvePartKind::tip});
    m.solve_parts.push_back({rod, SolvePartKind::base});
  } else {
    m.solve_parts.push_back({rod, SolvePartKind::whole});
  }
  m.segments.push_back(std::move(seg));
}

}  // namespace

namespace {

// The organ meshes' part of a model: cages, bindings, the world mesh buffers' layout, normals' gathers.
void take_mesh_binding(const WorldModel& from, WorldModel& m) {
  m.meshes_of = from.meshes_of;
  m.ring_total = from.ring_total;
  m.mesh_vertex_total = from.mesh_vertex_total;
  m.mesh_triangles = from.mesh_triangles;
  m.vertex_corner_start = from.vertex_corner_start;
  m.vertex_corner_pairs = from.vertex_corner_pairs;
  m.normal_slot_start = from.normal_slot_start;
  m.normal_gather_pairs = from.normal_gather_pairs;
  m.normal_slots = from.normal_slots;
  m.skin_chunks = from.skin_chunks;
  m.normal_chunks = from.normal_chunks;
  m.seam_group_start = from.seam_group_start;
  m.seam_group_members = from.seam_group_members;
  m.any_mesh = from.any_mesh;
}

WorldModel build_world_model_here(const WorldDesc& desc, const WorldModel* binding_from) {
  WorldModel m;
  m.gravity = desc.gravity;
  m.dt = desc.dt;
  m.frame_budget = desc.frame_budget;
  m.mesh_update = desc.mesh_update;
  m.sleep = {desc.sleep.enabled, desc.sleep.speed, desc.sleep.time, desc.sleep.ranges};
  const SolverDesc& sd = desc.solver;
  m.solver = {.mode = sd.mode,
              .iterations = sd.iterations,
              .substeps = sd.substeps,
              .relaxation = sd.relaxation,
              .tolerance = sd.tolerance,
              .max_iterations = sd.max_iterations,
              .on_instability = sd.on_instability,
              .max_substeps = sd.max_substeps,
              .max_retries = sd.max_retries,
              .calm_frames = sd.calm_frames,
              .max_displacement = sd.max_displacement};
  m.filter.enabled = desc.filter.enabled;

  build_environment(desc, m);
  std::vector<Eigen::Vector3d> initial_positions;
  std::vector<RodPoseBuffer> rest_poses;
  for (std::size_t si = 0; si < desc.segments.size(); ++si) build_rod(desc, si, m, initial_positions, rest_poses);
  std::vector<PiecePlaces> placed;
  std::vector<TriangleMesh> meshes = load_organ_meshes(desc, rest_poses, m, placed);
  build_beads(desc, initial_positions, rest_poses, meshes, m);
  for (SegmentModel& seg : m.segments)
    seg.has_load_stiffness = seg.has_drag || seg.bead_count > 0 || seg.anchor_count > 0;
  if (binding_from != nullptr)
    take_mesh_binding(*binding_from, m);
  else
    bind_organ_meshes(desc, rest_poses, meshes, placed, m);
  return m;
}

}  // namespace

WorldModel build_world_model(const WorldDesc& desc, const WorldModel* binding_from) {
  check_world_desc(desc);  // every field a description holds, before anything is built
  // Built on the world's own threads (the mesh binding's blocks, by index: the same bits on any
  // count), so that a study's worlds, one thread each, do not each take every core while building.
  tbb::task_arena arena(desc.threads > 0 ? desc.threads : tbb::task_arena::automatic);
  return arena.execute([&] { return build_world_model_here(desc, binding_from); });
}

}  // namespace haustra::detail
