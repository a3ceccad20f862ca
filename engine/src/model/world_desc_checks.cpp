// check_world_desc: every field of a world description checked before anything is built; what
// can only be checked against the model being built (nodes resolved, attachments, pieces) is
// checked where it is built.
#include "model/world_desc_checks.hpp"

#include <fmt/format.h>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>

#include "haustra/error.hpp"
#include "haustra/world.hpp"
#include "model/field_checks.hpp"

namespace haustra::detail {
namespace {

void check_solver(const SolverDesc& s) {
  check_int("solver.iterations", s.iterations, 1, 10000);
  check_int("solver.max_iterations", s.max_iterations, 1, 10000);
  check_int("solver.substeps", s.substeps, 1, 1 << 16);
  check_int("solver.max_substeps", s.max_substeps, s.substeps, 1 << 16);
  check_int("solver.max_retries", s.max_retries, 0, 64);
  check_int("solver.calm_frames", s.calm_frames, 1, 1'000'000);
  if (!(s.relaxation > 0.0) || s.relaxation > 1.0)
    fail("solver.relaxation", fmt::format("expected a value in (0, 1], got {}", s.relaxation));
  check_range("solver.tolerance", s.tolerance, 0.0, 1.0, "a dimensionless tolerance");
  check_positive("solver.max_displacement", s.max_displacement, "segment lengths per frame", 1e6);
}

// Connective tissue's ranges (decision 0095); whether a range holds a node is checked where the
// anchors are built.
void check_anchors(const SegmentDesc& d, const std::string& where) {
  for (std::size_t i = 0; i < d.anchors.size(); ++i) {
    const AnchorsDesc& a = d.anchors[i];
    const std::string w = fmt::format("{}.anchors[{}]", where, i);
    check_range(w + ".from", a.from, 0.0, 1.0, "a fraction of the organ's length");
    check_range(w + ".to", a.to, a.from, 1.0, "a fraction of the organ's length, not before `from`");
    check_range(w + ".stiffness", a.stiffness, 0.0, 1e9, "a stiffness per length of organ in N/m²");
    check_range(w + ".damping", a.damping, 0.0, 1e9, "a damping per length of organ in N·s/m²");
    check_range(w + ".slack", a.slack, 0.0, 10.0, "a slack in m");
    check_range(w + ".strength", a.strength, 0.0, 1e9, "a strength per length of organ in N/m (0: never tears)");
    check_range(w + ".support", a.support, 0.0, 1e9, "a support stiffness per length of organ in N/m² (0: none)");
    if (a.stiffness == 0.0 && a.damping == 0.0 && a.support == 0.0)
      fail(w + ".stiffness", "an anchor with neither stiffness, damping nor support holds nothing");
    if (a.target == AnchorTarget::root) {
      if (a.root.size() < 2)
        fail(w + ".root",
             fmt::format("expected a root line of two points or more, [[x, y, z], ...] in m, got {}", a.root.size()));
      for (std::size_t j = 0; j < a.root.size(); ++j) check_vector(fmt::format("{}.root[{}]", w, j), a.root[j], false);
    }
  }
}

void check_segment_desc(const WorldDesc& desc, const SegmentDesc& d, const std::string& where,
                        std::set<std::string>& names) {
  if (!names.insert(d.name).second) fail(where + ".name", fmt::format("the name '{}' is used twice", d.name));
  check_int(where + ".nodes", d.nodes, 2, 10'000'000);
  check_int(where + ".chain.pieces", d.chain_pieces, 1, 4096);
  const auto pieces = static_cast<std::size_t>(d.chain_pieces);
  for (std::size_t p = 0; pieces > 1 && p < pieces; ++p) {
    const std::string piece = fmt::format("{}-{}", d.name, p + 1);
    if (!names.insert(piece).second)
      fail(where + ".name", fmt::format("its piece '{}' takes a name already used", piece));
  }
  if (pieces > 1) {
    if (static_cast<long long>(pieces) * (d.nodes - 1) + 1 > 10'000'000)
      fail(where + ".chain.pieces",
           fmt::format("{} pieces of {} nodes: at most 10,000,000 nodes per chain", pieces, d.nodes));
    if (d.beads.radius_from_mesh)
      fail(where + ".beads.radius", "radius = \"mesh\" is for a segment with a mesh file, not a chain");
    if (!d.beads.nodes.empty())
      fail(where + ".beads.nodes", "a chain's beads are given per piece by count or spacing, not as a node list");
  }
  if (d.rest.kind != RestShapeKind::centreline)
    check_positive(where + ".rest.length", d.rest.length, "m", 1000.0, nullptr, 1e-3);
  check_vector(where + ".base_position", d.base_position, false);
  check_vector(where + ".base_tangent", d.base_tangent, true);
  check_vector(where + ".base_normal", d.base_normal, false);
  check_positive(where + ".radius", d.cross_section.radius, "m", 0.5,
                 " (lengths are in metres: did you mean millimetres?)", 1e-4);
  check_positive(where + ".wall_thickness", d.cross_section.wall_thickness, "m", d.cross_section.radius,
                 " (the wall cannot be thicker than the radius)", 1e-6);
  check_positive(where + ".youngs_modulus", d.material.youngs_modulus, "Pa", 1e12, nullptr, 1.0);
  check_range(where + ".poisson_ratio", d.material.poisson_ratio, 0.0, 0.4999, "a Poisson ratio");
  check_positive(where + ".density", d.material.density, "kg/m³", 1e5, nullptr, 1e-3);
  check_positive(where + ".failure_strain", d.material.failure_strain, "(axial strain)", 1e3);
  // As light as a study's weightless beam (validation: 6e-11 kg/m), not a denormal.
  if (d.linear_density) check_positive(where + ".linear_density", *d.linear_density, "kg/m", 1e4, nullptr, 1e-15);
  if (d.material.response == TissueResponse::exp2) {
    check_range(where + ".tissue.alpha", d.material.exp2_alpha, 0.0, 1e3, "α ≥ 0 (it multiplies ε²)");
    check_range(where + ".tissue.beta", d.material.exp2_beta, 0.0, 1e12, "β ≥ 0 in Pa");
    check_positive(where + ".tissue.gamma", d.material.exp2_gamma, "Pa", 1e12, nullptr, 1.0);
    if (desc.solver.mode == SolverMode::lagged)
      fail(where + ".tissue.response",
           "the EXP2 law is solved by Newton iteration: it needs solver.mode = \"newton\" (the lagged scheme "
           "assumes a constant stiffness)");
  }
  const bool any_viscous = std::any_of(d.law.begin(), d.law.end(), [](StrainLaw l) { return l != StrainLaw::elastic; });
  if (any_viscous) check_positive(where + ".relaxation_time", d.relaxation_time, "s", 1e9, nullptr, 1e-6);
  check_anchors(d, where);
  const double drag = d.drag.value_or(d.base == BaseMode::free ? 4.0 : 0.0);
  if (d.base == BaseMode::free)
    check_positive(where + ".drag", drag, "N·s/m² (a free base needs the drag of the medium to move against)", 1e9);
  else
    check_range(where + ".drag", drag, 0.0, 1e9, "a drag in N·s/m²");
}

}  // namespace

// A world that would not fit is refused before anything is built (decision 0038).
void check_memory(const WorldDesc& desc) {
  check_range("world.memory_limit", desc.memory_limit, 0.0, 1e18, "bytes (0: what the machine has available)");
  const MemoryEstimate e = estimate_memory(desc);
  const bool set = desc.memory_limit > 0.0;
  const std::size_t limit = set ? static_cast<std::size_t>(desc.memory_limit) : available_memory();
  if (limit == 0 || e.total <= limit) return;
  auto size = [](std::size_t b) {
    const double x = static_cast<double>(b);
    return x >= 1e9   ? fmt::format("{:.2f} GB", x / 1e9)
           : x >= 1e6 ? fmt::format("{:.1f} MB", x / 1e6)
                      : fmt::format("{:.0f} kB", x / 1e3);
  };
  const std::size_t largest =
      static_cast<std::size_t>(std::max_element(desc.segments.begin(), desc.segments.end(),
                                                [](const auto& a, const auto& b) {
                                                  return static_cast<long long>(a.nodes) * a.chain_pieces <
                                                         static_cast<long long>(b.nodes) * b.chain_pieces;
                                                }) -
                               desc.segments.begin());
  // Beads packed so close that each overlaps many neighbours: their pairs are what does not fit.
  const bool pairs = e.pair_bytes > e.total / 2;
  throw Error(
      ErrorCode::invalid_argument,
      fmt::format(
          "the world would need about {} ({} nodes: {} of rod state and {} of Newton workspace, {:.0f} "
          "bytes a node; beads {}, organ meshes {}; {} pairs of beads within reach of each other, {}), "
          "more than {} {}: {}{}",
          size(e.total), e.nodes, size(e.rod_bytes), size(e.solver_bytes),
          static_cast<double>(e.rod_bytes + e.solver_bytes) / static_cast<double>(std::max<std::size_t>(e.nodes, 1)),
          size(e.bead_bytes), size(e.mesh_bytes), e.bead_pairs, size(e.pair_bytes), size(limit),
          set ? "(world.memory_limit)" : "this machine has available",
          pairs ? fmt::format("{} beads overlap many neighbours each: fewer or smaller beads "
                              "(segment[i].beads count, spacing or radius)",
                              e.beads)
                : fmt::format("lower segment[{}].nodes (or its chain.pieces) or the mesh vertices", largest),
          set ? ", or raise world.memory_limit" : ""));
}

void check_world_desc(const WorldDesc& desc) {
  check_positive("world.dt", desc.dt, "s", 1.0, nullptr, 1e-6);
  if (!desc.gravity.allFinite()) fail("world.gravity", "expected three finite numbers");
  if (desc.gravity.norm() > 1000.0)  // 100 g: beyond any body a simulator trains on, and a typo's likely sign
    fail("world.gravity", fmt::format("expected at most 1000 m/s² (100 g), got {:.6g}", desc.gravity.norm()));
  check_int("world.threads", desc.threads, 0, 1024);
  check_range("world.frame_budget", desc.frame_budget, 0.0, 3600.0, "seconds a frame may take (0: no budget)");
  check_solver(desc.solver);
  check_positive("sleep.speed", desc.sleep.speed, "m/s", 10.0);
  check_range("sleep.time", desc.sleep.time, 0.0, 3600.0, "seconds at rest before a rod sleeps");
  if (desc.sleep.ranges && desc.solver.mode == SolverMode::lagged)
    fail("sleep.ranges",
         "needs solver.mode = \"newton\" or \"fast\": the lagged scheme solves a rod whole "
         "(decision 0127)");
  check_range("filter.zeta_scale", desc.filter.zeta_scale, 0.0, 1e12, "a scale factor");
  std::set<std::string> names;
  for (std::size_t si = 0; si < desc.segments.size(); ++si)
    check_segment_desc(desc, desc.segments[si], fmt::format("segment[{}]", si), names);
  check_memory(desc);
}

}  // namespace haustra::detail
