// The organ meshes' binding as a host's GPU reads it, and each frame's ring data (decision 0110).
#include <fmt/format.h>

#include <algorithm>

#include "haustra/kernels/cage_rings.hpp"
#include "step/world_impl.hpp"

namespace haustra {

namespace {

// One vertex's slots, gathered from its block's lanes (ring global, coefficients b Ax Ay Az).
struct Row {
  std::vector<std::uint32_t> start{0};
  std::vector<std::uint32_t> ring;
  std::vector<float> coefficient;
};

// Every vertex's own slots, in the kernel's order, leaving out the block's padding (a slot whose
// four coefficients are zero for this lane adds exactly nothing on the CPU either).
Row own_rows(const detail::WorldModel& m) {
  std::vector<std::vector<std::uint32_t>> slots_of(m.mesh_vertex_total);
  std::vector<std::vector<float>> coef_of(m.mesh_vertex_total);
  for (const detail::SegmentMesh& mesh : m.meshes_of) {
    if (!mesh.enabled) continue;
    const detail::SkinBinding& b = mesh.binding;
    for (std::size_t block = 0; block < b.blocks(); ++block)
      for (std::size_t lane = 0; lane < kernels::kSkinLanes; ++lane) {
        const std::uint32_t v = b.vertex[block * kernels::kSkinLanes + lane];
        if (v == kernels::kNoVertex) continue;
        const std::size_t global = mesh.vertex_offset + v;
        for (std::uint32_t s = b.slot_start[block]; s < b.slot_start[block + 1]; ++s) {
          const float* c = b.coefficient.data() + s * kernels::kSkinCoefficients * kernels::kSkinLanes + lane;
          const float four[4] = {c[0], c[kernels::kSkinLanes], c[2 * kernels::kSkinLanes], c[3 * kernels::kSkinLanes]};
          if (four[0] == 0.0f && four[1] == 0.0f && four[2] == 0.0f && four[3] == 0.0f) continue;
          slots_of[global].push_back(static_cast<std::uint32_t>(mesh.ring_offset + b.ring[s]));
          coef_of[global].insert(coef_of[global].end(), four, four + 4);
        }
      }
  }
  Row r;
  r.start.reserve(m.mesh_vertex_total + 1);
  for (std::size_t v = 0; v < m.mesh_vertex_total; ++v) {
    r.ring.insert(r.ring.end(), slots_of[v].begin(), slots_of[v].end());
    r.coefficient.insert(r.coefficient.end(), coef_of[v].begin(), coef_of[v].end());
    r.start.push_back(static_cast<std::uint32_t>(r.ring.size()));
  }
  return r;
}

}  // namespace

// Positions and normals at rest come from the CPU's own stages at the rest rings (so a seam's
// vertices are welded and the normals are the kernel's); a seam vertex's slots are its group's,
// each weighted 1/n, which is the CPU's mean of the group's skinned copies.
GpuSkinBinding World::Impl::make_gpu_skin() const {
  GpuSkinBinding g;
  g.vertices = model.mesh_vertex_total;
  g.rings = model.ring_total;
  std::vector<kernels::RingPose> rest(model.ring_total);
  for (const detail::SegmentMesh& mesh : model.meshes_of)
    if (mesh.enabled)
      std::copy(mesh.cage.ring_rest.begin(), mesh.cage.ring_rest.end(),
                rest.begin() + std::ptrdiff_t(mesh.ring_offset));
  std::vector<float> delta(kernels::kRingDeltaFloats * model.ring_total);
  detail::FloatVec3Buffer p, n;
  p.resize(g.vertices);
  n.resize(g.vertices);
  mesh_from_rings({rest, delta, p.out(), n.out()});
  g.rest_position.resize(3 * g.vertices);
  g.rest_normal.resize(3 * g.vertices);
  for (std::size_t v = 0; v < g.vertices; ++v) {
    g.rest_position[3 * v] = p.x[v], g.rest_position[3 * v + 1] = p.y[v], g.rest_position[3 * v + 2] = p.z[v];
    g.rest_normal[3 * v] = n.x[v], g.rest_normal[3 * v + 1] = n.y[v], g.rest_normal[3 * v + 2] = n.z[v];
  }
  const Row own = own_rows(model);
  std::vector<std::uint32_t> group_of(g.vertices, kernels::kNoVertex);
  for (std::size_t k = 0; k + 1 < model.seam_group_start.size(); ++k)
    for (std::uint32_t i = model.seam_group_start[k]; i < model.seam_group_start[k + 1]; ++i)
      group_of[model.seam_group_members[i]] = static_cast<std::uint32_t>(k);
  g.slot_range.resize(2 * g.vertices);
  auto append = [&](std::size_t v, float scale) {
    for (std::uint32_t s = own.start[v]; s < own.start[v + 1]; ++s) {
      g.slot_ring.push_back(own.ring[s]);
      for (int c = 0; c < 4; ++c) g.slot_coefficient.push_back(scale * own.coefficient[4 * s + c]);
    }
  };
  for (std::size_t v = 0; v < g.vertices; ++v) {
    const auto first = static_cast<std::uint32_t>(g.slot_ring.size());
    if (const std::uint32_t k = group_of[v]; k != kernels::kNoVertex) {
      const std::uint32_t a = model.seam_group_start[k], b = model.seam_group_start[k + 1];
      for (std::uint32_t i = a; i < b; ++i) append(model.seam_group_members[i], 1.0f / float(b - a));
    } else {
      append(v, 1.0f);
    }
    g.slot_range[2 * v] = first;
    g.slot_range[2 * v + 1] = static_cast<std::uint32_t>(g.slot_ring.size()) - first;
    g.max_slots = std::max(g.max_slots, g.slot_range[2 * v + 1]);
  }
  return g;
}

const GpuSkinBinding& World::gpu_skin_binding() const {
  const Use use(*this);
  if (!impl_->gpu_skin) impl_->gpu_skin = std::make_unique<GpuSkinBinding>(impl_->make_gpu_skin());
  return *impl_->gpu_skin;
}

void World::gpu_ring_frame(std::span<float> out) const {
  const Use use(*this);
  impl_->bring_mesh_up_to_date(/*rings_only=*/true);
  gpu_ring_frame_from(impl_->state.mesh.ring_pose, out);
}

void World::gpu_ring_frame_from(std::span<const kernels::RingPose> rings, std::span<float> out) const {
  const detail::WorldModel& m = impl_->model;
  if (rings.size() != m.ring_total || out.size() != kGpuRingFloats * m.ring_total)
    throw Error(
        ErrorCode::invalid_argument,
        fmt::format("gpu_ring_frame: expected {} ring poses and {} floats (kGpuRingFloats a ring), given {} and {}",
                    m.ring_total, kGpuRingFloats * m.ring_total, rings.size(), out.size()));
  for (const detail::SegmentMesh& mesh : m.meshes_of) {
    if (!mesh.enabled) continue;
    const std::size_t n = mesh.cage.ring_station.size();
    kernels::gpu_ring_frame(mesh.cage.ring_rest, rings.subspan(mesh.ring_offset, n),
                            out.subspan(kGpuRingFloats * mesh.ring_offset, kGpuRingFloats * n));
  }
}

}  // namespace haustra
