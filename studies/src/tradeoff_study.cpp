#include "haustra/studies/tradeoff_study.hpp"

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

namespace haustra::validation {
namespace {

using Clock = std::chrono::steady_clock;

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

Eigen::Vector3d node(const World& w, std::size_t k) {
  const auto p = w.node_positions();
  return {p.x[k], p.y[k], p.z[k]};
}

std::vector<Eigen::Vector3d> nodes(const World& w) {
  std::vector<Eigen::Vector3d> out(w.node_count());
  for (std::size_t k = 0; k < out.size(); ++k) out[k] = node(w, k);
  return out;
}

double max_distance(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) {
  double worst = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k) worst = std::max(worst, (a[k] - b[k]).norm());
  return worst;
}

// Median engine-measured frame time over `frames` further frames, µs.
double frame_cost(World& w, int frames) {
  std::vector<double> t;
  for (int f = 0; f < frames; ++f) {
    w.step();
    t.push_back(w.last_profile().frame_seconds * 1e6);
  }
  return median(t);
}

// Solve each frame to convergence and let the guard allow any jump: a static reference.
void converge_each_frame(WorldDesc& d) {
  d.solver.iterations = 60;
  d.solver.max_iterations = 60;
  d.solver.tolerance = 1e-13;
  d.solver.max_displacement = 1e6;
}

// m: the paper's tube and tissue, clamped level under gravity (qL³/B ≈ 12: a large, smooth
// deflection). At 0.4 m (qL³/B ≈ 100) the heavy elastica has several equilibria — N = 667 settles
// curled back, N = 2,001 never settles — so no N converges to anything there.
constexpr double kRodLength = 0.2;

// The paper's tube (R = 2 cm, 3 mm wall, E = 33.2 kPa), all strains elastic, clamped level.
WorldDesc cantilever(int nodes) {
  WorldDesc d;
  d.threads = 1;
  SegmentDesc s;
  s.nodes = nodes;
  s.rest.length = kRodLength;
  s.law = {StrainLaw::elastic, StrainLaw::elastic, StrainLaw::elastic, StrainLaw::elastic};
  s.base_position = {0.0, 0.0, 0.5};
  d.segments.push_back(s);
  return d;
}

std::filesystem::path scene_file(const std::string& name) {
  return std::filesystem::path(HAUSTRA_DEFAULT_ASSETS).parent_path() / (name + ".toml");
}

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
    WorldDesc c = cantilever(167);
    c.solver.mode = s.mode;
    c.solver.iterations = s.iterations;
    c.solver.max_displacement = 1e6;
    if (s.converged) converge_each_frame(c);
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
  const double length = 0.2;
  auto world = [&](TissueResponse law, int n, const Eigen::Vector3d& force, const Eigen::Vector3d& moment) {
    WorldDesc d;
    d.threads = 1;
    d.gravity = Eigen::Vector3d::Zero();
    SegmentDesc s;
    s.nodes = n;
    s.rest.length = length;
    s.law = {StrainLaw::elastic, StrainLaw::elastic, StrainLaw::elastic, StrainLaw::elastic};
    s.material.response = law;
    s.loads.push_back({-1, force, moment});
    d.segments.push_back(s);
    return d;
  };
  auto solve_tip = [&](const WorldDesc& d0) {
    WorldDesc d = d0;
    converge_each_frame(d);
    auto w = World::create(d);
    for (int f = 0; f < 6; ++f) w->step();
    return node(*w, w->node_count() - 1);
  };
  // Cost of a frame at rest under a 25 % pull, default solver, N = 167, per law: the two worlds
  // step in turn, so that the machine's load falls on both alike.
  std::array<double, 2> cost{};
  const double f25 = kernels::exp2_tube_axial_force(tissue, tube, 0.25).value;
  {
    auto hooke = World::create(world(TissueResponse::hooke, 167, {f25, 0, 0}, {0, 0, 0}));
    auto exp2 = World::create(world(TissueResponse::exp2, 167, {f25, 0, 0}, {0, 0, 0}));
    std::array<std::vector<double>, 2> t;
    for (int f = 0; f < 230; ++f) {
      hooke->step();
      exp2->step();
      if (f < 30) continue;
      t[0].push_back(hooke->last_profile().frame_seconds * 1e6);
      t[1].push_back(exp2->last_profile().frame_seconds * 1e6);
    }
    cost = {median(t[0]), median(t[1])};
  }
  for (double strain : {0.1, 0.25, 0.4, 0.6}) {
    const double force = kernels::exp2_tube_axial_force(tissue, tube, strain).value;
    const Eigen::Vector3d exact(length * (1.0 + strain), 0.0, 0.0);
    for (int law = 0; law < 2; ++law) {
      const TissueResponse response = law == 0 ? TissueResponse::hooke : TissueResponse::exp2;
      TradeoffRow r;
      r.setting = fmt::format("{}, pull to {:.0f} %", law == 0 ? "Hooke" : "EXP2", 100 * strain);
      const Eigen::Vector3d tip = solve_tip(world(response, 41, {force, 0, 0}, {0, 0, 0}));
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
      const Eigen::Vector3d tip = solve_tip(world(response, 41, {0, 0, 0}, {0.0, -m0, 0.0}));
      r.error = 1e3 * (tip - arc).norm();
      r.cost_us = cost[static_cast<std::size_t>(law)];
      r.details = fmt::format("M₀ = {:.2g} N·m; EXP2 tip turns {:.0f}°", m0, kappa * length * 180.0 / std::numbers::pi);
      r.is_default = law == 0;
      k.rows.push_back(r);
    }
  }
  return k;
}

// --- mean value coordinates: rings kept ---------------------------------------------------------

TradeoffKnob knob_rings() {
  TradeoffKnob k{"MVC rings kept per vertex, and linear-blend skinning",
                 "a straight procedural rectum (30 cm, 11 beads, 10,000 vertices) posed into a 90° bend, a 90° "
                 "twist and others (docs/skinning.md)",
                 "full mean value coordinates (every ring) in the same poses",
                 "max vertex error (mm)",
                 "frame (µs), with the mesh",
                 {},
                 1};
  const SkinningStudy s = run_skinning_study();
  // A whole frame of the same organ hanging from its clamp under gravity with each skinning: the
  // worlds step in turn, so that the machine's load falls on all alike.
  std::vector<std::unique_ptr<World>> worlds;
  for (const SkinningStudyRow& row : s.rows) {
    WorldDesc d =
        study_organ(row.method.rfind("MVC", 0) == 0 ? SkinningMethod::mean_value : SkinningMethod::linear_blend,
                    row.rings_per_vertex);
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
    r.error = 1e3 * row.max_error;
    r.cost_us = median(frame_times[i]);
    r.details = fmt::format(
        "skin stage {:.1f} µs; p99 {:.2f} mm; volume change: bend {:+.1f} %, twist {:+.1f} %; "
        "{:.0f} B per vertex",
        row.skin_us, 1e3 * row.p99_error, 100 * row.bend_volume_change, 100 * row.twist_volume_change,
        row.bytes_per_vertex);
    r.is_default = row.method.find("K = 4") != std::string::npos;
    r.is_reference = row.rings_per_vertex == 0 && row.method.rfind("MVC", 0) == 0;
    k.rows.push_back(r);
  }
  return k;
}

// --- reconstruction: precision and the integrator ----------------------------------------------

// The forward sweep in scalar type T, with the SE(3) exponential per section (each section a
// helix, exact for constant strain) or the midpoint rule (the section's rotation exact, its
// position a straight step along the midpoint tangent).
template <class T>
void sweep(std::span<const double> h, std::span<const double> q, bool midpoint, std::vector<Eigen::Vector3d>& out) {
  using V = Eigen::Matrix<T, 3, 1>;
  using Q = Eigen::Quaternion<T>;
  Q rot = Q::Identity();
  V pos = V::Zero();
  out[0] = pos.template cast<double>();
  for (std::size_t k = 0; k < h.size(); ++k) {
    const V u(static_cast<T>(0.5 * (q[4 * k] + q[4 * k + 4])), static_cast<T>(0.5 * (q[4 * k + 1] + q[4 * k + 5])),
              static_cast<T>(0.5 * (q[4 * k + 2] + q[4 * k + 6])));
    const T stretch = static_cast<T>(1.0 + 0.5 * (q[4 * k + 3] + q[4 * k + 7]));
    const T len = static_cast<T>(h[k]);
    const T angle = u.norm() * len;
    const V axis = angle > T(0) ? V(u / u.norm()) : V::UnitZ();
    const Q turn(Eigen::AngleAxis<T>(angle, axis));
    const V e3 = V::UnitZ();
    V step;
    if (midpoint) {
      const Q half(Eigen::AngleAxis<T>(T(0.5) * angle, axis));
      step = (half * e3) * (stretch * len);
    } else {
      // ∫₀ˡ exp(s[u]×) e3 ds: the closed form of the helix step.
      const T a = angle;
      const V w = axis;
      const T c1 = a > T(1e-4) ? (T(1) - std::cos(a)) / a : a / T(2);
      const T c2 = a > T(1e-4) ? (a - std::sin(a)) / a : a * a / T(6);
      step = (e3 + c1 * w.cross(e3) + c2 * w.cross(w.cross(e3))) * (stretch * len);
    }
    pos += rot * step;
    rot = (rot * turn).normalized();
    out[k + 1] = pos.template cast<double>();
  }
}

// A helix of the rectum's rest strains (κ = 8 /m, τ = −1.12 /m, 5 % stretch), 1.66 m.
void helix(int n, std::vector<double>& h, std::vector<double>& q) {
  h.assign(static_cast<std::size_t>(n - 1), 1.66 / (n - 1));
  q.assign(4 * static_cast<std::size_t>(n), 0.0);
  for (int k = 0; k < n; ++k) {
    q[4 * static_cast<std::size_t>(k) + 1] = 8.0;
    q[4 * static_cast<std::size_t>(k) + 2] = -1.124327;
    q[4 * static_cast<std::size_t>(k) + 3] = 0.05;
  }
}

template <class F>
double time_us(F f, int repeats) {
  std::vector<double> t;
  for (int i = 0; i < repeats; ++i) {
    const auto a = Clock::now();
    f();
    t.push_back(std::chrono::duration<double, std::micro>(Clock::now() - a).count());
  }
  return median(t);
}

std::vector<Eigen::Vector3d> engine_sweep(std::span<const double> h, std::span<const double> q, bool reference) {
  const std::size_t n = h.size() + 1;
  std::vector<double> b(n * 14);
  auto col = [&](std::size_t i) { return std::span<double>(b.data() + i * n, n); };
  kernels::RodPoses<double> poses{{col(0), col(1), col(2)},
                                  {col(3), col(4), col(5), col(6)},
                                  {col(7), col(8), col(9)},
                                  {col(10), col(11), col(12), col(13)}};
  const kernels::StrainView<const double> strain{q};
  if (reference)
    kernels::rod_forward_sweep_reference({}, h, strain, poses);
  else
    kernels::rod_forward_sweep({}, h, strain, poses);
  std::vector<Eigen::Vector3d> out(n);
  for (std::size_t k = 0; k < n; ++k) out[k] = poses.node_position.get(k);
  return out;
}

// The measured frame of the 0.2 m rod at rest with N nodes (default solver: one forward sweep a
// frame): what a sweep's change is added to.
double rod_frame_us(int n) {
  auto w = World::create(cantilever(n));
  for (int f = 0; f < 40; ++f) w->step();
  return frame_cost(*w, 30);
}

TradeoffKnob knob_precision() {
  TradeoffKnob k{"float against double in the rod's reconstruction",
                 "the forward sweep (strains → poses) of a 1.66 m helix with the rectum's rest strains; the same "
                 "study code instantiated in float and double; the Newton solve stays in double (not built in float). "
                 "Frame: the 0.2 m rod's measured frame at this N with the sweep's time exchanged (one sweep a frame)",
                 "the engine's double sweep (`kernels/rod_forward_sweep`)",
                 "max node error (µm)",
                 "frame (µs), estimated",
                 {},
                 100};
  for (int n : {167, 10'000}) {
    std::vector<double> h, q;
    helix(n, h, q);
    const std::vector<Eigen::Vector3d> exact = engine_sweep(h, q, false);
    std::vector<Eigen::Vector3d> out(static_cast<std::size_t>(n));
    const int repeats = n > 1000 ? 50 : 2000;
    const double engine_us = time_us([&] { (void)engine_sweep(h, q, false); }, repeats);
    const double frame_us = rod_frame_us(n);
    TradeoffRow e;
    e.setting = fmt::format("double, engine kernel, N = {}", n);
    e.cost_us = frame_us;
    e.details = fmt::format("the rod's measured frame; sweep {:.1f} µs (with the study's buffer set-up)", engine_us);
    e.is_default = true;
    e.is_reference = true;
    k.rows.push_back(e);
    for (int precision = 0; precision < 2; ++precision) {
      TradeoffRow r;
      r.setting = fmt::format("{}, study sweep, N = {}", precision == 0 ? "double" : "float", n);
      if (precision == 0) {
        sweep<double>(h, q, false, out);
        r.cost_us = time_us([&] { sweep<double>(h, q, false, out); }, repeats);
      } else {
        sweep<float>(h, q, false, out);
        r.cost_us = time_us([&] { sweep<float>(h, q, false, out); }, repeats);
      }
      r.error = 1e6 * max_distance(out, exact);
      r.details = fmt::format("sweep {:.1f} µs", r.cost_us);
      r.cost_us = frame_us - engine_us + r.cost_us;
      k.rows.push_back(r);
    }
  }
  return k;
}

TradeoffKnob knob_integrator() {
  TradeoffKnob k{"SE(3) exponential against midpoint reconstruction",
                 "the forward sweep of the 1.66 m helix (κ = 8 /m, τ = −1.12 /m, ε = 5 %), N nodes. Frame: the 0.2 m "
                 "rod's measured frame at this N with the sweep's time exchanged (one sweep a frame)",
                 "the matrix exponential of each section's twist (`rod_forward_sweep_reference`): the exact helix",
                 "tip error (mm)",
                 "frame (µs), estimated",
                 {},
                 1};
  for (int n : {21, 41, 83, 167, 333, 667}) {
    std::vector<double> h, q;
    helix(n, h, q);
    const double frame_us = rod_frame_us(n);
    const double engine_us = time_us([&] { (void)engine_sweep(h, q, false); }, 2000);
    const Eigen::Vector3d exact = engine_sweep(h, q, true).back();
    std::vector<Eigen::Vector3d> out(static_cast<std::size_t>(n));
    for (int midpoint = 0; midpoint < 2; ++midpoint) {
      TradeoffRow r;
      r.setting = fmt::format("{}, N = {}", midpoint != 0 ? "midpoint" : "exponential", n);
      if (midpoint == 0) {
        const std::vector<Eigen::Vector3d> engine = engine_sweep(h, q, false);
        r.error = 1e3 * (engine.back() - exact).norm();
        r.cost_us = frame_us;
        r.details = fmt::format("the engine's kernel: the rod's measured frame; sweep {:.1f} µs", engine_us);
        r.is_default = n == 167;
      } else {
        sweep<double>(h, q, true, out);
        r.error = 1e3 * (out.back() - exact).norm();
        const double sweep_us = time_us([&] { sweep<double>(h, q, true, out); }, 2000);
        r.cost_us = frame_us - engine_us + sweep_us;
        r.details = fmt::format("study code; sweep {:.1f} µs", sweep_us);
      }
      k.rows.push_back(r);
    }
  }
  return k;
}

// Settings no other setting beats in both error and cost.
std::vector<bool> pareto(const TradeoffKnob& k) {
  std::vector<bool> front(k.rows.size(), k.pareto);
  if (!k.pareto) return front;
  for (std::size_t i = 0; i < k.rows.size(); ++i)
    for (std::size_t j = 0; j < k.rows.size(); ++j) {
      const TradeoffRow& a = k.rows[i];
      const TradeoffRow& b = k.rows[j];
      if (i != j && b.error <= a.error && b.cost_us <= a.cost_us && (b.error < a.error || b.cost_us < a.cost_us))
        front[i] = false;
    }
  return front;
}

}  // namespace

TradeoffStudy run_tradeoff_study(const std::function<void(const std::string&)>& progress) {
  const auto start = Clock::now();
  TradeoffStudy s;
  const std::vector<std::pair<std::string, TradeoffKnob (*)()>> knobs = {
      {"nodes per segment", knob_nodes},         {"beads per node", knob_beads},
      {"iterations per frame", knob_iterations}, {"inertia filter", knob_filter},
      {"Hooke against EXP2", knob_exp2},         {"MVC rings and linear blend", knob_rings},
      {"float against double", knob_precision},  {"exponential against midpoint", knob_integrator}};
  for (const auto& [name, run] : knobs) {
    if (progress) progress(name);
    s.knobs.push_back(run());
  }
  s.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return s;
}

std::string tradeoff_csv(const TradeoffStudy& study) {
  std::string out = "knob,setting,error,error_name,cost_us,cost_name,pareto,default\n";
  auto quoted = [](const std::string& s) { return "\"" + s + "\""; };
  for (const TradeoffKnob& k : study.knobs) {
    const std::vector<bool> front = pareto(k);
    for (std::size_t i = 0; i < k.rows.size(); ++i) {
      const TradeoffRow& r = k.rows[i];
      out += fmt::format("{},{},{:.6g},{},{:.6g},{},{},{}\n", quoted(k.name), quoted(r.setting), r.error,
                         quoted(k.error_name), r.cost_us, quoted(k.cost_name), front[i] ? 1 : 0, r.is_default ? 1 : 0);
    }
  }
  return out;
}

std::string tradeoff_markdown(const TradeoffStudy& study) {
  std::string md =
      "# Speed against accuracy\n\n"
      "<!-- Generated by `make study` (haustra study --markdown); edit studies/src/tradeoff_study.cpp. -->\n\n"
      "Every simplification the paper made, and a few of ours, as a knob: each setting's error against a "
      "stated reference, and what it costs per frame on this machine (one thread, the engine's own "
      "frame timer or the median of repeated runs of the stage the knob changes). The machine is "
      "shared and noisy: costs are good to ~20 %, errors are deterministic. ● marks the Pareto front "
      "(no other setting of the knob is both cheaper and more accurate).\n\n"
      "![error against cost per knob, Pareto fronts joined](figures/tradeoff.png)\n\n"
      "Where each scheme holds as E, Δt, N and the load vary (gravity, a pull, a stiff contact) is "
      "mapped in [stability.md](stability.md) (`make stability-doc`).\n\n"
      "## Guide\n\n"
      "Picked from the tables below by rule, not by hand: for a **haptic loop** (1 kHz, every "
      "microsecond counts) the cheapest setting within the error stated; for an **offline accuracy "
      "check** the most accurate setting measured.\n\n";
  for (const TradeoffKnob& k : study.knobs) {
    if (k.rows.empty()) continue;
    const TradeoffRow* best = &k.rows[0];
    for (const TradeoffRow& r : k.rows)
      if (r.error < best->error) best = &r;
    if (k.haptic_error <= 0.0) {
      // Hooke against EXP2: what the simplification misses, up to and beyond the paper's 25 %.
      double gentle = 0.0, hard = 0.0, hooke_cost = 0.0, exp2_cost = 0.0;
      std::string worst_gentle, worst_hard;
      for (const TradeoffRow& r : k.rows) {
        const bool hooke = r.setting.rfind("Hooke", 0) == 0;
        (hooke ? hooke_cost : exp2_cost) = r.cost_us;
        if (!hooke) continue;
        const bool beyond = r.setting.find("40 %") != std::string::npos || r.setting.find("60 %") != std::string::npos;
        double& worst = beyond ? hard : gentle;
        if (r.error > worst) {
          worst = r.error;
          (beyond ? worst_hard : worst_gentle) = r.setting.substr(7);
        }
      }
      md += fmt::format(
          "- **{}**: up to 25 % strain Hooke's law misses the EXP2 equilibrium by up to {:.3g} mm ({}) on the "
          "0.2 m rod, beyond it by up to {:.3g} mm ({}); EXP2 costs {:.2f}× Hooke's frame. With measured EXP2 "
          "parameters use EXP2 in both loops — it costs next to nothing; Hooke's one modulus is the choice only when "
          "that is all that is known. (The parameters here are illustrative: the paper gives none.)\n",
          k.name, gentle, worst_gentle, hard, worst_hard, hooke_cost > 0.0 ? exp2_cost / hooke_cost : 0.0);
      continue;
    }
    const TradeoffRow* haptic = nullptr;
    const TradeoffRow* cheapest = nullptr;
    for (const TradeoffRow& r : k.rows) {
      if (r.is_reference) continue;
      if (cheapest == nullptr || r.cost_us < cheapest->cost_us) cheapest = &r;
      if (r.error <= k.haptic_error && (haptic == nullptr || r.cost_us < haptic->cost_us)) haptic = &r;
    }
    md += fmt::format(
        "- **{}**: haptic loop — {}; offline — {} ({} {:.3g}, {:.4g} µs).\n", k.name,
        haptic == nullptr
            ? fmt::format("none within {:g} ({}); the cheapest, {}, misses by {:.3g}", k.haptic_error, k.error_name,
                          cheapest != nullptr ? cheapest->setting : "—", cheapest != nullptr ? cheapest->error : 0.0)
            : fmt::format("{} ({} {:.3g} ≤ {:g}, {:.4g} µs)", haptic->setting, k.error_name, haptic->error,
                          k.haptic_error, haptic->cost_us),
        best->setting, k.error_name, best->error, best->cost_us);
    if (!k.guide_note.empty()) md += fmt::format("  *Note:* {}.\n", k.guide_note);
  }
  md += "\n## Knobs\n\n";
  for (const TradeoffKnob& k : study.knobs) {
    const std::vector<bool> front = pareto(k);
    md += fmt::format("### {}\n\n", k.name);
    md += fmt::format("*Run:* {}.  \n*Reference:* {}.\n\n", k.scene, k.reference);
    if (k.haptic_error > 0.0)
      md += fmt::format("Guide's haptic threshold: {} ≤ {:g}.\n\n", k.error_name, k.haptic_error);
    md += fmt::format("| setting | {} | {} | Pareto | further |\n|---|---:|---:|:-:|---|\n", k.error_name, k.cost_name);
    for (std::size_t i = 0; i < k.rows.size(); ++i) {
      const TradeoffRow& r = k.rows[i];
      const std::string error = r.is_reference ? "0 (reference)" : fmt::format("{:.3g}", r.error);
      md += fmt::format("| {}{} | {} | {:.4g} | {} | {} |\n", r.setting, r.is_default ? " **(default)**" : "", error,
                        r.cost_us, front[i] ? "●" : "", r.details);
    }
    md += "\n";
  }
  md += fmt::format("The whole study ran in {:.0f} s on one thread.\n", study.seconds);
  return md;
}

}  // namespace haustra::validation
