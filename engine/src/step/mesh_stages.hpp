#pragma once
// The frame's last stages: cage rings follow the rod, the organ meshes follow the rings, normals.
#include "model/world_model.hpp"
#include "step/world_state.hpp"

namespace haustra::detail {

// Per segment with a mesh: ring poses from the rod's stations and their change since rest.
void stage_cage(const WorldModel& model, WorldState& state, std::size_t segment);
// Per skinning chunk: vertices from the ring deltas (rigid-group form).
void stage_skin(const WorldModel& model, WorldState& state, std::size_t chunk);
// Once skinned: the vertices a chain's cut copied into two pieces, set to their mean.
void stage_weld_seams(const WorldModel& model, WorldState& state);
// Per normals chunk (segments that asked for normals): its vertices' normals, 8 at a time over
// their corner pairs (kernels/mesh_normals).
void stage_normals(const WorldModel& model, WorldState& state, std::size_t chunk);

}  // namespace haustra::detail
