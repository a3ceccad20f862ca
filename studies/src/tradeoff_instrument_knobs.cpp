// The study's instrument knob: the grasp's virtual coupling against the rigid grasp, a grasp driven
// through the floor at haptic rate (scenes/grasp-push.toml, decision 0057).
#include <fmt/format.h>

#include <string>

#include "haustra/scene.hpp"
#include "haustra/studies/grasp_push.hpp"
#include "tradeoff_knobs.hpp"

namespace haustra::validation::tradeoff {

TradeoffKnob knob_coupling() {
  TradeoffKnob k{"grasp coupling",
                 "scenes/grasp-push.toml: a 1 m rod (N = 101, 35 beads) on the floor at 1 kHz, grasped at its "
                 "middle; the grasp point driven from 2 cm above the floor to 2 cm below it over 2.7 s, then held "
                 "0.3 s",
                 "none: the floor allows no depth; the error is how deep a bead went",
                 "deepest bead in the floor (mm)",
                 "frame (µs)",
                 {},
                 0,
                 false,
                 "not a speed knob: the coupling bounds the force a device is sent (at most its limit, smooth "
                 "from frame to frame); the rigid grasp follows the command into the floor until the frame fails"};
  for (const double stiffness : {250.0, 1000.0, 4000.0, 16000.0, 0.0}) {
    SceneDesc scene = load_scene(scene_file("grasp-push"));
    scene.world.threads = 1;
    scene.world.instruments[0].coupling_stiffness = stiffness;
    const GraspPush p = push_grasp(scene, 50, Eigen::Vector3d::UnitZ(), 0.04);
    TradeoffRow r;
    r.setting = stiffness > 0.0 ? fmt::format("k = {:g} N/m, limit 8 N", stiffness) : std::string("rigid grasp");
    r.error = 1e3 * p.deepest;
    r.cost_us = median(p.frame_us);
    r.details = fmt::format("largest force {:.3g} N, largest change in one 1 ms frame {:.3g} N; {}", p.largest,
                            p.steepest, p.stop.empty() ? std::string("ran all 3,000 frames") : p.stop);
    r.is_default = stiffness == 1000.0;
    k.rows.push_back(r);
  }
  return k;
}

}  // namespace haustra::validation::tradeoff
