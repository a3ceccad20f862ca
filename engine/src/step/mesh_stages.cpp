// Mesh stages: cage rings follow the rod, skinning, seams welded, normals.
#include "step/mesh_stages.hpp"

#include "haustra/kernels/cage_rings.hpp"
#include "haustra/kernels/mesh_normals.hpp"
#include "haustra/kernels/skinning.hpp"
#include "haustra/kernels/vertex_weld.hpp"

namespace haustra::detail {

void stage_cage(const WorldModel& model, WorldState& state, std::size_t piece) {
  const SegmentMesh& mesh = model.meshes_of[piece];
  if (!mesh.enabled) return;
  const std::size_t rings = mesh.cage.ring_station.size();
  const std::span<kernels::RingPose> pose = std::span(state.mesh.ring_pose).subspan(mesh.ring_offset, rings);
  const SegmentPiece& p = model.pieces[piece];
  kernels::ring_poses(segment_views(model, state, p.rod).poses.subview(p.first_node, p.info.nodes.count),
                      mesh.cage.ring_station, pose);
  kernels::ring_deltas(mesh.cage.ring_rest, pose,
                       std::span(state.mesh.ring_delta)
                           .subspan(kernels::kRingDeltaFloats * mesh.ring_offset, kernels::kRingDeltaFloats * rings));
}

void stage_skin(const WorldModel& model, WorldState& state, std::size_t chunk) {
  const SkinChunk& c = model.skin_chunks[chunk];
  const SegmentMesh& mesh = model.meshes_of[c.piece];
  const std::size_t n = mesh.binding.vertices;
  auto part = [&](std::span<float> v) { return v.subspan(mesh.vertex_offset, n); };
  const std::size_t rings = mesh.cage.ring_station.size();
  kernels::skin_rigid_groups(
      mesh.binding.view(),
      std::span<const float>(state.mesh.ring_delta)
          .subspan(kernels::kRingDeltaFloats * mesh.ring_offset, kernels::kRingDeltaFloats * rings),
      c.first_block, c.blocks, {part(state.mesh.position.x), part(state.mesh.position.y), part(state.mesh.position.z)});
}

void stage_weld_seams(const WorldModel& model, WorldState& state) {
  if (model.seam_group_members.empty()) return;
  kernels::weld_vertex_groups(model.seam_group_start, model.seam_group_members, state.mesh.position.x,
                              state.mesh.position.y, state.mesh.position.z);
}

void stage_normals(const WorldModel& model, WorldState& state, std::size_t chunk) {
  const NormalChunk& c = model.normal_chunks[chunk];
  kernels::vertex_normals_blocked({model.normal_slot_start, model.normal_slots, model.normal_gather_pairs},
                                  c.first_block, model.vertex_corner_start, model.vertex_corner_pairs,
                                  state.mesh.position.x, state.mesh.position.y, state.mesh.position.z, c.first_vertex,
                                  c.vertices, state.mesh.normal.out());
}

}  // namespace haustra::detail
