// What a world will hold, estimated from its description before anything is built (decision
// 0038): the model's and the state's arrays per node, the Newton solve's workspace per node, the
// beads, and the procedural organ meshes per vertex by their skin. World::create refuses a world whose estimate
// exceeds the memory the machine has available (or the host's world.memory_limit).
#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include "haustra/kernels/rod_condensed.hpp"
#include "haustra/world.hpp"
#include "model/world_desc_checks.hpp"
#include "model/world_model.hpp"
#include "state/world_state.hpp"

namespace haustra {
namespace {

constexpr std::size_t kDouble = sizeof(double);

// Per node, whatever the solver: the model (section length, rest strain, mass, drag, the mass
// matrix's factor, initial loads: 16 doubles), the state (its lists' per-node buffers: the frame
// and its snapshot, 18 doubles each; substep starts, loads, generalized forces, 31 doubles and a
// byte), and what building it takes on the way (the rest pose and initial positions: 17).
constexpr std::size_t kModelPerNode = 16 * kDouble;
constexpr std::size_t kStatePerNode = detail::kStateBytesPerNode;
constexpr std::size_t kBuildPerNode = 17 * kDouble;
// The Newton workspace besides its gains, from its list: the step, residual, law stress and
// tangent, load stiffness (a 3×3 per node), the strains before a step (41 doubles), the last
// sweep kept with its strains (18, decision 0128); the banded
// fallback's 16×16 blocks (lower, diagonal, upper, fill), swaps and distal loads (its right-hand
// sides, 16 doubles a column, below).
constexpr std::size_t kNewtonPerNode = detail::kNewtonBytesPerNode;
constexpr std::size_t kBandPerNode = detail::kBandBytesPerNode;
// Per bead: its model, collision state and candidate lists (measured on drop and bowel).
constexpr std::size_t kPerBead = 640;
// A procedural organ mesh by its skin (measured on drop, 5,000 and 20,000 vertices, 55 and 110
// beads: the heap a world holds after its first step less the same world's without a mesh; the
// marginal bytes a vertex). Per vertex: its position and normal, corner pairs and normal slots,
// triangles' indices and the binding's slots — along the rod 240 bytes (2.05 to 2.5 slots), the
// linear blend 267 (4 slots); the cage 169 and 34 a slot, the slots decision 0048's rule keeps
// growing as the rings crowd the radius: 4.5 (321 bytes) with rings 15 mm apart on drop's 20 mm,
// 7.6 (426) 7.6 mm apart, so 1.45 + 2.33 r / spacing; the cage with every ring 215 bytes and 27 a
// ring (3,158 at 109 rings, 6,130 at 219). Per cage ring (2 a bead less one) its vertices, poses and
// GPU rows, about 1.9 kB; along the rod, per station (a node or a section's midpoint) 440 bytes more.
constexpr std::size_t kPerMeshVertexAlongRod = 240;
constexpr std::size_t kPerMeshVertexLinearBlend = 267;
constexpr double kPerMeshVertexCage = 169.0;
constexpr double kPerCageSlot = 34.0;
constexpr double kCageSlots = 1.45, kCageSlotsPerRadius = 2.33;
constexpr std::size_t kPerMeshVertexCageFull = 215;
constexpr std::size_t kPerMeshVertexRing = 27;
constexpr std::size_t kPerCageRing = 1900;
constexpr std::size_t kPerStation = 440;
// Whatever the size: the events' reserved room, the collision chunks', the scheduler's arena.
constexpr std::size_t kFixed = 1'000'000;
// Per pair of one segment's beads within reach at rest (decision 0106): its rest-pose exclusion (a
// 4-byte index), and in the first step the broad phase's lists of pairs within the margin — each
// chunk's and the merged one, both grown to twice what they hold (measured: 64 bytes a pair on a rod
// of 20,000 nodes with 2,000 to 10,000 beads of 2 cm).
constexpr std::size_t kPerRestPair = 4;
constexpr std::size_t kPerStepPair = 64;

// Seconds on one core of the reference machine (2 vCPU, measured on 2026-11-28 with the C API's
// defaults, decision 0106): building a rod, a rest-pose pair; binding a procedural mesh vertex by
// its skin (marginal, drop at 5,000 and 20,000 vertices, 55 and 110 beads, two runs): along the rod
// 1.4e-5 to 2.3e-5 s (no mean value coordinates), the linear blend 1.5e-5 to 2.3e-5 s, the cage and
// the cage with every ring alike (mean value coordinates over every cage vertex, then kept or not)
// 1.3e-6 to 1.9e-6 s a cage ring (1.4e-4 to 2.1e-4 s at 109 rings, 2.7e-4 to 4.1e-4 s at 219); a
// frame's Newton iteration per node (0.8 µs), the lagged scheme's (0.2 µs) and fast mode's chord
// (0.3 µs), a pair in the broad phase, a mesh vertex skinned.
constexpr double kBuildSecondsPerNode = 1.0e-6;
constexpr double kBuildPerRestPair = 2.0e-8;
constexpr double kBuildPerVertexAlongRod = 2.0e-5;
constexpr double kBuildPerVertexLinearBlend = 2.2e-5;
constexpr double kBuildPerVertexRing = 1.6e-6;
constexpr double kNewtonSecondsPerNode = 0.8e-6;
constexpr double kLaggedSecondsPerNode = 0.2e-6;
constexpr double kChordSecondsPerNode = 0.3e-6;
constexpr double kStepPerPair = 1.0e-7;
constexpr double kSkinPerMeshVertex = 5.0e-9;

std::size_t columns_of(const WorldDesc& desc, const SegmentDesc& s, bool beads) {
  std::size_t rows = 0;
  for (const AttachmentDesc& a : s.attachments) rows += a.hold_frame ? 6 : 3;
  for (const InstrumentDesc& i : desc.instruments) rows += i.hold_frame ? 6 : 3;
  return 1 + std::min<std::size_t>(rows, detail::kMaxConstraintRows) + (beads ? detail::kMaxCoupledContacts : 0);
}

std::size_t gain_bytes(std::size_t steps, std::size_t columns) {
  return kernels::condensed_gain_size(steps, static_cast<int>(columns)) * kDouble;
}

// The rod's rest length: the centreline's polyline, or the straight or arc rest shape's length.
double rest_length(const SegmentDesc& s) {
  if (s.rest.kind != RestShapeKind::centreline)
    return std::isfinite(s.rest.length) ? std::max(s.rest.length, 0.0) : 0.0;
  double length = 0.0;
  for (std::size_t i = 1; i < s.rest.centreline.size(); ++i)
    length += (s.rest.centreline[i] - s.rest.centreline[i - 1]).norm();
  return std::isfinite(length) ? length : 0.0;
}

// The beads the builder puts on a piece of `nodes` nodes and `length` m, as it chooses them: a node
// list, one per spacing, a count, or every third node.
std::size_t piece_beads(const BeadsDesc& b, std::size_t nodes, double length) {
  if (!b.enabled && b.count <= 0 && !(b.spacing > 0.0) && b.nodes.empty()) return 0;
  if (!b.nodes.empty()) return std::min(nodes, b.nodes.size());
  if (b.spacing > 0.0 && std::isfinite(b.spacing))
    return std::min(nodes, static_cast<std::size_t>(std::min(length / b.spacing, 1e15)) + 2);
  if (b.count > 0) return std::min(nodes, static_cast<std::size_t>(b.count));
  return (nodes + 2) / 3;
}

// The largest bead radius a segment's beads take.
double bead_radius(const SegmentDesc& s) {
  double r = s.beads.radius > 0.0 ? s.beads.radius : s.cross_section.radius;
  for (const auto& [f, pr] : s.beads.radius_profile) r = std::max(r, pr);
  return std::isfinite(r) && r > 0.0 ? r : 0.0;
}

// Pairs of `beads` beads evenly `spacing` apart whose spheres (radius r) come within `reach`
// (2r plus a margin) of each other: each with its next k = reach / spacing neighbours.
std::size_t pairs_within(std::size_t beads, double spacing, double reach) {
  if (beads < 2 || !(spacing > 0.0)) return 0;
  const double k = std::min(static_cast<double>(beads - 1), std::floor(reach / spacing));
  if (!(k >= 1.0)) return 0;
  const double pairs = static_cast<double>(beads) * k - k * (k + 1.0) / 2.0;
  return pairs < 1e18 ? static_cast<std::size_t>(pairs) : static_cast<std::size_t>(1e18);
}

// A procedural mesh of `vertices` on a piece with `beads` beads and `nodes` nodes, `length` m long
// with a wall `radius` m from the rod: the bytes its skin holds and the seconds binding it takes.
struct MeshCost {
  std::size_t bytes = 0;
  double seconds = 0.0;
};
MeshCost mesh_cost(SkinningMethod skin, std::size_t vertices, std::size_t beads, std::size_t nodes, double length,
                   double radius) {
  const std::size_t rings = std::max<std::size_t>(2 * beads, 2) - 1;
  const auto v = static_cast<double>(vertices);
  MeshCost c{rings * kPerCageRing, kBuildPerVertexRing * static_cast<double>(rings) * v};
  switch (skin) {
    case SkinningMethod::along_rod:
      c.bytes += vertices * kPerMeshVertexAlongRod + (2 * nodes - 1) * kPerStation;
      c.seconds = kBuildPerVertexAlongRod * v;
      break;
    case SkinningMethod::cage: {
      const double spacing = length / static_cast<double>(rings);
      const double slots = spacing > 0.0 && std::isfinite(radius / spacing)
                               ? std::min(kCageSlots + kCageSlotsPerRadius * radius / spacing, 1.0 * rings)
                               : 1.0 * rings;
      c.bytes += static_cast<std::size_t>(v * (kPerMeshVertexCage + kPerCageSlot * slots));
      break;
    }
    case SkinningMethod::cage_full: c.bytes += vertices * (kPerMeshVertexCageFull + rings * kPerMeshVertexRing); break;
    case SkinningMethod::linear_blend:
      c.bytes += vertices * kPerMeshVertexLinearBlend;
      c.seconds = kBuildPerVertexLinearBlend * v;
      break;
  }
  return c;
}

}  // namespace

MemoryEstimate estimate_memory(const WorldDesc& desc) {
  MemoryEstimate e;
  const bool newton =
      desc.solver.mode != SolverMode::lagged || desc.solver.on_instability == InstabilityPolicy::recover;
  // The contact margin: the scene's, or half the smallest bead radius.
  double smallest_bead = 1e300;
  for (const SegmentDesc& s : desc.segments)
    if (piece_beads(s.beads, static_cast<std::size_t>(std::clamp(s.nodes, 2, 10'000'000)), 1.0) > 0 &&
        bead_radius(s) > 0.0)
      smallest_bead = std::min(smallest_bead, bead_radius(s));
  const double margin =
      desc.contact.margin >= 0.0 ? desc.contact.margin : (smallest_bead < 1e300 ? 0.5 * smallest_bead : 0.0);
  const double substeps = std::max(desc.solver.substeps, 1);
  const double iterations = std::max(desc.solver.iterations, 1);
  const double per_node = desc.solver.mode == SolverMode::lagged ? kLaggedSecondsPerNode
                          : desc.solver.mode == SolverMode::fast ? kChordSecondsPerNode
                                                                 : kNewtonSecondsPerNode;
  std::size_t rest_pairs = 0, step_pairs = 0, mesh_vertices = 0;
  double mesh_seconds = 0.0;
  for (const SegmentDesc& s : desc.segments) {
    const std::size_t pieces = static_cast<std::size_t>(std::clamp(s.chain_pieces, 1, 4096));
    const std::size_t piece_nodes = static_cast<std::size_t>(std::clamp(s.nodes, 2, 10'000'000));
    const std::size_t n = pieces * (piece_nodes - 1) + 1;
    const double length = rest_length(s);
    const std::size_t beads = pieces * piece_beads(s.beads, piece_nodes, length / static_cast<double>(pieces));
    if (beads > 1) {
      const double spacing = length / static_cast<double>(beads - 1);
      const double r = bead_radius(s);
      rest_pairs += pairs_within(beads, spacing, 2.0 * r);
      step_pairs += pairs_within(beads, spacing, 2.0 * r + margin);
    }
    e.beads += beads;
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
        // Fast mode: the record the chord iterations replay.
        if (desc.solver.mode == SolverMode::fast) solver += kernels::condensed_record_size(n) * kDouble;
        // Sleeping ranges (decision 0127): a base side that may end at any node, as a split rod's base part.
        if (desc.sleep.ranges && n > detail::kMinSleepingRange)
          solver += gain_bytes(n - 1, cols + kernels::kJointColumns) +
                    2 * cols * (6 * (cols + kernels::kJointColumns) + 6 * cols + 60) * kDouble +  // raw, tip's
                    20 * (cols + 14) * kDouble;  // the held interface and zero start
      }
      if (n <= detail::kBandFallbackNodes) solver += n * (kBandPerNode + 16 * cols * kDouble);
    }
    std::size_t mesh = 0;
    if (s.mesh.enabled && s.mesh.source == MeshSource::procedural) {
      const auto vertices = static_cast<std::size_t>(std::clamp(s.mesh.procedural.vertices, 0, 100'000'000));
      const double piece_length = length / static_cast<double>(pieces);
      const double radius = s.mesh.procedural.radius > 0.0 ? s.mesh.procedural.radius : s.cross_section.radius;
      const MeshCost c = mesh_cost(s.mesh.skinning, vertices, piece_beads(s.beads, piece_nodes, piece_length),
                                   piece_nodes, piece_length, radius);
      mesh = pieces * c.bytes;
      mesh_seconds += static_cast<double>(pieces) * c.seconds;
      mesh_vertices += pieces * vertices;
    }
    e.nodes += n;
    e.rod_bytes += rod;
    e.solver_bytes += solver;
    e.bead_bytes += beads * kPerBead;
    e.mesh_bytes += mesh;
  }
  e.bead_pairs = step_pairs;
  e.pair_bytes = rest_pairs * kPerRestPair + step_pairs * kPerStepPair;
  e.total = kFixed + e.rod_bytes + e.solver_bytes + e.bead_bytes + e.mesh_bytes + e.pair_bytes;
  const auto nodes = static_cast<double>(e.nodes);
  e.build_seconds = kBuildSecondsPerNode * nodes + kBuildPerRestPair * static_cast<double>(rest_pairs) + mesh_seconds;
  e.step_seconds = substeps * (iterations * per_node * nodes + kStepPerPair * static_cast<double>(step_pairs)) +
                   kSkinPerMeshVertex * static_cast<double>(mesh_vertices);
  return e;
}

void check_fits(const WorldDesc& desc) { detail::check_memory(desc); }

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
