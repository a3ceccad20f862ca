// The organ meshes' binding as a host's GPU reads it, and each frame's ring data (decision 0110).
#include <fmt/format.h>

#include <algorithm>

#include "haustra/kernels/cage_rings.hpp"
#include "haustra/kernels/skinning.hpp"
#include "model/skin_binding.hpp"
#include "step/world_impl.hpp"

namespace haustra {

namespace {

constexpr std::uint8_t kRigid = 0, kScrewPlace = 1, kScrewWeight = 2;

// Every vertex's own slots (ring global, four coefficients), in the kernel's order, leaving out
// the block's padding (a slot whose four coefficients are zero for this lane adds exactly nothing
// on the CPU either). A screw is two slots; `kind` says which coefficients a cut's 1/n scales.
struct Row {
  std::vector<std::uint32_t> start{0};
  std::vector<std::uint32_t> ring;
  std::vector<float> coefficient;
  std::vector<std::uint8_t> kind;  // per slot: kRigid (all four scale), kScrewPlace (none), kScrewWeight (the first)
};

struct RowBuilder {
  std::vector<std::vector<std::uint32_t>> ring;
  std::vector<std::vector<float>> coef;
  std::vector<std::vector<std::uint8_t>> kind;
  explicit RowBuilder(std::size_t vertices) : ring(vertices), coef(vertices), kind(vertices) {}
  void add(std::size_t v, std::uint32_t g, const float four[4], std::uint8_t k = kRigid) {
    ring[v].push_back(g);
    coef[v].insert(coef[v].end(), four, four + 4);
    kind[v].push_back(k);
  }
  Row rows() const {
    Row r;
    for (std::size_t v = 0; v < ring.size(); ++v) {
      r.ring.insert(r.ring.end(), ring[v].begin(), ring[v].end());
      r.coefficient.insert(r.coefficient.end(), coef[v].begin(), coef[v].end());
      r.kind.insert(r.kind.end(), kind[v].begin(), kind[v].end());
      r.start.push_back(static_cast<std::uint32_t>(r.ring.size()));
    }
    return r;
  }
};

void rigid_rows(const detail::SegmentMesh& mesh, RowBuilder& out) {
  const detail::SkinBinding& b = mesh.binding;
  for (std::size_t block = 0; block < b.blocks(); ++block)
    for (std::size_t lane = 0; lane < kernels::kSkinLanes; ++lane) {
      const std::uint32_t v = b.vertex[block * kernels::kSkinLanes + lane];
      if (v == kernels::kNoVertex) continue;
      for (std::uint32_t s = b.slot_start[block]; s < b.slot_start[block + 1]; ++s) {
        const float* c = b.coefficient.data() + s * kernels::kSkinCoefficients * kernels::kSkinLanes + lane;
        const float four[4] = {c[0], c[kernels::kSkinLanes], c[2 * kernels::kSkinLanes], c[3 * kernels::kSkinLanes]};
        if (four[0] == 0.0f && four[1] == 0.0f && four[2] == 0.0f && four[3] == 0.0f) continue;
        out.add(mesh.vertex_offset + v, static_cast<std::uint32_t>(mesh.ring_offset + b.ring[s]), four);
      }
    }
}

// An along-rod mesh's vertices as screws (decision 0122): (t, o) and (1, the rest normal in the
// rest screw's frame at t); normal: the CPU's normals at rest, by global vertex.
void screw_rows(const detail::WorldModel& m, const detail::SegmentMesh& mesh, std::span<const float> normal,
                RowBuilder& out) {
  const detail::SkinBinding& b = mesh.binding;
  for (std::size_t i = 0; i < b.vertex.size(); ++i) {
    const std::uint32_t v = b.vertex[i];
    if (v == kernels::kNoVertex) continue;
    const std::size_t s = b.slot_start[i / kernels::kSkinLanes], lane = i % kernels::kSkinLanes;
    const float* c = b.coefficient.data() + s * kernels::kSkinCoefficients * kernels::kSkinLanes + lane;
    const float four[4] = {c[0], c[kernels::kSkinLanes], c[2 * kernels::kSkinLanes], c[3 * kernels::kSkinLanes]};
    const std::uint32_t g = b.ring[s];
    const kernels::RingPose at = kernels::screw_pose(
        kernels::screw_between(mesh.cage.ring_rest[g], mesh.cage.ring_rest[g + 1]), double(four[0]));
    const std::size_t global = mesh.vertex_offset + v;
    const Eigen::Vector3d n =
        at.rotation.transpose() * Eigen::Vector3d(normal[3 * global], normal[3 * global + 1], normal[3 * global + 2]);
    const float second[4] = {1.0f, float(n.x()), float(n.y()), float(n.z())};
    const auto ring = static_cast<std::uint32_t>(m.ring_total + mesh.ring_offset + g) | kGpuScrewSlot;
    out.add(global, ring, four, kScrewPlace);
    out.add(global, ring, second, kScrewWeight);
  }
}

// The slots of every vertex as the shader reads them; a vertex on a chain's cut takes its group's
// slots, each weighted 1/n, which is the CPU's mean of the group's skinned copies.
void append_rows(const detail::WorldModel& model, const Row& own, std::vector<std::uint32_t>& range,
                 std::vector<std::uint32_t>& ring, std::vector<float>& coefficient, std::uint32_t& most) {
  const std::size_t vertices = model.mesh_vertex_total;
  std::vector<std::uint32_t> group_of(vertices, kernels::kNoVertex);
  for (std::size_t k = 0; k + 1 < model.seam_group_start.size(); ++k)
    for (std::uint32_t i = model.seam_group_start[k]; i < model.seam_group_start[k + 1]; ++i)
      group_of[model.seam_group_members[i]] = static_cast<std::uint32_t>(k);
  range.resize(2 * vertices);
  auto append = [&](std::size_t v, float scale) {
    for (std::uint32_t s = own.start[v]; s < own.start[v + 1]; ++s) {
      ring.push_back(own.ring[s]);
      for (int c = 0; c < 4; ++c) {
        const bool scaled = own.kind[s] == kRigid || (own.kind[s] == kScrewWeight && c == 0);
        coefficient.push_back(scaled ? scale * own.coefficient[4 * s + c] : own.coefficient[4 * s + c]);
      }
    }
  };
  for (std::size_t v = 0; v < vertices; ++v) {
    const auto first = static_cast<std::uint32_t>(ring.size());
    if (const std::uint32_t k = group_of[v]; k != kernels::kNoVertex) {
      const std::uint32_t a = model.seam_group_start[k], b = model.seam_group_start[k + 1];
      for (std::uint32_t i = a; i < b; ++i) append(model.seam_group_members[i], 1.0f / float(b - a));
    } else {
      append(v, 1.0f);
    }
    range[2 * v] = first;
    range[2 * v + 1] = static_cast<std::uint32_t>(ring.size()) - first;
    most = std::max(most, range[2 * v + 1]);
  }
}

}  // namespace

// Positions and normals at rest come from the CPU's own stages at the rest rings (so a seam's
// vertices are welded and the normals are the kernel's).
GpuSkinBinding World::Impl::make_gpu_skin() const {
  GpuSkinBinding g;
  g.vertices = model.mesh_vertex_total;
  g.rings = model.ring_total;
  std::vector<kernels::RingPose> rest(model.ring_total);
  for (const detail::SegmentMesh& mesh : model.meshes_of)
    if (mesh.enabled)
      std::copy(mesh.cage.ring_rest.begin(), mesh.cage.ring_rest.end(),
                rest.begin() + std::ptrdiff_t(mesh.ring_offset));
  std::vector<float> scratch(kernels::kRingScratchFloats * model.ring_total);
  detail::FloatVec3Buffer p, n;
  p.resize(g.vertices);
  n.resize(g.vertices);
  mesh_from_rings({rest, scratch, p.out(), n.out()});
  g.rest_position.resize(3 * g.vertices);
  g.rest_normal.resize(3 * g.vertices);
  for (std::size_t v = 0; v < g.vertices; ++v) {
    g.rest_position[3 * v] = p.x[v], g.rest_position[3 * v + 1] = p.y[v], g.rest_position[3 * v + 2] = p.z[v];
    g.rest_normal[3 * v] = n.x[v], g.rest_normal[3 * v + 1] = n.y[v], g.rest_normal[3 * v + 2] = n.z[v];
  }
  RowBuilder rows(g.vertices), linear(g.vertices);
  bool any_screw = false;
  for (const detail::SegmentMesh& mesh : model.meshes_of) {
    if (!mesh.enabled) continue;
    if (!mesh.binding.screw) {
      rigid_rows(mesh, rows);
      rigid_rows(mesh, linear);
      continue;
    }
    any_screw = true;
    screw_rows(model, mesh, g.rest_normal, rows);
    TriangleMesh at_rest;  // the piece's rest vertices, as its binding holds them
    at_rest.vertices.resize(mesh.binding.vertices);
    for (std::size_t i = 0; i < mesh.binding.vertex.size(); ++i)
      if (const std::uint32_t v = mesh.binding.vertex[i]; v != kernels::kNoVertex)
        at_rest.vertices[v] = {mesh.binding.rest_x[i], mesh.binding.rest_y[i], mesh.binding.rest_z[i]};
    detail::along_rod_linear_slots(
        mesh.cage, mesh.binding, at_rest, [&](std::uint32_t v, std::uint32_t ring, double b, const Eigen::Vector3d& a) {
          const float four[4] = {float(b), float(a.x()), float(a.y()), float(a.z())};
          linear.add(mesh.vertex_offset + v, static_cast<std::uint32_t>(mesh.ring_offset + ring), four);
        });
  }
  append_rows(model, rows.rows(), g.slot_range, g.slot_ring, g.slot_coefficient, g.max_slots);
  if (any_screw)
    append_rows(model, linear.rows(), g.linear_slot_range, g.linear_slot_ring, g.linear_slot_coefficient,
                g.linear_max_slots);
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
  const bool with_screws = out.size() == kGpuRingDataFloats * m.ring_total;
  if (rings.size() != m.ring_total || (!with_screws && out.size() != kGpuRingFloats * m.ring_total))
    throw Error(ErrorCode::invalid_argument,
                fmt::format("gpu_ring_frame: expected {} ring poses and {} floats (kGpuRingDataFloats a ring; {}, "
                            "kGpuRingFloats a ring, for the rings alone), given {} and {}",
                            m.ring_total, kGpuRingDataFloats * m.ring_total, kGpuRingFloats * m.ring_total,
                            rings.size(), out.size()));
  const std::span<float> screws = with_screws ? out.subspan(kGpuRingFloats * m.ring_total) : std::span<float>();
  for (const detail::SegmentMesh& mesh : m.meshes_of) {
    if (!mesh.enabled) continue;
    const std::size_t n = mesh.cage.ring_station.size();
    kernels::gpu_ring_frame(mesh.cage.ring_rest, rings.subspan(mesh.ring_offset, n),
                            out.subspan(kGpuRingFloats * mesh.ring_offset, kGpuRingFloats * n));
    if (!with_screws) continue;
    const std::span<float> own = screws.subspan(kGpuRingFloats * mesh.ring_offset, kGpuRingFloats * n);
    if (!mesh.binding.screw) {  // no screw reads it: zeros, the same every frame
      std::fill(own.begin(), own.end(), 0.0f);
      continue;
    }
    const std::size_t first = mesh.cage.first_station_ring;
    std::fill(own.begin(), own.begin() + std::ptrdiff_t(kGpuRingFloats * first), 0.0f);
    kernels::screw_frame(rings.subspan(mesh.ring_offset + first, n - first), own.subspan(kGpuRingFloats * first));
  }
}

}  // namespace haustra
