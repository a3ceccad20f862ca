// Mesh stages: cage rings follow the rod, skinning, seams welded, normals.
#include "step/mesh_stages.hpp"

#include "haustra/kernels/mesh_normals.hpp"
#include "haustra/kernels/vertex_weld.hpp"

namespace haustra::detail {

namespace {

// The scratch's second run: kScrewFloats a ring, after every ring's delta.
std::span<float> screws(const WorldModel& model, std::span<float> scratch) {
  return scratch.subspan(kernels::kRingDeltaFloats * model.ring_total, kernels::kScrewFloats * model.ring_total);
}

}  // namespace

MeshTarget own_mesh(WorldState& state) {
  return {state.mesh.ring_pose, state.mesh.ring_delta, state.mesh.position.out(), state.mesh.normal.out()};
}

void stage_rings(const WorldModel& model, WorldState& state, std::span<kernels::RingPose> ring_pose,
                 std::size_t piece) {
  const SegmentMesh& mesh = model.meshes_of[piece];
  if (!mesh.enabled) return;
  const SegmentPiece& p = model.pieces[piece];
  kernels::ring_poses(segment_views(model, state, p.rod).poses.subview(p.first_node, p.info.nodes.count),
                      mesh.cage.ring_station, ring_pose.subspan(mesh.ring_offset, mesh.cage.ring_station.size()));
}

void stage_ring_deltas(const WorldModel& model, const MeshTarget& target, std::size_t piece) {
  const SegmentMesh& mesh = model.meshes_of[piece];
  if (!mesh.enabled) return;
  const std::size_t rings = mesh.cage.ring_station.size();
  if (mesh.binding.screw) {  // the along-rod skin reads its stations' screws alone
    const std::size_t first = mesh.ring_offset + mesh.cage.first_station_ring;
    const std::size_t stations = rings - mesh.cage.first_station_ring;
    kernels::screw_frame(
        target.ring_pose.subspan(first, stations),
        screws(model, target.ring_delta).subspan(kernels::kScrewFloats * first, kernels::kScrewFloats * stations));
    return;
  }
  kernels::ring_deltas(
      mesh.cage.ring_rest, target.ring_pose.subspan(mesh.ring_offset, rings),
      target.ring_delta.subspan(kernels::kRingDeltaFloats * mesh.ring_offset, kernels::kRingDeltaFloats * rings));
}

void stage_skin(const WorldModel& model, const MeshTarget& target, std::size_t chunk) {
  const SkinChunk& c = model.skin_chunks[chunk];
  const SegmentMesh& mesh = model.meshes_of[c.piece];
  const std::size_t n = mesh.binding.vertices;
  auto part = [&](std::span<float> v) { return v.subspan(mesh.vertex_offset, n); };
  const std::size_t rings = mesh.cage.ring_station.size();
  const kernels::FloatVec3Out out{part(target.position.x), part(target.position.y), part(target.position.z)};
  if (mesh.binding.screw) {
    kernels::skin_screw(mesh.binding.view(),
                        screws(model, target.ring_delta)
                            .subspan(kernels::kScrewFloats * mesh.ring_offset, kernels::kScrewFloats * rings),
                        c.first_block, c.blocks, out);
    return;
  }
  kernels::skin_rigid_groups(
      mesh.binding.view(),
      std::span<const float>(target.ring_delta)
          .subspan(kernels::kRingDeltaFloats * mesh.ring_offset, kernels::kRingDeltaFloats * rings),
      c.first_block, c.blocks, out);
}

void stage_weld_seams(const WorldModel& model, const MeshTarget& target) {
  if (model.seam_group_members.empty()) return;
  kernels::weld_vertex_groups(model.seam_group_start, model.seam_group_members, target.position.x, target.position.y,
                              target.position.z);
}

void stage_normals(const WorldModel& model, const MeshTarget& target, std::size_t chunk) {
  const NormalChunk& c = model.normal_chunks[chunk];
  kernels::vertex_normals_blocked({model.normal_slot_start, model.normal_slots, model.normal_gather_pairs},
                                  c.first_block, model.vertex_corner_start, model.vertex_corner_pairs,
                                  target.position.x, target.position.y, target.position.z, c.first_vertex, c.vertices,
                                  target.normal);
}

}  // namespace haustra::detail
