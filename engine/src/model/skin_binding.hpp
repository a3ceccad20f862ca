#pragma once
// Binding an organ mesh to its cage: mean value coordinates of every mesh vertex in the binding
// pose (in double, in parallel), regrouped by ring into the rigid-group form the skinning kernel
// applies, localized to the rings of largest weight, and made exact at the curved rest pose
// (docs/decisions/0018-skinning-localization.md).
// Linear-blend skinning on the bead rings is bound into the same form, for comparison.
#include <cstdint>
#include <span>
#include <vector>

#include "haustra/kernels/skinning.hpp"
#include "haustra/mesh_io.hpp"
#include "haustra/world.hpp"
#include "model/cage_builder.hpp"

namespace haustra::detail {

struct SkinBinding {
  std::size_t vertices = 0;
  std::vector<std::uint32_t> slot_start;      // blocks + 1
  std::vector<float> rest_x, rest_y, rest_z;  // blocks × lanes
  std::vector<std::uint32_t> vertex;          // blocks × lanes: mesh vertex (local), or kNoVertex
  std::vector<std::uint32_t> ring;            // per slot, local to the segment's rings, local to the segment's rings
  std::vector<float> coefficient;
  // The along-rod screw (decision 0122): one slot a block, ring the station pair's first station,
  // coefficients t, ox, oy, oz (kernels::skin_screw); else the rigid-group form (b, Ax, Ay, Az).
  bool screw = false;
  [[nodiscard]] std::size_t blocks() const { return rest_x.size() / kernels::kSkinLanes; }
  [[nodiscard]] kernels::SkinBindingView view() const {
    return {slot_start, rest_x, rest_y, rest_z, vertex, ring, coefficient};
  }
};

// The kept weights over cage vertices, as CSR rows (the plain reference of the rigid-group form).
struct CageWeights {
  std::vector<std::uint32_t> start, column;
  std::vector<double> weight;
};

// rings_per_vertex: rings kept at least (0: every ring, full MVC); weight_left_out: more rings are
// kept, per vertex, while the weight mass left out exceeds this fraction of the vertex's total
// (0: exactly rings_per_vertex; decision 0048); the weight of the rings left out is folded onto the
// kept rings nearest along the rod (decision 0083). The scene's "cage" is 4 and 0.02, "cage-full" 0
// (decision 0120). csr: when given, filled with the kept MVC weights, renormalized (the binding
// itself when every ring is kept).
SkinBinding bind_mean_value(const CageModel& cage, const TriangleMesh& mesh, int rings_per_vertex,
                            double weight_left_out, SkinReport& report, CageWeights* csr = nullptr);

// Linear-blend skinning on the bead rings: each vertex on the two beads whose centre segment is
// nearest, weights by its position along that segment.
SkinBinding bind_linear_blend(const CageModel& cage, const TriangleMesh& mesh, SkinReport& report);

// The rod's own frames for the along-rod skin (decision 0117): a ring with no cage vertices on
// every station of the piece (its nodes and section midpoints, in arc order), after the cage's rings.
void add_station_rings(CageModel& cage, kernels::RodPoses<const double> rest, std::span<const double> section_length);

// A vertex on its own stretch of wall (decisions 0117, 0122): on the two station rings
// (add_station_rings) either side of its place s along the rod (cage.mesh_place, the harmonic
// binding's for a surface), never on a ring of another loop that lies close in space; carried by
// the screw between them (kernels::skin_screw) at its fraction t of the way, its rest offset o
// taken in the same screw's rest frame: x = T(t) T_rest(t)⁻¹ x_rest. The rod's frame between two
// stations is that screw (its strain is constant over a section), so every rod pose — rigid
// motions, bends, twists, stretch — carries the mesh as rigid cross-sections, to float rounding.
SkinBinding bind_along_rod(const CageModel& cage, const TriangleMesh& mesh, SkinReport& report);

// The same places bound linearly (decision 0117's form, what hosts from before ABI 17 skin on
// their GPU): per vertex of an along-rod binding its two stations' rigid-group slots, weights
// 1 − t and t, each carrying the rest offset rigidly. Calls slot(vertex, ring, b, A) for each.
template <class Slot>
void along_rod_linear_slots(const CageModel& cage, const SkinBinding& b, const TriangleMesh& mesh, Slot slot) {
  for (std::size_t i = 0; i < b.vertex.size(); ++i) {
    const std::uint32_t v = b.vertex[i];
    if (v == kernels::kNoVertex) continue;
    const std::size_t block = i / kernels::kSkinLanes, lane = i % kernels::kSkinLanes, s = b.slot_start[block];
    const double t = b.coefficient[s * kernels::kSkinCoefficients * kernels::kSkinLanes + lane];
    const std::uint32_t g = b.ring[s];
    const double w[2] = {1.0 - t, t};
    for (std::uint32_t k = 0; k < 2; ++k) {
      if (w[k] == 0.0) continue;
      const kernels::RingPose& r = cage.ring_rest[g + k];
      slot(v, g + k, w[k], Eigen::Vector3d(w[k] * (r.rotation.transpose() * (mesh.vertices[v] - r.centre))));
    }
  }
}

}  // namespace haustra::detail
