#pragma once
// The cage around an organ mesh (the paper's §6.1–6.2), built once at the rod's rest pose.
//
// Rings: a bead template on every bead's node and a middle template at the rod station (node or
// section midpoint) nearest halfway, in arc length, between adjacent beads. Each ring has m
// vertices in its station's (d1, d2) plane; consecutive rings are joined by quads (two triangles)
// and the ends are capped by one vertex each on the axis. Every ring vertex starts where a ray from
// the ring's centre meets the mesh wall, plus the clearance, and is pushed outward (caps: along the
// axis) until Embree finds every mesh vertex inside the cage and no mesh edge crossing it.
//
// Tight bends: all ring planes of a bend pass through its axis of curvature, so a ring vertex on
// the inner side may reach no farther than where its ray crosses the neighbouring rings' planes
// (it is held at 90 % of that). A middle ring whose cage still intersects itself is dropped; a
// cage that cannot be repaired fails with the ring, its place on the rod and the bend radius there.
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
  std::vector<std::uint32_t> ring_station;    // per ring: 2k node k, 2k + 1 midpoint of section k
  std::vector<kernels::RingPose> ring_rest;   // per ring, at rest
  std::vector<std::int32_t> ring_bead;        // per ring: the bead (local index) or −1 for a middle ring
  std::vector<std::uint32_t> vertex_ring;     // per cage vertex
  std::vector<Eigen::Vector3d> offset;        // per cage vertex, in its ring's frame
  std::vector<Eigen::Vector3d> rest_vertices; // per cage vertex, world, at rest
  std::vector<std::array<std::uint32_t, 3>> triangles;  // outward
};

struct CageBuildInput {
  kernels::RodPoses<const double> rest;  // the segment's rest poses (nodes and section midpoints)
  std::span<const double> section_length;
  std::span<const double> rest_strain;   // 4 per node
  std::vector<std::size_t> bead_node;    // local, ascending
  std::vector<double> bead_radius;
  const TriangleMesh* mesh = nullptr;    // at rest, metres
  CageDesc desc;
  double clearance = 0.0;                // m, resolved
  std::string where;                     // e.g. "segment[0].mesh", for messages
};

// Throws FieldError{invalid_geometry} naming the ring and the bend when no embedding cage exists.
CageModel build_cage(const CageBuildInput& in, CageReport& report);

}  // namespace haustra::detail
