#pragma once
// The run-time knobs (solver mode and iterations, the inertia filter, tissue law, beads per node,
// MVC rings, gravity, the contact coefficient, the 1 kHz rate): each one a change to a WorldDesc
// and a line for the log.
// The model is immutable while stepping, so every change is applied by a rebuild that keeps the
// state (World::reconfigure).
#include <optional>
#include <string>
#include <string_view>

#include "haustra/world_desc.hpp"

namespace haustra::view {

struct KnobChange {
  WorldDesc desc;
  std::string what;  // "solver.mode newton -> lagged"
};

// Sets knob `name` to `value` (the script's and the panel's words: mode lagged|newton|fast,
// iterations N, filter on|off, law hooke|exp2, beads_per_node X, rings N, skin mvc|along-rod, gravity "x y z",
// contact X, rate scene|1khz). scene_dt is the scene's own dt (for rate scene). Throws haustra::Error
// naming the knob and what it accepts.
KnobChange set_knob(const WorldDesc& now, std::string_view name, std::string_view value, double scene_dt);

// The current value of a knob, as set_knob reads it.
std::string knob_value(const WorldDesc& desc, std::string_view name);

// Beads per node of the first segment with beads (0 when none).
double beads_per_node(const WorldDesc& desc);

}  // namespace haustra::view
