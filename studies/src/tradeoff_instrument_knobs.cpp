// The study's instrument knob: the grasp's virtual coupling against the rigid grasp, a grasp driven
// through the floor at haptic rate (decision 0057).
#include <fmt/format.h>

#include <algorithm>
#include <string>

#include "haustra/error.hpp"
#include "haustra/scene.hpp"
#include "tradeoff_knobs.hpp"

namespace haustra::validation::tradeoff {
namespace {

// A 1 m rod (101 nodes, 35 beads, free, in a viscous medium) on the floor at 1 kHz, a grasper
// above its middle.
SceneDesc rod_on_floor() {
  const std::string text = R"(
[world]
dt = 0.001
[solver]
mode = "newton"
[[environment.plane]]
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
[[segment]]
name = "rod"
nodes = 101
base = "free"
drag = 4.0
base_position = [0.0, 0.0, 0.0202]
base_tangent = [1.0, 0.0, 0.0]
radius = 0.02
wall_thickness = 0.003
[segment.rest]
length = 1.0
[segment.beads]
count = 35
radius = 0.02
[[instrument]]
name = "grasper"
grasp_reach = 0.01
tip = [0.5, 0.0, 0.5]
)";
  return parse_scene(text, "study: grasp through the floor");
}

struct Push {
  double deepest = 0.0;   // m, the floor's deepest bead
  double largest = 0.0;   // N, on the grasper
  double steepest = 0.0;  // N, its largest change in one frame
  int frames = 0;
  std::string stop;
  std::vector<double> cost;
};

// Grasps the middle node from above and drives the grasp point from 2 cm above the floor to 2 cm
// below it over 2.7 s, then holds 0.3 s.
Push push_through_floor(double stiffness) {
  SceneDesc scene = rod_on_floor();
  scene.world.instruments[0].coupling_stiffness = stiffness;
  auto w = create_world(scene);
  for (int f = 0; f < 50; ++f) w->step();
  const Eigen::Vector3d start = node(*w, 50) + Eigen::Vector3d(0.0, 0.0, 0.025);
  w->set_instrument_pose(0, start, Eigen::Vector3d::UnitZ());
  w->set_instrument_grasp(0, true);
  Push r;
  Eigen::Vector3d last = Eigen::Vector3d::Zero();
  try {
    for (int f = 1; f <= 3000; ++f) {
      const double s = std::min(1.0, f / 2700.0);
      w->set_instrument_pose(0, start - Eigen::Vector3d(0.0, 0.0, 0.04 * s), Eigen::Vector3d::UnitZ());
      w->step();
      const Eigen::Vector3d force = w->instrument(0).force;
      r.largest = std::max(r.largest, force.norm());
      if (f > 1) r.steepest = std::max(r.steepest, (force - last).norm());
      last = force;
      r.deepest = std::max(r.deepest, w->contacts().max_environment_depth);
      r.cost.push_back(w->last_profile().frame_seconds * 1e6);
      r.frames = f;
    }
  } catch (const Error& e) {
    r.stop = fmt::format("stopped at frame {} ({})", r.frames + 1, error_code_name(e.code()));
  }
  return r;
}

}  // namespace

TradeoffKnob knob_coupling() {
  TradeoffKnob k{"grasp coupling",
                 "a 1 m rod (N = 101, 35 beads) on the floor at 1 kHz, grasped at its middle; the grasp point "
                 "driven from 2 cm above the floor to 2 cm below it over 2.7 s, then held 0.3 s",
                 "none: the floor allows no depth; the error is how deep a bead went",
                 "deepest bead in the floor (mm)",
                 "frame (µs)",
                 {},
                 0,
                 false,
                 "not a speed knob: the coupling bounds the force a device is sent (at most its limit, smooth "
                 "from frame to frame); the rigid grasp follows the command into the floor until the frame fails"};
  for (const double stiffness : {250.0, 1000.0, 4000.0, 16000.0, 0.0}) {
    const Push p = push_through_floor(stiffness);
    TradeoffRow r;
    r.setting = stiffness > 0.0 ? fmt::format("k = {:g} N/m, limit 8 N", stiffness) : std::string("rigid grasp");
    r.error = 1e3 * p.deepest;
    r.cost_us = median(p.cost);
    r.details = fmt::format("largest force {:.3g} N, largest change in one 1 ms frame {:.3g} N; {}", p.largest,
                            p.steepest, p.stop.empty() ? std::string("ran all 3,000 frames") : p.stop);
    r.is_default = stiffness == 1000.0;
    k.rows.push_back(r);
  }
  return k;
}

}  // namespace haustra::validation::tradeoff
