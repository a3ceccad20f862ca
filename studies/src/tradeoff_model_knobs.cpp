// The speed/accuracy study's knobs of the model: nodes, beads, iterations, the inertia filter, EXP2,
// the skin (mesh.skinning).
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <numbers>

#include "haustra/embree_scene.hpp"
#include "haustra/kernels/rod_forward_sweep.hpp"
#include "haustra/kernels/tissue_law.hpp"
#include "haustra/scene.hpp"
#include "haustra/studies/skinning_study.hpp"
#include "haustra/world.hpp"

#include "tradeoff_knobs.hpp"

namespace haustra::validation::tradeoff {

// --- nodes per segment ---------------------------------------------------------------------

TradeoffKnob knob_nodes() {
  TradeoffKnob k{"nodes per segment",
                 "a 0.2 m rod of the paper's tube and tissue (all strains elastic), clamped level, hanging under "
                 "gravity to its static shape",
                 "the same rod with 2,001 nodes, Newton to convergence (10⁻¹³) every frame",
                 "tip error (mm)",
                 "frame (µs), default solver, at rest",
                 {},
                 1};
  auto tip_of = [](int n) {
    WorldDesc d = cantilever(n);
    converge_each_frame(d);
    auto w = World::create(d);
    for (int f = 0; f < 4; ++f) w->step();
    return node(*w, w->node_count() - 1);
  };
  const Eigen::Vector3d reference = tip_of(2001);
  for (int n : {21, 41, 83, 167, 333, 667}) {
    TradeoffRow r;
    r.setting = fmt::format("N = {}", n);
    r.error = 1e3 * (tip_of(n) - reference).norm();
    auto w = World::create(cantilever(n));
    for (int f = 0; f < 40; ++f) w->step();  // settles under the default solver
    r.cost_us = frame_cost(*w, 30);
    r.details = fmt::format("{:.1f} µs per node", r.cost_us / n);
    r.is_default = n == 167;  // the paper's
    k.rows.push_back(r);
  }
  return k;
}

// --- beads per node --------------------------------------------------------------------------

namespace {

struct MeshPenetration {
  double floor_depth = 0.0;     // m, deepest mesh vertex below the floor
  std::size_t self_inside = 0;  // mesh vertices inside another part of the organ
};

// The deformed organ mesh against the floor (z = 0, exact) and against itself, with Embree: a
// vertex pushed 0.1 mm out along its normal that is still inside the closed mesh lies inside
// another part of the organ (or its own folds crossed).
MeshPenetration mesh_penetration(const World& w) {
  MeshPenetration m;
  const std::size_t nv = w.mesh_buffer_size();
  const auto p = w.mesh_positions();
  const auto n = w.mesh_normals();
  std::vector<Eigen::Vector3d> v(nv);
  for (std::size_t i = 0; i < nv; ++i) {
    v[i] = Eigen::Vector3d(p.x[i], p.y[i], p.z[i]);
    m.floor_depth = std::max(m.floor_depth, -v[i].z());
  }
  const auto tri = w.mesh_triangles();
  EmbreeScene scene;
  scene.add_triangles(v, tri);
  scene.commit();
  for (std::size_t i = 0; i < nv; ++i) {
    const Eigen::Vector3d normal = Eigen::Vector3d(n.x[i], n.y[i], n.z[i]).normalized();
    const Eigen::Vector3d out = v[i] + 1e-4 * normal;
    if (scene.inside(out)) ++m.self_inside;
  }
  return m;
}

}  // namespace

TradeoffKnob knob_beads() {
  TradeoffKnob k{"beads per node",
                 "`drop` (the rectum, 167 nodes, falls 0.5 m onto the floor and onto itself) with its 10k-vertex "
                 "procedural mesh, 6 s",
                 "no penetration: the skinned mesh measured against the floor plane (exact, the deepest vertex) "
                 "and against itself (Embree inside tests: vertices inside the organ) at 4, 5 and 6 s",
                 "mesh below the floor (mm)",
                 "frame (µs), with the mesh",
                 {},
                 2};
  struct Setting {
    const char* name;
    int count;
  };
  for (const Setting& s : {Setting{"every node (167 beads)", 167}, Setting{"every 2nd (84)", 84},
                           Setting{"every 3rd (56; the paper's 55)", 56}, Setting{"every 5th (34)", 34}}) {
    const std::vector<std::string> sets = {"segment.mesh.source=procedural",
                                           fmt::format("segment.beads.count={}", s.count)};
    SceneDesc scene = load_scene(scene_file("drop"), sets);
    scene.world.threads = 1;
    auto w = create_world(scene);
    const std::size_t at_rest = mesh_penetration(*w).self_inside;
    std::vector<double> t;
    MeshPenetration worst;
    double bead_floor = 0.0, bead_overlap = 0.0;
    for (int f = 1; f <= 360; ++f) {
      w->step();
      if (f > 240) t.push_back(w->last_profile().frame_seconds * 1e6);
      if (f >= 240) {
        bead_floor = std::max(bead_floor, w->contacts().max_environment_depth_ratio);
        bead_overlap = std::max(bead_overlap, w->contacts().max_bead_overlap_ratio);
      }
      if (f == 240 || f == 300 || f == 360) {
        const MeshPenetration m = mesh_penetration(*w);
        worst.floor_depth = std::max(worst.floor_depth, m.floor_depth);
        worst.self_inside = std::max(worst.self_inside, m.self_inside);
      }
    }
    TradeoffRow r;
    r.setting = s.name;
    r.error = 1e3 * worst.floor_depth;
    r.cost_us = median(t);
    r.details = fmt::format(
        "mesh vertices inside the organ: {} of {} ({} at rest, before the fall); beads: "
        "floor ≤ {:.1f} %, each other ≤ {:.1f} % of r",
        worst.self_inside, w->mesh_buffer_size(), at_rest, 100 * bead_floor, 100 * bead_overlap);
    r.is_default = s.count == 56;
    k.rows.push_back(r);
  }
  return k;
}

// --- iterations per frame --------------------------------------------------------------------

// The 0.2 m rod released under gravity with one solver setting: its error after one frame against
// the converged static tip, and how often its tip reverses (by more than 1 mm both ways) in 1 s.
std::pair<std::string, int> released_rod(SolverMode mode, int iterations, bool converged,
                                         const Eigen::Vector3d& static_tip) {
  WorldDesc c = cantilever(167);
  c.solver.mode = mode;
  c.solver.iterations = iterations;
  c.solver.max_displacement = 1e6;
  if (converged) converge_each_frame(c);
  std::string static_error;
  int flips = 0;  // the tip reversing its motion by more than 1 mm both ways, over 1 s
  try {
    auto cw = World::create(c);
    cw->step();
    static_error = fmt::format("{:.1f} mm{}", 1e3 * (node(*cw, 166) - static_tip).norm(),
                               cw->events().empty() ? "" : " (the guard refused the lagged frame; Newton redid it)");
    Eigen::Vector3d last = node(*cw, 166), last_move = Eigen::Vector3d::Zero();
    for (int f = 1; f < 60; ++f) {
      cw->step();
      const Eigen::Vector3d move = node(*cw, 166) - last;
      if (move.norm() > 1e-3 && last_move.norm() > 1e-3 && move.dot(last_move) < 0.0) ++flips;
      last = node(*cw, 166);
      last_move = move;
    }
  } catch (const Error& e) {
    static_error = fmt::format("stopped ({})", error_code_name(e.code()));
  }
  return {static_error, flips};
}

TradeoffKnob knob_iterations() {
  TradeoffKnob k{"iterations per frame",
                 "`drop` without its mesh: the error at 1 s (falling and bending, before the coils pile up "
                 "chaotically); events over 4.5 s; the static error on the 0.2 m rod after one frame",
                 "Newton to convergence (10⁻¹² per section) every frame, same scene",
                 "node error at 1 s (mm)",
                 "frame (µs)",
                 {},
                 1,
                 true,
                 "before convergence the fall's trajectories differ by tens of mm whatever the count; one Newton "
                 "iteration a frame costs least; which settings needed the robust mode is in the details"};
  auto drop = [](SolverMode mode, int iterations, bool converged) {
    SceneDesc scene = load_scene(scene_file("drop"));
    scene.world.threads = 1;
    scene.world.solver.mode = mode;
    scene.world.solver.iterations = iterations;
    if (converged) {
      scene.world.solver.iterations = 40;
      scene.world.solver.max_iterations = 40;
      scene.world.solver.tolerance = 1e-12;
    }
    return create_world(scene);
  };
  auto w_ref = drop(SolverMode::newton, 40, true);
  for (int f = 0; f < 60; ++f) w_ref->step();
  const std::vector<Eigen::Vector3d> reference = nodes(*w_ref);
  WorldDesc cd = cantilever(167);
  converge_each_frame(cd);
  auto c_ref = World::create(cd);
  for (int f = 0; f < 4; ++f) c_ref->step();
  const Eigen::Vector3d static_tip = node(*c_ref, 166);

  struct Setting {
    const char* name;
    SolverMode mode;
    int iterations;
    bool converged;
  };
  for (const Setting& s : {Setting{"lagged, 1 pass (the paper)", SolverMode::lagged, 1, false},
                           Setting{"fast mode (chord Newton, decision 0037)", SolverMode::fast, 1, false},
                           Setting{"Newton, 1 iteration", SolverMode::newton, 1, false},
                           Setting{"Newton, 2 (drop's setting)", SolverMode::newton, 2, false},
                           Setting{"Newton, 4", SolverMode::newton, 4, false},
                           Setting{"Newton, converged", SolverMode::newton, 40, true}}) {
    auto w = drop(s.mode, s.iterations, s.converged);
    std::vector<double> t;
    double error = 0.0;
    int iterations = 0, chords = 0;
    for (int f = 1; f <= 270; ++f) {
      w->step();
      t.push_back(w->last_profile().frame_seconds * 1e6);
      iterations += w->last_profile().iterations;
      chords += w->last_profile().chords;
      if (f == 60) error = max_distance(nodes(*w), reference);
    }
    std::size_t recovered = 0;
    for (const Event& e : w->events()) recovered += e.kind == Event::Kind::recovered ? 1 : 0;
    const auto [static_error, flips] = released_rod(s.mode, s.iterations, s.converged, static_tip);
    TradeoffRow r;
    r.setting = s.name;
    r.error = 1e3 * error;
    r.cost_us = median(t);
    r.details = fmt::format(
        "{} robust-mode recoveries in 270 frames; 0.2 m rod released: static error after one "
        "frame {}, {} flips of the tip (reversals > 1 mm) in 1 s",
        recovered, static_error, flips);
    if (s.mode == SolverMode::fast)
      r.details += fmt::format("; {} of {} iterations reused a factorization", chords, iterations);
    r.is_default = s.mode == SolverMode::newton && s.iterations == 1 && !s.converged;
    r.is_reference = s.converged;
    k.rows.push_back(r);
  }
  return k;
}

// --- the inertia filter ----------------------------------------------------------------------

TradeoffKnob knob_filter() {
  TradeoffKnob k{"inertia filter",
                 "the 0.2 m rod (N = 167) released level from rest at haptic rate (Δt = 1 ms), default solver "
                 "(one Newton iteration a frame), 1.5 s",
                 "no filter, same solver: the tip's path without the filter's lag",
                 "lag to within 1 mm of rest (ms)",
                 "frame (µs)",
                 {},
                 100,
                 true,
                 "the rule sees only the lag; the filter's gain is smoothness — it shrinks the largest jump of a "
                 "node in one frame (details), which is what to size ζ by for a haptic device"};
  struct Setting {
    const char* name;
    bool on;
    double zeta;
  };
  constexpr int kFrames = 1500;
  Eigen::Vector3d final_tip = Eigen::Vector3d::Zero();
  for (const Setting& s :
       {Setting{"off", false, 1.0}, Setting{"ζ × 0.25", true, 0.25}, Setting{"ζ × 1 (the paper's)", true, 1.0},
        Setting{"ζ × 4", true, 4.0}, Setting{"ζ × 16", true, 16.0}, Setting{"ζ × 64", true, 64.0},
        Setting{"ζ × 256", true, 256.0}}) {
    WorldDesc d = cantilever(167);
    d.dt = 1e-3;
    d.filter.enabled = s.on;
    d.filter.zeta_scale = s.zeta;
    auto w = World::create(d);
    std::vector<Eigen::Vector3d> before = nodes(*w);
    std::vector<Eigen::Vector3d> tips;
    std::vector<double> t;
    double jump = 0.0;
    for (int f = 0; f < kFrames; ++f) {
      w->step();
      t.push_back(w->last_profile().frame_seconds * 1e6);
      const std::vector<Eigen::Vector3d> now = nodes(*w);
      jump = std::max(jump, max_distance(now, before));
      before = now;
      tips.push_back(node(*w, 166));
    }
    if (!s.on) final_tip = tips.back();
    int settled = 0;
    for (int f = static_cast<int>(tips.size()); f-- > 0;)
      if ((tips[static_cast<std::size_t>(f)] - final_tip).norm() > 1e-3) {
        settled = f + 1;
        break;
      }
    TradeoffRow r;
    r.setting = s.name;
    r.error = 1e3 * settled * w->dt();
    r.cost_us = median(t);
    r.details = fmt::format("largest jump of a node in one frame {:.1f} mm; tip at 1.5 s {:.2f} mm from the unfiltered",
                            1e3 * jump, 1e3 * (tips.back() - final_tip).norm());
    r.is_default = s.on && s.zeta == 1.0;
    k.rows.push_back(r);
  }
  return k;
}

// --- Hooke against EXP2 ----------------------------------------------------------------------

constexpr double kExp2RodLength = 0.2;  // m

// A clamped rod of the paper's tube, no gravity, with a force and a moment at its tip.
WorldDesc loaded_rod(TissueResponse law, int n, const Eigen::Vector3d& force, const Eigen::Vector3d& moment) {
  WorldDesc d;
  d.threads = 1;
  d.gravity = Eigen::Vector3d::Zero();
  SegmentDesc s;
  s.nodes = n;
  s.rest.length = kExp2RodLength;
  s.law = {StrainLaw::elastic, StrainLaw::elastic, StrainLaw::elastic, StrainLaw::elastic};
  s.material.response = law;
  s.loads.push_back({-1, force, moment});
  d.segments.push_back(s);
  return d;
}

// Cost of a frame at rest under a pull, default solver, N = 167, Hooke and EXP2: the two worlds
// step in turn, so that the machine's load falls on both alike.
std::array<double, 2> frame_cost_per_law(double pull) {
  auto hooke = World::create(loaded_rod(TissueResponse::hooke, 167, {pull, 0, 0}, {0, 0, 0}));
  auto exp2 = World::create(loaded_rod(TissueResponse::exp2, 167, {pull, 0, 0}, {0, 0, 0}));
  std::array<std::vector<double>, 2> t;
  for (int f = 0; f < 230; ++f) {
    hooke->step();
    exp2->step();
    if (f < 30) continue;
    t[0].push_back(hooke->last_profile().frame_seconds * 1e6);
    t[1].push_back(exp2->last_profile().frame_seconds * 1e6);
  }
  return {median(t[0]), median(t[1])};
}

TradeoffKnob knob_exp2() {
  TradeoffKnob k{"tissue law: Hooke against EXP2",
                 "a clamped 0.2 m rod of the paper's tube (N = 41, no gravity) pulled at its tip, or bent by an end "
                 "moment, to a strain of the EXP2 law (γ = 20 kPa, α = 8, β = 6.7 kPa; Hooke: E = 33.2 kPa)",
                 "the analytic equilibrium under EXP2: A σ(ε) = F (tip at L(1 + ε)); an arc of M(κ) = M₀",
                 "tip error (mm)",
                 "frame (µs), N = 167, at rest",
                 {},
                 0,
                 false};
  const kernels::Exp2Tissue tissue{8.0, 6.7e3, 20.0e3};
  const kernels::TubeSection tube{0.02, 0.003};
  const double length = kExp2RodLength;
  auto solve_tip = [&](const WorldDesc& d0) {
    WorldDesc d = d0;
    converge_each_frame(d);
    auto w = World::create(d);
    for (int f = 0; f < 6; ++f) w->step();
    return node(*w, w->node_count() - 1);
  };
  const std::array<double, 2> cost = frame_cost_per_law(kernels::exp2_tube_axial_force(tissue, tube, 0.25).value);
  for (double strain : {0.1, 0.25, 0.4, 0.6}) {
    const double force = kernels::exp2_tube_axial_force(tissue, tube, strain).value;
    const Eigen::Vector3d exact(length * (1.0 + strain), 0.0, 0.0);
    for (int law = 0; law < 2; ++law) {
      const TissueResponse response = law == 0 ? TissueResponse::hooke : TissueResponse::exp2;
      TradeoffRow r;
      r.setting = fmt::format("{}, pull to {:.0f} %", law == 0 ? "Hooke" : "EXP2", 100 * strain);
      const Eigen::Vector3d tip = solve_tip(loaded_rod(response, 41, {force, 0, 0}, {0, 0, 0}));
      r.error = 1e3 * (tip - exact).norm();
      r.cost_us = cost[static_cast<std::size_t>(law)];
      r.details = fmt::format("F = {:.2f} N; tip stretch {:.1f} % (EXP2: {:.0f} %)", force,
                              100 * (tip.x() / length - 1.0), 100 * strain);
      r.is_default = law == 0;
      k.rows.push_back(r);
    }
  }
  for (double outer : {0.1, 0.25, 0.4}) {
    const double kappa = outer / tube.radius;
    const double m0 = kernels::exp2_tube_bending_moment(tissue, tube, kappa).value;
    const Eigen::Vector3d arc(std::sin(kappa * length) / kappa, 0.0, (1.0 - std::cos(kappa * length)) / kappa);
    for (int law = 0; law < 2; ++law) {
      const TissueResponse response = law == 0 ? TissueResponse::hooke : TissueResponse::exp2;
      TradeoffRow r;
      r.setting = fmt::format("{}, bend to {:.0f} % at the wall", law == 0 ? "Hooke" : "EXP2", 100 * outer);
      const Eigen::Vector3d tip = solve_tip(loaded_rod(response, 41, {0, 0, 0}, {0.0, -m0, 0.0}));
      r.error = 1e3 * (tip - arc).norm();
      r.cost_us = cost[static_cast<std::size_t>(law)];
      r.details = fmt::format("M₀ = {:.2g} N·m; EXP2 tip turns {:.0f}°", m0, kappa * length * 180.0 / std::numbers::pi);
      r.is_default = law == 0;
      k.rows.push_back(r);
    }
  }
  return k;
}

// --- the skin (decision 0120) ------------------------------------------------------------------

TradeoffKnob knob_rings() {
  TradeoffKnob k{"the skin: mesh.skinning",
                 "a straight procedural rectum (30 cm, 11 beads, 10,000 vertices) posed into a 90° bend, a 90° "
                 "twist and others (docs/skinning.md)",
                 "rigid cross-sections: each vertex carried by the rod's own frame at its rest arc length (issue 35: "
                 "not full MVC, which a skin can match and still tear)",
                 "max vertex error (mm)",
                 "frame (µs), with the mesh",
                 {},
                 1};
  const SkinningStudy s = run_skinning_study();
  // A whole frame of the same organ hanging from its clamp under gravity with each skinning: the
  // worlds step in turn, so that the machine's load falls on all alike.
  std::vector<std::unique_ptr<World>> worlds;
  for (const SkinningStudyRow& row : s.rows) {
    WorldDesc d = study_organ(row.skinning);
    d.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
    worlds.push_back(World::create(d));
  }
  std::vector<std::vector<double>> frame_times(worlds.size());
  for (int f = 0; f < 220; ++f)
    for (std::size_t i = 0; i < worlds.size(); ++i) {
      worlds[i]->step();
      if (f >= 20) frame_times[i].push_back(worlds[i]->last_profile().frame_seconds * 1e6);
    }
  for (std::size_t i = 0; i < s.rows.size(); ++i) {
    const SkinningStudyRow& row = s.rows[i];
    TradeoffRow r;
    r.setting = row.method;
    r.error = 1e3 * row.transport_max;
    r.cost_us = median(frame_times[i]);
    r.details = fmt::format(
        "skin stage {:.1f} µs; p99 {:.2f} mm; {:.2f} mm from full MVC; volume change: bend {:+.1f} %, twist {:+.1f} "
        "%; {:.2f} slots ({:.0f} B) a vertex",
        row.skin_us, 1e3 * row.transport_p99, 1e3 * row.max_error, 100 * row.bend_volume_change,
        100 * row.twist_volume_change, row.slots_per_vertex, row.bytes_per_vertex);
    r.is_default = row.skinning == SkinningMethod::along_rod;
    k.rows.push_back(r);
  }
  return k;
}

}  // namespace haustra::validation::tradeoff
