// The speed/accuracy study's sleeping-rods knob (decision 0119): how slow a rod must be to sleep,
// against every rod awake.
#include <fmt/format.h>

#include "haustra/scene.hpp"
#include "tradeoff_knobs.hpp"

namespace haustra::validation::tradeoff {

TradeoffKnob knob_sleep() {
  TradeoffKnob k{"sleeping rods",
                 "scenes/ropes.toml (six clamped rods bending under gravity, 486 nodes: the elastic and "
                 "Kelvin–Voigt ones come to rest, the viscous ones creep on), 10 s at 60 Hz, one thread",
                 "every rod awake (sleeping off, the default)",
                 "largest node distance from every rod awake at 10 s (mm)",
                 "frame (µs), median of the last 5 s",
                 {},
                 0.0,
                 true,
                 "a sleeping rod leaves out motion slower than sleep.speed: the error grows with the time asleep, "
                 "at most speed × time"};
  constexpr int kFrames = 600;
  struct Setting {
    const char* name;
    bool on;
    double speed;
  };
  std::vector<Eigen::Vector3d> awake_end;
  for (const Setting& s :
       {Setting{"off", false, 1e-3}, Setting{"speed 0.1 mm/s", true, 1e-4},
        Setting{"speed 1 mm/s (sleep.speed's default)", true, 1e-3}, Setting{"speed 10 mm/s", true, 1e-2}}) {
    SceneDesc scene = load_scene(scene_file("ropes"));
    scene.world.threads = 1;
    scene.world.sleep.enabled = s.on;
    scene.world.sleep.speed = s.speed;
    auto w = create_world(scene);
    std::vector<double> t;
    for (int f = 0; f < kFrames; ++f) {
      w->step();
      if (f >= kFrames / 2) t.push_back(w->last_profile().frame_seconds * 1e6);
    }
    if (!s.on) awake_end = nodes(*w);
    TradeoffRow r;
    r.setting = s.name;
    r.error = 1e3 * max_distance(nodes(*w), awake_end);
    r.cost_us = median(t);
    r.details = fmt::format("{} of {} nodes asleep at 10 s", w->last_profile().nodes_asleep, w->node_count());
    r.is_default = !s.on;
    r.is_reference = !s.on;
    k.rows.push_back(r);
  }
  return k;
}

}  // namespace haustra::validation::tradeoff
