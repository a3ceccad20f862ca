// What a world will hold, estimated from its description before anything is built (decision
// 0038): the model's and the state's arrays per node, the Newton solve's workspace per node, the
// beads, and the procedural organ meshes per vertex. World::create refuses a world whose estimate
// exceeds the memory the machine has available (or the host's world.memory_limit).
#include <unistd.h>
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <string>

#include "haustra/kernels/rod_condensed.hpp"
#include "haustra/world.hpp"
#include "model/world_model.hpp"
#include "step/collision.hpp"
#include "step/world_state.hpp"

namespace haustra {
namespace {

constexpr std::size_t kDouble = sizeof(double);

// Per node, whatever the solver: the model (section length, rest strain, mass, drag, the mass
// matrix's factor, initial loads: 16 doubles), the state (the frame and its snapshot: strain,
// position, rotation, midpoint pose, 18 doubles each; substep starts, loads, generalized forces:
// 31), and what building it takes on the way (the rest pose and initial positions: 17).
constexpr std::size_t kModelPerNode = 16 * kDouble;
constexpr std::size_t kStatePerNode = (2 * 18 + 31) * kDouble + 1;
constexpr std::size_t kBuildPerNode = 17 * kDouble;
// The Newton workspace besides its gains: the step, residual, law stress and tangent, load
// stiffness (a 3×3 per node), the strains before a step (41 doubles).
constexpr std::size_t kNewtonPerNode = 41 * kDouble;
// The banded fallback's 16×16 blocks (lower, diagonal, upper, fill) and swaps, per node.
constexpr std::size_t kBandPerNode = 4 * 256 * kDouble + 16 + 10 * kDouble;
// Per bead: its model, collision state and candidate lists (measured on drop and bowel).
constexpr std::size_t kPerBead = 640;
// Per procedural mesh vertex: its skinning binding (rest position, output index, 4 rings' 4
// coefficients), its position and normal, its corner pairs and normal slots, its triangles'
// indices, and the cage binding's share while it is built (measured: 326 bytes on drop's 10k).
constexpr std::size_t kPerMeshVertex = 330;
// Whatever the size: the events' reserved room, the collision chunks', the scheduler's arena.
constexpr std::size_t kFixed = 1'000'000;

std::size_t columns_of(const WorldDesc& desc, const SegmentDesc& s, bool beads) {
  std::size_t rows = 0;
  for (const AttachmentDesc& a : s.attachments) rows += a.hold_frame ? 6 : 3;
  for (const InstrumentDesc& i : desc.instruments) rows += i.hold_frame ? 6 : 3;
  return 1 + std::min<std::size_t>(rows, detail::kMaxConstraintRows) + (beads ? detail::kMaxCoupledContacts : 0);
}

std::size_t gain_bytes(std::size_t steps, std::size_t columns) {
  return kernels::condensed_gain_size(steps, static_cast<int>(columns)) * kDouble;
}

}  // namespace

MemoryEstimate estimate_memory(const WorldDesc& desc) {
  MemoryEstimate e;
  const bool newton =
      desc.solver.mode != SolverMode::lagged || desc.solver.on_instability == InstabilityPolicy::recover;
  for (const SegmentDesc& s : desc.segments) {
    const std::size_t pieces = static_cast<std::size_t>(std::clamp(s.chain_pieces, 1, 4096));
    const std::size_t piece_nodes = static_cast<std::size_t>(std::clamp(s.nodes, 2, 10'000'000));
    const std::size_t n = pieces * (piece_nodes - 1) + 1;
    std::size_t beads = 0;
    if (s.beads.enabled || s.beads.count > 0 || s.beads.spacing > 0.0 || !s.beads.nodes.empty())
      beads = pieces * static_cast<std::size_t>(std::max<int>(s.beads.count, static_cast<int>(s.beads.nodes.size())));
    if (s.beads.spacing > 0.0 && s.rest.length > 0.0)
      beads = std::max(beads, static_cast<std::size_t>(pieces * s.rest.length / s.beads.spacing) + 1);
    std::size_t rod = n * (kModelPerNode + kStatePerNode + kBuildPerNode);
    std::size_t solver = 0;
    if (newton) {
      const std::size_t cols = columns_of(desc, s, beads > 0);
      solver = n * kNewtonPerNode;
      if (detail::rod_is_split(n, desc.solver.mode)) {
        const auto m = static_cast<std::size_t>(detail::kSplitBaseFraction * static_cast<double>(n - 1));
        solver += gain_bytes(n - 1 - m, cols) + gain_bytes(m, cols + kernels::kJointColumns) + (n - m) * 14 * kDouble +
                  2 * cols * (6 * cols + 60) * kDouble;  // the tip part's responses (decision 0087)
      } else {
        solver += gain_bytes(n, cols);
        // Fast mode: the record, and the prefactor's (decision 0085) — a second record and gains,
        // and its copy of a linearization (poses, loads, stiffness, law, residual: 40 doubles a node).
        if (desc.solver.mode == SolverMode::fast)
          solver += 2 * kernels::condensed_record_size(n) * kDouble + gain_bytes(n, cols) + n * 40 * kDouble;
      }
      if (n <= detail::kBandFallbackNodes) solver += n * (kBandPerNode + 16 * cols * kDouble);
    }
    std::size_t mesh = 0;
    if (s.mesh.enabled && s.mesh.source == MeshSource::procedural)
      mesh = pieces * static_cast<std::size_t>(std::max(s.mesh.procedural.vertices, 0)) * kPerMeshVertex;
    e.nodes += n;
    e.rod_bytes += rod;
    e.solver_bytes += solver;
    e.bead_bytes += beads * kPerBead;
    e.mesh_bytes += mesh;
  }
  e.total = kFixed + e.rod_bytes + e.solver_bytes + e.bead_bytes + e.mesh_bytes;
  return e;
}

std::size_t available_memory() {
  // MemAvailable: what the kernel can give without swapping.
  std::ifstream meminfo("/proc/meminfo");
  std::string key;
  std::size_t kb = 0;
  std::string unit;
  while (meminfo >> key >> kb >> unit)
    if (key == "MemAvailable:") return kb * 1024;
  const long pages = sysconf(_SC_AVPHYS_PAGES), size = sysconf(_SC_PAGE_SIZE);
  return pages > 0 && size > 0 ? static_cast<std::size_t>(pages) * static_cast<std::size_t>(size) : 0;
}

}  // namespace haustra
