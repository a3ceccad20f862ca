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

// A vertex on its own stretch of wall (decision 0117): on the two station rings (add_station_rings)
// either side of its place s along the rod (cage.mesh_place, the harmonic binding's for a surface),
// never on a ring of another loop that lies close in space; weights linear in s, each station
// carrying the vertex's rest offset from it rigidly. The stations are half a section apart, so the
// blend is close to the rod's own frame at s (rigid cross-sections). The weights sum to 1: the rest
// pose is exact and a rigid motion of the rod moves the mesh rigidly.
SkinBinding bind_along_rod(const CageModel& cage, const TriangleMesh& mesh, SkinReport& report);

}  // namespace haustra::detail
