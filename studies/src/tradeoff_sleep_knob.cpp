// The speed/accuracy study's sleeping knobs: how slow a rod must be to sleep (decision 0119), and a
// rod's range at rest asleep while the rest of it moves (decision 0127), against everything awake.
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

TradeoffKnob knob_sleep_ranges() {
  TradeoffKnob k{"sleeping ranges",
                 "scenes/range-pull.toml (a 1.5 m bowel, 151 nodes, held by its tissue over its base half, its tip "
                 "grasped, lifted 8 cm and pulled aside; a probe touches the base side at 4.2 s), 5 s at 60 Hz, "
                 "one thread",
                 "everything awake (sleeping off, the default)",
                 "largest node distance from everything awake at 5 s (mm)",
                 "frame (µs), median of 1–4 s (the pull)",
                 {},
                 0.0,
                 true,
                 "a sleeping range leaves out its motion slower than sleep.speed while the rest of the rod moves; "
                 "its boundary holds the moving range where the range stands"};
  constexpr int kFrames = 300;
  struct Setting {
    const char* name;
    bool on, ranges;
    double speed;
  };
  std::vector<Eigen::Vector3d> awake_end;
  for (const Setting& s : {Setting{"off", false, false, 1e-3}, Setting{"rods only, 1 mm/s", true, false, 1e-3},
                           Setting{"ranges, 0.1 mm/s", true, true, 1e-4},
                           Setting{"ranges, 1 mm/s (sleep.speed's default)", true, true, 1e-3},
                           Setting{"ranges, 10 mm/s", true, true, 1e-2}}) {
    SceneDesc scene = load_scene(scene_file("range-pull"));
    scene.world.threads = 1;
    scene.world.sleep.enabled = s.on;
    scene.world.sleep.ranges = s.ranges;
    scene.world.sleep.speed = s.speed;
    auto w = create_world(scene);
    std::vector<double> t;
    double asleep = 0.0;
    for (int f = 0; f < kFrames; ++f) {
      w->step();
      if (f >= 60 && f < 240) {
        t.push_back(w->last_profile().frame_seconds * 1e6);
        asleep += w->last_profile().nodes_asleep / 180.0;
      }
    }
    if (!s.on) awake_end = nodes(*w);
    TradeoffRow r;
    r.setting = s.name;
    r.error = 1e3 * max_distance(nodes(*w), awake_end);
    r.cost_us = median(t);
    r.details = fmt::format("{:.0f} of {} nodes asleep on average over 1–4 s", asleep, w->node_count());
    r.is_default = !s.on;
    r.is_reference = !s.on;
    k.rows.push_back(r);
  }
  return k;
}

}  // namespace haustra::validation::tradeoff
