// Organ meshes of the segments: loaded or generated at the rest pose, caged and bound to the rings.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <numeric>
#include <optional>
#include <utility>

#include "haustra/error.hpp"
#include "haustra/kernels/mesh_normals.hpp"
#include "haustra/procedural_organ.hpp"
#include "haustra/rod_curve.hpp"
#include "model/binding_arcs.hpp"
#include "model/field_checks.hpp"
#include "model/fused_contacts.hpp"
#include "model/world_model.hpp"

namespace haustra::detail {
namespace {

[[noreturn]] void fail(ErrorCode code, const std::string& field, const std::string& detail) {
  throw FieldError(code, field, detail);
}

constexpr std::size_t kChunkBlocks = 64;  // 512 vertices per skinning task
// A jump in place along the rod across a wall that cuts it into two (organ radii): more than the
// inner side of a bend turns through (π radii at a hairpin), far less than loops apart (issue 35).
constexpr double kFusedJumpRadii = 4.0;
// The cage's one localization rule (decision 0048, kept by 0120): at least 4 rings a vertex, more
// while over 2 % of its weight mass is left out (folded onto the kept rings, decision 0083).
constexpr int kCageRingsAtLeast = 4;
constexpr double kCageWeightLeftOut = 0.02;

// Decision 0049: a mesh from a file binds by the harmonic place unless the scene says otherwise; a
// procedural one, made around the rod, by its closest points.
bool harmonic_binding(const OrganMeshDesc& d) {
  return d.cage.binding == CageBinding::harmonic ||
         (d.cage.binding == CageBinding::automatic && d.source == MeshSource::file);
}

// The vertices a chain's cut copied into two pieces (or more): one vertex of the organ's whole mesh
// (not one point: where a repair split a pinched point, or a cut of fused loops copied one, the
// copies stay apart).
class SeamFinder {
 public:
  void add(std::size_t rod, std::size_t vertex_offset, std::span<const std::uint32_t> origin) {
    for (std::size_t v = 0; v < origin.size(); ++v) {
      const auto world = static_cast<std::uint32_t>(vertex_offset + v);
      const auto [at, first] = point_.try_emplace(Key{rod, origin[v]}, world);
      if (!first) copies_.emplace_back(at->second, world);
    }
  }
  // Groups of a first vertex and its copies, by the first's index (CSR).
  void groups(std::vector<std::uint32_t>& start, std::vector<std::uint32_t>& members) {
    std::stable_sort(copies_.begin(), copies_.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    start.assign(1, 0);
    members.clear();
    for (std::size_t i = 0; i < copies_.size(); ++i) {
      if (i == 0 || copies_[i].first != copies_[i - 1].first) {
        if (i > 0) start.push_back(static_cast<std::uint32_t>(members.size()));
        members.push_back(copies_[i].first);
      }
      members.push_back(copies_[i].second);
    }
    if (!copies_.empty()) start.push_back(static_cast<std::uint32_t>(members.size()));
  }

 private:
  using Key = std::pair<std::size_t, std::uint32_t>;  // the rod, the vertex of its whole mesh
  std::map<Key, std::uint32_t> point_;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> copies_;  // (first, copy)
};

// Each vertex's corner pairs (CSR), for its normal in one pass, summed in a fixed order. A seam's
// copies are one vertex here: every copy lists the pairs of all triangles around the point, in
// every piece, so the pieces' normals agree across the cut as the whole surface's would.
void corner_pairs_across_seams(WorldModel& m) {
  std::vector<std::uint32_t> first(m.mesh_vertex_total);
  std::iota(first.begin(), first.end(), 0U);
  for (std::size_t g = 0; g + 1 < m.seam_group_start.size(); ++g)
    for (std::uint32_t k = m.seam_group_start[g] + 1; k < m.seam_group_start[g + 1]; ++k)
      first[m.seam_group_members[k]] = m.seam_group_members[m.seam_group_start[g]];
  std::vector<std::array<std::uint32_t, 3>> welded = m.mesh_triangles;
  for (auto& t : welded)
    for (std::uint32_t& v : t) v = first[v];
  std::vector<std::uint32_t> start(m.mesh_vertex_total + 1, 0), pairs(6 * welded.size(), 0);
  kernels::vertex_corner_pairs(welded, m.mesh_vertex_total, start, pairs);
  // Copies take their first's list (theirs is empty: no welded triangle names them). `start`
  // counts pairs, two entries each.
  m.vertex_corner_start.assign(1, 0);
  m.vertex_corner_pairs.clear();
  for (std::size_t v = 0; v < m.mesh_vertex_total; ++v) {
    const std::uint32_t f = first[v];
    m.vertex_corner_pairs.insert(m.vertex_corner_pairs.end(), pairs.begin() + 2 * start[f],
                                 pairs.begin() + 2 * start[f + 1]);
    m.vertex_corner_start.push_back(static_cast<std::uint32_t>(m.vertex_corner_pairs.size() / 2));
  }
}

}  // namespace

std::optional<double> mesh_cross_section_radius(const EmbreeScene& wall, const kernels::Pose& station, double reach) {
  constexpr int kRays = 16;
  const Eigen::Matrix3d r = station.rotation.toRotationMatrix();
  std::vector<double> hits;
  for (int i = 0; i < kRays; ++i) {
    const double theta = 2.0 * std::numbers::pi * i / kRays;
    const Eigen::Vector3d dir = std::cos(theta) * r.col(0) + std::sin(theta) * r.col(1);
    const EmbreeScene::Hit h = wall.first_hit(station.position, dir, 0.0, reach);
    if (h.found) hits.push_back(h.distance);
  }
  if (hits.size() < kRays / 2) return std::nullopt;  // past an open end, or outside the mesh
  std::nth_element(hits.begin(), hits.begin() + static_cast<std::ptrdiff_t>(hits.size() / 2), hits.end());
  return hits[hits.size() / 2];
}

// The whole rod's rest centreline, sampled, and a mesh's places along it (harmonic or closest, as
// the binding's kind): what the cut of fused loops and a chain's pieces go by.
struct WholePlaces {
  std::vector<Eigen::Vector3d> samples;
  double length = 0.0;
  std::vector<double> place;  // per vertex, m
  BindingArcs harmonic;       // what the harmonic places found (their arcs moved to `place`)
};

WholePlaces whole_places(const TriangleMesh& mesh, const WorldModel& m, const SegmentModel& seg,
                         const kernels::RodPoses<const double>& rest, bool harmonic) {
  const std::size_t off = seg.node_offset, n = seg.node_count;
  const RodCurve curve(std::span<const double>(m.section_length).subspan(off, n - 1),
                       std::span<const double>(m.rest_strain).subspan(4 * off, 4 * n),
                       {rest.node_rotation.get(0), rest.node_position.get(0)});
  WholePlaces w{.samples = centreline_samples(curve), .length = curve.length(), .place = {}, .harmonic = {}};
  if (harmonic) {
    w.harmonic = harmonic_binding_arcs(mesh, w.samples, w.length);
    w.place = std::move(w.harmonic.arc);
  } else {
    w.place.resize(mesh.vertices.size());
    for (std::size_t v = 0; v < w.place.size(); ++v) w.place[v] = closest_arc(w.samples, w.length, mesh.vertices[v]);
  }
  return w;
}

// A chain's mesh from a file, cut into its pieces: each triangle goes to the piece whose stretch of
// the rod holds its vertices' mean place along the rod (the whole mesh's places, which a harmonic
// binding keeps for every piece: the copies of a cut vertex have one place; a closest-point binding
// places each piece afresh), each piece with its own copy of the vertices it uses (welded back
// together after skinning: each piece vertex's index in the whole mesh says which are one).
void split_into_pieces(const TriangleMesh& mesh, const WorldModel& m, const SegmentModel& seg,
                       const std::vector<double>& arc, const std::string& where, std::vector<TriangleMesh>& meshes,
                       std::vector<PiecePlaces>& placed) {
  const std::size_t off = seg.node_offset;
  // Each piece's first node's place along the rod.
  std::vector<double> starts;
  for (std::size_t p = seg.first_piece; p < seg.first_piece + seg.piece_count; ++p) {
    double s = 0.0;
    for (std::size_t k = 0; k < m.pieces[p].first_node; ++k) s += m.section_length[off + k];
    starts.push_back(s);
  }
  std::vector<std::size_t> piece_of(mesh.triangles.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    const double at = (arc[tri[0]] + arc[tri[1]] + arc[tri[2]]) / 3.0;
    piece_of[t] = static_cast<std::size_t>(std::upper_bound(starts.begin() + 1, starts.end(), at) - starts.begin() - 1);
  }
  std::vector<std::uint8_t> keep(mesh.triangles.size());
  std::vector<std::uint32_t> kept;
  for (std::size_t p = 0; p < seg.piece_count; ++p) {
    for (std::size_t t = 0; t < keep.size(); ++t) keep[t] = piece_of[t] == p ? 1 : 0;
    meshes[seg.first_piece + p] = submesh(mesh, keep, &kept);
    PiecePlaces& out = placed[seg.first_piece + p];
    for (std::uint32_t v : kept) {
      out.place.push_back(arc[v] - starts[p]);
      out.origin.push_back(v);
    }
    if (meshes[seg.first_piece + p].triangles.empty())
      fail(ErrorCode::invalid_geometry, where + ".file",
           fmt::format("no part of the mesh lies along piece {} of the chain (from {:.3f} m along the rod): fewer "
                       "pieces ([segment.chain] pieces) or a mesh that covers the whole centreline",
                       p + 1, starts[p]));
  }
}

std::vector<TriangleMesh> load_organ_meshes(const WorldDesc& desc, const std::vector<RodPoseBuffer>& rest_poses,
                                            const WorldModel& m, std::vector<PiecePlaces>& placed) {
  std::vector<TriangleMesh> meshes(m.pieces.size());
  placed.assign(m.pieces.size(), {});
  for (std::size_t pi = 0; pi < m.pieces.size(); ++pi) {
    const SegmentPiece& piece = m.pieces[pi];
    const std::size_t si = piece.rod;
    const OrganMeshDesc& d = desc.segments[si].mesh;
    if (!d.enabled) continue;
    const std::string where = fmt::format("segment[{}].mesh", si);
    TriangleMesh& mesh = meshes[pi];
    if (d.source == MeshSource::procedural) {
      const std::size_t off = piece.info.nodes.offset, n = piece.info.nodes.count;
      const kernels::RodPoses<const double> rest = rest_poses[si].view();
      const RodCurve curve(std::span<const double>(m.section_length).subspan(off, n - 1),
                           std::span<const double>(m.rest_strain).subspan(4 * off, 4 * n),
                           {rest.node_rotation.get(piece.first_node), rest.node_position.get(piece.first_node)});
      mesh = procedural_organ(curve, d.procedural, desc.segments[si].cross_section.radius, where + ".procedural");
    } else {
      const SegmentModel& seg = m.segments[si];
      if (pi != seg.first_piece) continue;  // a chain's mesh is read once, by its first piece
      if (d.file.empty())
        fail(ErrorCode::invalid_argument, where + ".file", "a mesh from a file needs file = \"path\"");
      if (!std::isfinite(d.scale) || !(d.scale > 0.0) || d.scale > kMaxMeshScale)
        fail(ErrorCode::invalid_argument, where + ".scale",
             fmt::format("expected a positive scale up to {:g} (0.001 for millimetres), got {}", kMaxMeshScale,
                         d.scale));
      if (!d.translate.allFinite() || d.translate.cwiseAbs().maxCoeff() > kMaxVectorComponent)
        fail(ErrorCode::invalid_argument, where + ".translate",
             fmt::format("expected three finite numbers within ±{:g} m to move {} by", kMaxVectorComponent, d.file));
      try {
        mesh = load_mesh(d.file);
      } catch (const Error& e) {
        fail(e.code(), where + ".file", e.what());
      }
      for (auto& v : mesh.vertices) {
        v = d.scale * v + d.translate;
        if (v.cwiseAbs().maxCoeff() > kMaxVectorComponent)
          fail(ErrorCode::invalid_argument, where + ".scale",
               fmt::format("a vertex of {} lands at ({:.6g}, {:.6g}, {:.6g}) m after scale and translate, beyond "
                           "±{:g} m",
                           d.file, v.x(), v.y(), v.z(), kMaxVectorComponent));
      }
      const bool harmonic = harmonic_binding(d);
      if (seg.piece_count == 1 && !harmonic) continue;
      WholePlaces whole = whole_places(mesh, m, seg, rest_poses[si].view(), harmonic);
      // Loops the segmentation fused into one wall (the places jump by more than a stretch of the
      // organ a tight bend could turn through): cut apart, so neither drags the other's skin.
      FusedCut cut;
      if (harmonic) try {
          cut = cut_fused_contacts(mesh, whole.place, kFusedJumpRadii * desc.segments[si].cross_section.radius,
                                   whole.samples, whole.length);
        } catch (const Error& e) {
          fail(e.code(), where + ".file", fmt::format("{}: {}", d.file, e.what()));
        }
      if (seg.piece_count > 1) {
        const TriangleMesh whole_mesh = std::move(mesh);
        mesh = TriangleMesh{};
        split_into_pieces(whole_mesh, m, seg, whole.place, where, meshes, placed);
        if (!harmonic)  // closest points: each piece places its own afresh (with its neighbours' medians)
          for (std::size_t p = 0; p < seg.piece_count; ++p) placed[seg.first_piece + p].place.clear();
      } else {
        placed[pi].place = std::move(whole.place);
      }
      // The whole surface's report goes with the organ's first piece.
      placed[pi].surface_pieces = whole.harmonic.pieces;
      placed[pi].closest_pieces = whole.harmonic.closest_pieces;
      placed[pi].followed = whole.harmonic.followed;
      placed[pi].fused_copies = cut.copies;
    }
  }
  return meshes;
}

namespace {

// The beads of a piece's cage: the rod's beads on its nodes, its joints' included.
std::pair<std::size_t, std::size_t> piece_beads(const WorldModel& m, const SegmentModel& seg, std::size_t off,
                                                std::size_t n) {
  std::size_t first_bead = seg.bead_offset, end_bead = seg.bead_offset;
  for (std::size_t b = seg.bead_offset; b < seg.bead_offset + seg.bead_count; ++b) {
    const std::size_t node = m.beads.node[b];
    if (node < off) first_bead = b + 1;
    if (node < off + n) end_bead = b + 1;
  }
  return {first_bead, end_bead};
}

void check_mesh_fields(const SegmentDesc& sd, const SegmentModel& seg, std::size_t first_bead, std::size_t end_bead,
                       const std::string& where) {
  const OrganMeshDesc& d = sd.mesh;
  if (!std::isfinite(d.cage.clearance) || d.cage.clearance < 0.0 || d.cage.clearance > sd.cross_section.radius)
    fail(ErrorCode::invalid_argument, where + ".cage.clearance",
         fmt::format("expected a clearance in [0, {}] m (0: 5 % of the radius), got {}", sd.cross_section.radius,
                     d.cage.clearance));
  if (end_bead < first_bead + 2)
    fail(ErrorCode::invalid_argument, where,
         seg.piece_count > 1
             ? "the cage is built from the beads: give each piece of the chain at least two beads "
               "([segment.beads])"
             : "the cage is built from the beads: give the segment at least two beads ([segment.beads])");
}

// The piece's mesh in the world's buffers: its rings, vertices and triangles at their offsets, its
// skinning chunks and, with normals, its normal chunks.
void append_mesh_buffers(std::size_t pi, const TriangleMesh& mesh, bool normals, SegmentMesh& out, WorldModel& m) {
  out.ring_offset = m.ring_total;
  m.ring_total += out.cage.ring_station.size();
  out.vertex_offset = m.mesh_vertex_total;
  m.mesh_vertex_total += mesh.vertices.size();
  out.triangle_offset = m.mesh_triangles.size();
  for (const auto& t : mesh.triangles)
    m.mesh_triangles.push_back({static_cast<std::uint32_t>(out.vertex_offset + t[0]),
                                static_cast<std::uint32_t>(out.vertex_offset + t[1]),
                                static_cast<std::uint32_t>(out.vertex_offset + t[2])});
  out.info.vertices = {out.vertex_offset, mesh.vertices.size()};
  out.info.triangles = {out.triangle_offset, mesh.triangles.size()};
  for (std::size_t first = 0; first < out.binding.blocks(); first += kChunkBlocks)
    m.skin_chunks.push_back(
        {static_cast<std::uint32_t>(pi), first, std::min(kChunkBlocks, out.binding.blocks() - first)});
  const std::size_t chunk_vertices = kChunkBlocks * kernels::kSkinLanes;
  if (normals)
    for (std::size_t first = 0; first < mesh.vertices.size(); first += chunk_vertices)
      m.normal_chunks.push_back({static_cast<std::uint32_t>(pi), out.vertex_offset + first,
                                 std::min(chunk_vertices, mesh.vertices.size() - first)});
}

}  // namespace

void bind_organ_meshes(const WorldDesc& desc, const std::vector<RodPoseBuffer>& rest_poses,
                       std::vector<TriangleMesh>& meshes, const std::vector<PiecePlaces>& placed, WorldModel& m) {
  m.meshes_of.assign(m.pieces.size(), SegmentMesh{});
  SeamFinder seams;
  for (std::size_t pi = 0; pi < m.pieces.size(); ++pi) {
    const SegmentPiece& piece = m.pieces[pi];
    const std::size_t si = piece.rod;
    const SegmentDesc& sd = desc.segments[si];
    const OrganMeshDesc& d = sd.mesh;
    if (!d.enabled) continue;
    const std::string where = fmt::format("segment[{}].mesh", si);
    const SegmentModel& seg = m.segments[si];
    const std::size_t off = piece.info.nodes.offset, n = piece.info.nodes.count;
    const auto [first_bead, end_bead] = piece_beads(m, seg, off, n);
    check_mesh_fields(sd, seg, first_bead, end_bead, where);

    SegmentMesh& out = m.meshes_of[pi];
    out.enabled = true;
    out.info.enabled = true;
    out.info.source = d.source == MeshSource::procedural ? "procedural" : d.file;
    CageBuildInput in{.rest = rest_poses[si].view().subview(piece.first_node, n),
                      .section_length = std::span<const double>(m.section_length).subspan(off, n - 1),
                      .rest_strain = std::span<const double>(m.rest_strain).subspan(4 * off, 4 * n),
                      .bead_node = {},
                      .bead_radius = {},
                      .mesh = &meshes[pi],
                      .desc = d.cage,
                      .clearance = d.cage.clearance > 0.0 ? d.cage.clearance : 0.05 * sd.cross_section.radius,
                      .harmonic_binding = harmonic_binding(d),
                      .places = placed[pi].place,
                      .cross_section_rings = d.source == MeshSource::file,
                      .where = where};
    for (std::size_t b = first_bead; b < end_bead; ++b) {
      in.bead_node.push_back(m.beads.node[b] - off);
      in.bead_radius.push_back(m.beads.radius[b]);
    }
    try {
      out.cage = build_cage(in, out.info.cage);
      if (!in.places.empty()) {  // placed with the whole surface: its report, on the organ's first piece
        out.info.cage.binding_pieces = placed[pi].surface_pieces;
        out.info.cage.binding_closest_pieces = placed[pi].closest_pieces;
        out.info.cage.binding_followed = placed[pi].followed;
        out.info.cage.fused_copies = placed[pi].fused_copies;
      }
    } catch (const FieldError& e) {
      // Name the mesh too: the field points at the scene, the detail at what is wrong with the file.
      if (d.source == MeshSource::procedural) throw;
      throw FieldError(e.code(), e.field(), fmt::format("{} (mesh {})", e.detail(), d.file));
    }
    switch (d.skinning) {
      case SkinningMethod::cage:
        out.binding = bind_mean_value(out.cage, meshes[pi], kCageRingsAtLeast, kCageWeightLeftOut, out.info.skin);
        break;
      case SkinningMethod::cage_full: out.binding = bind_mean_value(out.cage, meshes[pi], 0, 0.0, out.info.skin); break;
      case SkinningMethod::linear_blend: out.binding = bind_linear_blend(out.cage, meshes[pi], out.info.skin); break;
      case SkinningMethod::along_rod:  // the rod's own frames at every station, then the vertices on them
        add_station_rings(out.cage, in.rest, in.section_length);
        out.binding = bind_along_rod(out.cage, meshes[pi], out.info.skin);
        break;
    }

    append_mesh_buffers(pi, meshes[pi], d.normals, out, m);
    m.any_mesh = true;
    if (seg.piece_count > 1 && d.source == MeshSource::file) seams.add(si, out.vertex_offset, placed[pi].origin);
    meshes[pi] = TriangleMesh{};  // the binding keeps what stepping needs
  }
  seams.groups(m.seam_group_start, m.seam_group_members);
  corner_pairs_across_seams(m);
  std::size_t blocks = 0;
  for (NormalChunk& c : m.normal_chunks) {
    c.first_block = blocks;
    blocks += kernels::append_normal_blocks(m.vertex_corner_start, m.vertex_corner_pairs, c.first_vertex, c.vertices,
                                            m.normal_slot_start, m.normal_slots, m.normal_gather_pairs);
  }
}

}  // namespace haustra::detail
