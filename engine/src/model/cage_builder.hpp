#pragma once
// The cage around an organ mesh (the paper's §6.1–6.2), built once, in the binding pose.
//
// Binding pose: like the paper ("we build up a cage at the binding pose where the whole rectum is
// fully extended"), the mesh is taken into the rod's material coordinates: every vertex x becomes
// (o_x, o_y, s + o_z), s its closest point on the rest centreline and o its offset in the rod's
// frame there. In that straight pose the rings are parallel: a bead template ring on every bead's
// node and a middle template ring at the rod station (node or section midpoint) nearest halfway
// between adjacent beads, m vertices each; quads join consecutive rings, one vertex caps each end.
// Every ring vertex starts where a ray from the ring's centre meets the (straightened) mesh wall,
// plus the clearance, and is pushed outward (caps: along the axis) until Embree finds every mesh
// vertex inside the cage, no mesh edge crossing it and no cage triangle crossing another.
//
// A real colon bends with radii close to its own radius and its loops touch: a cage of planar
// rings around the curved rest pose folds on the inner side of such bends (all ring planes of a
// bend meet at its axis). In the binding pose no ring plane meets another. Every cage vertex is a
// fixed offset in its ring's frame, so the same cage, carried by the rest poses of the rings'
// stations, is the cage at the curved rest pose (docs/decisions/0017-cage-in-the-binding-pose.md).
#include <cstdint>
#include <string>
#include <vector>

#include "haustra/kernels/cage_rings.hpp"
#include "haustra/kernels/spans.hpp"
#include "haustra/mesh_io.hpp"
#include "haustra/world.hpp"
#include "haustra/world_desc.hpp"

namespace haustra::detail {

struct CageModel {
  std::vector<std::uint32_t> ring_station;              // per ring: 2k node k, 2k + 1 midpoint of section k
  std::vector<kernels::RingPose> ring_rest;             // per ring, the station's rest pose (curved)
  std::vector<kernels::RingPose> ring_binding;          // per ring, in the binding pose (straight)
  std::vector<std::int32_t> ring_bead;                  // per ring: the bead (local index) or −1 for a middle ring
  std::vector<std::uint32_t> vertex_ring;               // per cage vertex
  std::vector<Eigen::Vector3d> offset;                  // per cage vertex, in its ring's frame
  std::vector<Eigen::Vector3d> binding_vertices;        // per cage vertex, binding pose
  std::vector<Eigen::Vector3d> rest_vertices;           // per cage vertex, curved rest pose
  std::vector<std::array<std::uint32_t, 3>> triangles;  // outward
  std::vector<Eigen::Vector3d> mesh_binding;            // the mesh's vertices in the binding pose
  std::vector<double> mesh_place;                       // each mesh vertex's place s along the rod (m)
  // Rings from here on are the rod's stations (every node and section midpoint), with no cage
  // vertices: the frames the along-rod skin blends (decision 0117). The cage's own rings: all before.
  std::size_t first_station_ring = 0;
};

struct CageBuildInput {
  kernels::RodPoses<const double> rest;  // the segment's rest poses (nodes and section midpoints)
  std::span<const double> section_length;
  std::span<const double> rest_strain;  // 4 per node
  std::vector<std::size_t> bead_node;   // local, ascending
  std::vector<double> bead_radius;
  const TriangleMesh* mesh = nullptr;  // at rest, metres
  CageDesc desc;
  double clearance = 0.0;         // m, resolved
  bool harmonic_binding = false;  // resolved from desc.binding (decision 0049)
  // Each mesh vertex's place along this piece's rod (m), when the whole organ's surface was placed
  // once (and cut where loops were fused): the binding takes these instead of placing the piece afresh.
  std::span<const double> places;
  // Rings from the mesh's cross-sections around them, and rings past the ends where the mesh runs
  // on (decision 0049); otherwise the paper's templates, as for the procedural organs.
  bool cross_section_rings = false;
  std::string where;  // e.g. "segment[0].mesh", for messages
};

// Throws FieldError{invalid_geometry} naming the ring when no embedding cage exists.
CageModel build_cage(const CageBuildInput& in, CageReport& report);

}  // namespace haustra::detail
