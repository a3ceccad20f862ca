#pragma once
// The frame's last stages: cage rings follow the rod, the organ meshes follow the rings, normals.
// They write to a MeshTarget: the world's own mesh state, or a reader's frame slot (decision 0060).
#include "haustra/kernels/cage_rings.hpp"
#include "haustra/kernels/skinning.hpp"
#include "model/world_model.hpp"
#include "state/world_state.hpp"

namespace haustra::detail {

// Where a mesh update writes: ring poses (model.ring_total), their deltas and screws
// (kRingScratchFloats per ring, as two runs), skinned positions and normals (model.mesh_vertex_total).
struct MeshTarget {
  std::span<const kernels::RingPose> ring_pose;  // read: stage_rings makes them
  std::span<float> ring_delta;
  kernels::FloatVec3Out position, normal;
};

// The world's own mesh state as a target.
MeshTarget own_mesh(WorldState& state);

// Per segment with a mesh: ring poses from the rod's stations (the current frame's poses).
void stage_rings(const WorldModel& model, WorldState& state, std::span<kernels::RingPose> ring_pose, std::size_t piece);
// Per segment with a mesh: the rings' change since rest, and for the along-rod skin the screws
// between its stations (reads only the model and the target).
void stage_ring_deltas(const WorldModel& model, const MeshTarget& target, std::size_t piece);
// Per skinning chunk: vertices from the ring deltas (rigid-group form) or the screws (along the rod).
void stage_skin(const WorldModel& model, const MeshTarget& target, std::size_t chunk);
// Once skinned: the vertices a chain's cut copied into two pieces, set to their mean.
void stage_weld_seams(const WorldModel& model, const MeshTarget& target);
// Per normals chunk (segments that asked for normals): its vertices' normals, 8 at a time over
// their corner pairs (kernels/mesh_normals).
void stage_normals(const WorldModel& model, const MeshTarget& target, std::size_t chunk);

}  // namespace haustra::detail
