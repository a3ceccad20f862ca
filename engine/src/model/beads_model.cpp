// Building the beads, their rest-pose exclusions, the environment and the instruments.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>

#include "haustra/embree_scene.hpp"
#include "haustra/error.hpp"
#include "haustra/kernels/broad_phase.hpp"
#include "model/field_checks.hpp"
#include "model/static_meshes.hpp"
#include "model/world_desc_checks.hpp"
#include "model/world_model.hpp"

namespace haustra::detail {
namespace {

void check_finite(const std::string& field, const Eigen::Vector3d& v) { check_vector(field, v, false); }

void check_unit(const std::string& field, const Eigen::Vector3d& v) {
  check_finite(field, v);
  if (!(v.norm() > 0.0)) fail(field, "expected a non-zero direction");
}

void check_radius(const std::string& field, double r) {
  if (!std::isfinite(r) || !(r > 0.0)) fail(field, fmt::format("expected a positive radius in m, got {}", r));
  if (r > 0.5) fail(field, fmt::format("{} m is beyond the plausible maximum 0.5 m (did you mean millimetres?)", r));
  if (r < 1e-4) fail(field, fmt::format("{} m is below the plausible minimum 0.0001 m", r));
}

// An obstacle's radius: positive, up to the bound on positions.
void check_obstacle_radius(const std::string& field, double r) {
  if (!std::isfinite(r) || !(r > 0.0) || r > kMaxVectorComponent)
    fail(field, fmt::format("expected a positive radius in m up to {:g}, got {}", kMaxVectorComponent, r));
}

// A container must bound a volume, wound one way throughout: every edge in exactly two triangles,
// once in each direction (its inside is then where its volume is: decision 0093).
void check_container(const MeshObstacleDesc& mesh, const std::string& where) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::array<int, 2>> runs;  // each way along an edge
  for (const auto& t : mesh.triangles)
    for (std::size_t e = 0; e < 3; ++e) {
      const std::uint32_t a = t[e], b = t[(e + 1) % 3];
      ++runs[{std::min(a, b), std::max(a, b)}][a < b ? 0 : 1];
    }
  std::size_t open = 0, against = 0;
  for (const auto& [edge, way] : runs) {
    if (way[0] + way[1] != 2)
      ++open;  // an edge of one triangle, or of three or more
    else if (way[0] != 1)
      ++against;  // two neighbours that run the edge the same way
  }
  const std::string file = mesh.source.empty() ? mesh.name : mesh.source;
  if (open > 0)
    throw FieldError(
        ErrorCode::invalid_geometry, where + ".container",
        fmt::format("{} is not closed ({} edges are not shared by exactly two triangles): a container must be a "
                    "closed surface, the boundary of the volume that holds the beads",
                    file, open));
  if (against > 0)
    throw FieldError(
        ErrorCode::invalid_geometry, where + ".container",
        fmt::format("{} is not wound one way ({} edges shared by neighbours facing opposite ways): a container's "
                    "inside is read from its winding",
                    file, against));
}

// Node indices of one segment's beads, ascending and distinct.
std::vector<std::size_t> bead_nodes(const BeadsDesc& b, const SegmentModel& seg, std::span<const double> h,
                                    const std::string& where) {
  const std::size_t n = seg.node_count;
  std::vector<std::size_t> nodes;
  const int ways = (b.count > 0 ? 1 : 0) + (b.spacing > 0.0 ? 1 : 0) + (b.nodes.empty() ? 0 : 1);
  if (ways > 1) fail(where, "give the beads by count, by spacing or as a node list: one of them");
  if (!b.nodes.empty()) {
    for (std::size_t i = 0; i < b.nodes.size(); ++i) {
      const long long k = b.nodes[i] < 0 ? static_cast<long long>(n) + b.nodes[i] : b.nodes[i];
      if (k < 0 || k >= static_cast<long long>(n))
        fail(fmt::format("{}.nodes[{}]", where, i),
             fmt::format("expected a node index in [{}, {}], got {}", -static_cast<long long>(n), n - 1, b.nodes[i]));
      nodes.push_back(static_cast<std::size_t>(k));
    }
  } else if (b.spacing > 0.0) {
    if (!std::isfinite(b.spacing) || b.spacing > 1000.0)
      fail(where + ".spacing", fmt::format("expected a spacing in (0, 1000] m, got {}", b.spacing));
    double s = 0.0, next = 0.0;
    for (std::size_t k = 0; k < n; ++k) {
      if (k > 0) s += h[k - 1];
      if (s + 0.5 * (k + 1 < n ? h[k] : 0.0) >= next) {  // the first node at or past the next mark
        nodes.push_back(k);
        next = s + b.spacing;
      }
    }
    nodes.push_back(n - 1);
  } else {
    if (b.count < 0) fail(where + ".count", fmt::format("expected a positive count, got {}", b.count));
    const std::size_t count = b.count > 0 ? static_cast<std::size_t>(b.count) : (n + 2) / 3;  // every third node
    if (count > n) fail(where + ".count", fmt::format("{} beads on {} nodes: at most one bead per node", count, n));
    for (std::size_t j = 0; j < count; ++j)
      nodes.push_back(count == 1
                          ? 0
                          : static_cast<std::size_t>(std::llround(static_cast<double>(j) * static_cast<double>(n - 1) /
                                                                  static_cast<double>(count - 1))));
  }
  std::sort(nodes.begin(), nodes.end());
  nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
  return nodes;
}

double profile_radius(const std::vector<std::pair<double, double>>& profile, double fraction) {
  if (fraction <= profile.front().first) return profile.front().second;
  for (std::size_t i = 1; i < profile.size(); ++i)
    if (fraction <= profile[i].first) {
      const auto& [f0, r0] = profile[i - 1];
      const auto& [f1, r1] = profile[i];
      return f1 > f0 ? r0 + (r1 - r0) * (fraction - f0) / (f1 - f0) : r1;
    }
  return profile.back().second;
}

}  // namespace

bool BeadModel::excluded(std::uint32_t a, std::uint32_t b) const {
  const auto lo = exclusion.begin() + exclusion_start[a];
  const auto hi = exclusion.begin() + exclusion_start[a + 1];
  return std::binary_search(lo, hi, b);
}

// An instrument's fields, checked; its axes normalized (world_desc_checks.hpp).
void check_instrument(InstrumentDesc& ins, std::size_t i) {
  const std::string where = fmt::format("instrument[{}]", i);
  check_radius(where + ".radius", ins.radius);
  if (!std::isfinite(ins.length) || !(ins.length > 0.0) || ins.length > 10.0)
    fail(where + ".length", fmt::format("expected a length in (0, 10] m, got {}", ins.length));
  if (!std::isfinite(ins.grasp_reach) || ins.grasp_reach < 0.0 || ins.grasp_reach > 0.5)
    fail(where + ".grasp_reach", fmt::format("expected a reach in [0, 0.5] m, got {}", ins.grasp_reach));
  if (!std::isfinite(ins.force_filter) || ins.force_filter < 0.0 || ins.force_filter > 100.0)
    fail(where + ".force_filter", fmt::format("expected a time constant in [0, 100] s, got {}", ins.force_filter));
  if (!std::isfinite(ins.coupling_stiffness) || ins.coupling_stiffness < 0.0 || ins.coupling_stiffness > 1e7)
    fail(where + ".coupling_stiffness",
         fmt::format("expected a stiffness in [0, 1e7] N/m (0: a rigid grasp), got {}", ins.coupling_stiffness));
  if (!std::isfinite(ins.coupling_damping) || ins.coupling_damping < 0.0 || ins.coupling_damping > 1e5)
    fail(where + ".coupling_damping",
         fmt::format("expected a damping in [0, 1e5] N·s/m, got {}", ins.coupling_damping));
  if (!(ins.force_limit > 0.0) || ins.force_limit > 1e5)  // infinity is refused too: the limit is the point
    fail(where + ".force_limit", fmt::format("expected a force in (0, 1e5] N, got {}", ins.force_limit));
  if (!std::isfinite(ins.holding_force) || ins.holding_force < 0.0 || ins.holding_force > kMaxVectorComponent)
    fail(where + ".holding_force", fmt::format("expected a force in [0, {:g}] N (0: the grasp never slips), got {}",
                                               kMaxVectorComponent, ins.holding_force));
  if (!std::isfinite(ins.cut_radius) || !(ins.cut_radius > 0.0) || ins.cut_radius > 0.5)
    fail(where + ".cut_radius", fmt::format("expected a radius in (0, 0.5] m, got {}", ins.cut_radius));
  check_finite(where + ".tip", ins.tip);
  check_unit(where + ".axis", ins.axis);
  ins.axis.normalize();
  for (std::size_t k = 0; k < ins.keyframes.size(); ++k) {
    InstrumentKeyframe& kf = ins.keyframes[k];
    const std::string kw = fmt::format("{}.keyframe[{}]", where, k);
    if (!std::isfinite(kf.time) || std::abs(kf.time) > kMaxKeyframeTime)
      fail(kw + ".time", fmt::format("expected a time in s within ±{:g}, got {}", kMaxKeyframeTime, kf.time));
    if (k > 0 && !(kf.time > ins.keyframes[k - 1].time))
      fail(kw + ".time",
           fmt::format("keyframes must come in increasing time: {} after {}", kf.time, ins.keyframes[k - 1].time));
    check_finite(kw + ".tip", kf.tip);
    check_unit(kw + ".axis", kf.axis);
    kf.axis.normalize();
  }
}

void build_environment(const WorldDesc& desc, WorldModel& m) {
  const ContactDesc& c = desc.contact;
  if (!std::isfinite(c.coefficient) || !(c.coefficient > 0.0) || c.coefficient > 1e6)
    fail("contact.coefficient", fmt::format("expected a positive coefficient up to 1e6, got {}", c.coefficient));
  if (!std::isfinite(c.exponent) || c.exponent < 1.0 || c.exponent > 4.0)
    fail("contact.exponent", fmt::format("expected an exponent in [1, 4], got {}", c.exponent));
  if (!std::isfinite(c.margin) || c.margin > 0.5)
    fail("contact.margin",
         fmt::format("expected a margin in m of at most 0.5 (negative: automatic), got {}", c.margin));
  // The margin and the broad phase are resolved once the beads exist (build_rest_exclusions).
  m.contact = {c.coefficient, c.exponent, c.margin, c.broad_phase, c.self, c.rest_exclusions};
  const EnvironmentDesc& env = desc.environment;
  for (std::size_t i = 0; i < env.planes.size(); ++i) {
    const PlaneDesc& p = env.planes[i];
    check_finite(fmt::format("environment.plane[{}].point", i), p.point);
    check_unit(fmt::format("environment.plane[{}].normal", i), p.normal);
    m.environment.planes.push_back({p.point, p.normal.normalized()});
  }
  for (std::size_t i = 0; i < env.spheres.size(); ++i) {
    const SphereObstacleDesc& s = env.spheres[i];
    check_finite(fmt::format("environment.sphere[{}].center", i), s.center);
    check_obstacle_radius(fmt::format("environment.sphere[{}].radius", i), s.radius);
    m.environment.spheres.push_back({s.center, s.radius});
  }
  for (std::size_t i = 0; i < env.capsules.size(); ++i) {
    const CapsuleObstacleDesc& s = env.capsules[i];
    check_finite(fmt::format("environment.capsule[{}].a", i), s.a);
    check_finite(fmt::format("environment.capsule[{}].b", i), s.b);
    check_obstacle_radius(fmt::format("environment.capsule[{}].radius", i), s.radius);
    m.environment.capsules.push_back({s.a, s.b, s.radius});
  }
  for (std::size_t i = 0; i < env.meshes.size(); ++i) {
    const MeshObstacleDesc& mesh = env.meshes[i];
    const std::string where = fmt::format("environment.mesh[{}]", i);
    if (mesh.triangles.empty()) fail(where, "the mesh has no triangles");
    for (const auto& t : mesh.triangles)
      for (std::uint32_t v : t)
        if (v >= mesh.vertices.size())
          fail(where, fmt::format("a triangle uses vertex {} but there are {}", v, mesh.vertices.size()));
    for (const auto& v : mesh.vertices)
      if (!v.allFinite() || v.cwiseAbs().maxCoeff() > kMaxVectorComponent)
        fail(where, fmt::format("a vertex at ({:.6g}, {:.6g}, {:.6g}) m (after scale and translate): vertices must be "
                                "finite and within ±{:g} m",
                                v.x(), v.y(), v.z(), kMaxVectorComponent));
    if (mesh.container) check_container(mesh, where);
    m.environment.mesh_container.push_back(mesh.container ? 1 : 0);
  }
  m.meshes = std::make_shared<const StaticMeshes>(env.meshes);
  for (std::size_t i = 0; i < desc.instruments.size(); ++i) {
    InstrumentDesc d = desc.instruments[i];
    check_instrument(d, i);  // normalizes its axes
    m.instruments.push_back(instrument_model(d));
  }
}

InstrumentModel instrument_model(const InstrumentDesc& d) {
  return {.name = d.name,
          .radius = d.radius,
          .length = d.length,
          .grasp_reach = d.grasp_reach,
          .hold_frame = d.hold_frame,
          .force_filter = d.force_filter,
          .coupling_stiffness = d.coupling_stiffness,
          .coupling_damping = d.coupling_damping,
          .force_limit = d.force_limit,
          .proxy = d.proxy,
          .holding_force = d.holding_force,
          .cut_radius = d.cut_radius,
          .tip = d.tip,
          .axis = d.axis,
          .keyframes = d.keyframes};
}

// Beads whose node the mesh does not surround (a centreline running past an open end, rays
// escaping there) take the radius of the nearest bead it does surround, along the rod. None
// surrounded: the mesh is not around this rod at all.
void fill_uncovered_radii(std::vector<std::optional<double>>& radii, const std::vector<double>& arcs,
                          const std::string& where, double reach) {
  std::size_t covered = 0;
  for (const auto& r : radii) covered += r ? 1 : 0;
  if (covered == radii.size()) return;
  if (covered == 0)
    throw FieldError(ErrorCode::invalid_geometry, where + ".radius",
                     fmt::format("no bead's node has the organ mesh around it (16 rays in its normal plane, within "
                                 "{:.3g} m): the mesh does not surround the rod",
                                 reach));
  const std::vector<std::optional<double>> measured = radii;
  for (std::size_t i = 0; i < radii.size(); ++i) {
    if (radii[i]) continue;
    double best = 1e300;
    for (std::size_t j = 0; j < measured.size(); ++j)
      if (measured[j] && std::abs(arcs[j] - arcs[i]) < best) {
        best = std::abs(arcs[j] - arcs[i]);
        radii[i] = measured[j];
      }
  }
}

namespace {

// The bead fields of one segment, checked: one way of giving radii, each within bounds.
void check_bead_radii(const BeadsDesc& b, const TriangleMesh& own_mesh, const std::string& where) {
  if (b.radius != 0.0) check_radius(where + ".radius", b.radius);
  for (std::size_t i = 0; i < b.radius_profile.size(); ++i) {
    const auto& [f, r] = b.radius_profile[i];
    if (!std::isfinite(f) || f < 0.0 || f > 1.0 || (i > 0 && f < b.radius_profile[i - 1].first))
      fail(fmt::format("{}.radius_profile[{}]", where, i), "fractions of the length must rise from 0 to 1");
    check_radius(fmt::format("{}.radius_profile[{}]", where, i), r);
  }
  if ((b.radius != 0.0 ? 1 : 0) + (b.radius_profile.empty() ? 0 : 1) + (b.radius_from_mesh ? 1 : 0) > 1)
    fail(where, "give one of radius, radius_profile or radius = \"mesh\"");
  if (b.radius_from_mesh && own_mesh.triangles.empty())
    fail(where + ".radius", "radius = \"mesh\" needs the segment's organ mesh ([segment.mesh])");
}

// The segment's nodes that carry a bead, ascending: a chain places them piece by piece (a joint
// node gets one bead).
std::vector<std::size_t> segment_bead_nodes(const WorldModel& m, const SegmentModel& seg, const BeadsDesc& b,
                                            std::span<const double> h, const std::string& where) {
  std::vector<std::size_t> rod_nodes;
  for (std::size_t p = seg.first_piece; p < seg.first_piece + seg.piece_count; ++p) {
    const SegmentPiece& piece = m.pieces[p];
    SegmentModel span_of_piece;
    span_of_piece.node_count = piece.info.nodes.count;
    for (std::size_t k : bead_nodes(b, span_of_piece, h.subspan(piece.first_node, piece.info.nodes.count - 1), where))
      rod_nodes.push_back(piece.first_node + k);
  }
  std::sort(rod_nodes.begin(), rod_nodes.end());
  rod_nodes.erase(std::unique(rod_nodes.begin(), rod_nodes.end()), rod_nodes.end());
  return rod_nodes;
}

// Each bead's radius: the profile at its arc length, the one radius, the cross-section's, or
// measured from the organ mesh at its rest pose (gaps filled from the nearest measured bead).
std::vector<double> bead_radii(const SegmentDesc& sd, const SegmentModel& seg,
                               const std::vector<std::size_t>& rod_nodes, std::span<const double> h,
                               const RodPoseBuffer& rest_poses, const TriangleMesh& own_mesh,
                               const std::string& where) {
  const BeadsDesc& b = sd.beads;
  std::unique_ptr<EmbreeScene> wall;
  if (b.radius_from_mesh) {
    wall = std::make_unique<EmbreeScene>();
    wall->add_triangles(own_mesh.vertices, own_mesh.triangles);
    wall->commit();
  }
  double arc = 0.0;
  std::size_t last = 0;
  std::vector<double> arcs;
  std::vector<std::optional<double>> radii;
  for (std::size_t k : rod_nodes) {
    for (; last < k; ++last) arc += h[last];
    const double fraction = arc / seg.info.length;
    std::optional<double> r = !b.radius_profile.empty() ? profile_radius(b.radius_profile, fraction)
                              : b.radius != 0.0         ? b.radius
                                                        : sd.cross_section.radius;
    if (b.radius_from_mesh) {
      const kernels::RodPoses<const double> rest = rest_poses.view();
      r = mesh_cross_section_radius(*wall, {rest.node_rotation.get(k), rest.node_position.get(k)},
                                    10.0 * sd.cross_section.radius);
    }
    arcs.push_back(arc);
    radii.push_back(r);
  }
  fill_uncovered_radii(radii, arcs, where, 10.0 * sd.cross_section.radius);
  std::vector<double> out;
  for (const std::optional<double>& r : radii) out.push_back(*r);
  return out;
}

// Each piece's beads: those on its nodes, a joint's going to the later piece.
void assign_piece_beads(const BeadModel& beads, const SegmentModel& seg, std::vector<SegmentPiece>& pieces) {
  for (std::size_t p = seg.first_piece; p < seg.first_piece + seg.piece_count; ++p) {
    SegmentPiece& piece = pieces[p];
    const bool last_piece = p + 1 == seg.first_piece + seg.piece_count;
    const std::size_t end = piece.first_node + piece.info.nodes.count - (last_piece ? 0 : 1);
    piece.bead_offset = beads.size();
    for (std::size_t bead = seg.bead_offset; bead < seg.bead_offset + seg.bead_count; ++bead) {
      const std::size_t k = beads.node[bead] - seg.node_offset;
      if (k < piece.first_node) continue;
      if (k >= end) break;
      piece.bead_offset = std::min(piece.bead_offset, bead);
      ++piece.bead_count;
    }
    if (piece.bead_count == 0) piece.bead_offset = seg.bead_offset + seg.bead_count;
  }
}

// Rest-pose exclusions: pairs of one segment (or of any two: contact.rest_exclusions) whose spheres
// overlap or touch at rest; and the
// contact margin (half the smallest bead unless given).
void build_rest_exclusions(const std::vector<Eigen::Vector3d>& initial_positions, WorldModel& m) {
  BeadModel& beads = m.beads;
  const std::size_t nb = beads.size();
  std::vector<double> x(nb), y(nb), z(nb);
  for (std::size_t i = 0; i < nb; ++i) {
    x[i] = initial_positions[beads.node[i]].x();
    y[i] = initial_positions[beads.node[i]].y();
    z[i] = initial_positions[beads.node[i]].z();
  }
  const kernels::SphereSet set{x, y, z, beads.radius};
  double smallest = 1e300;
  for (double r : beads.radius) smallest = std::min(smallest, r);
  // "Touch" allows for rounding: a bead chain laid exactly tangent at rest stays excluded.
  const double touch = nb > 0 ? 1e-9 * smallest : 0.0;
  std::vector<kernels::SpherePair> pairs(8 * nb + 16);
  kernels::SphereGrid grid;
  grid.build(set, touch);
  std::size_t count = grid.query(set, 0, nb, pairs);
  if (count > pairs.size()) {
    pairs.resize(count);
    count = grid.query(set, 0, nb, pairs);
  }
  const bool across = m.contact.rest_exclusions == RestExclusions::world;
  auto kept = [&](const kernels::SpherePair& pair) { return across || beads.segment[pair.a] == beads.segment[pair.b]; };
  beads.exclusion_start.assign(nb + 1, 0);
  for (std::size_t p = 0; p < count; ++p)
    if (kept(pairs[p])) ++beads.exclusion_start[pairs[p].a + 1];
  for (std::size_t i = 0; i < nb; ++i) beads.exclusion_start[i + 1] += beads.exclusion_start[i];
  beads.exclusion.assign(beads.exclusion_start[nb], 0);
  std::vector<std::uint32_t> fill(beads.exclusion_start.begin(), beads.exclusion_start.end() - 1);
  for (std::size_t p = 0; p < count; ++p)  // pairs come in ascending (a, b): lists come sorted
    if (kept(pairs[p])) beads.exclusion[fill[pairs[p].a]++] = pairs[p].b;
  // The description's margin (negative: automatic) and broad phase, resolved (ContactModel).
  if (m.contact.margin < 0.0) m.contact.margin = nb > 0 ? 0.5 * smallest : 0.0;
  if (m.contact.broad_phase == BroadPhase::automatic)
    m.contact.broad_phase = nb < kBruteForceBelow ? BroadPhase::brute : BroadPhase::grid;
}

}  // namespace

void build_beads(const WorldDesc& desc, const std::vector<Eigen::Vector3d>& initial_positions,
                 const std::vector<RodPoseBuffer>& rest_poses, const std::vector<TriangleMesh>& meshes, WorldModel& m) {
  BeadModel& beads = m.beads;
  for (std::size_t si = 0; si < m.segments.size(); ++si) {
    SegmentModel& seg = m.segments[si];
    const BeadsDesc& b = desc.segments[si].beads;
    seg.bead_offset = beads.size();
    for (std::size_t p = seg.first_piece; p < seg.first_piece + seg.piece_count; ++p)
      m.pieces[p].bead_offset = beads.size();
    if (!b.enabled) continue;
    const std::string where = fmt::format("segment[{}].beads", si);
    const std::span<const double> h =
        std::span<const double>(m.section_length).subspan(seg.node_offset, seg.node_count - 1);
    const TriangleMesh& own_mesh = meshes[seg.first_piece];  // only a single piece may take radii from it
    check_bead_radii(b, own_mesh, where);
    const std::vector<std::size_t> rod_nodes = segment_bead_nodes(m, seg, b, h, where);
    const std::vector<double> radii = bead_radii(desc.segments[si], seg, rod_nodes, h, rest_poses[si], own_mesh, where);
    for (std::size_t i = 0; i < rod_nodes.size(); ++i) {
      beads.node.push_back(static_cast<std::uint32_t>(seg.node_offset + rod_nodes[i]));
      beads.segment.push_back(static_cast<std::uint32_t>(si));
      beads.radius.push_back(radii[i]);
      beads.modulus.push_back(desc.segments[si].material.youngs_modulus);
    }
    seg.bead_count = beads.size() - seg.bead_offset;
    assign_piece_beads(beads, seg, m.pieces);
  }
  build_rest_exclusions(initial_positions, m);
}

}  // namespace haustra::detail
