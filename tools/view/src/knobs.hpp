#pragma once
// The run-time knobs (solver mode and iterations, the inertia filter, tissue law, beads per node,
// the skin, gravity, the contact coefficient, the 1 kHz rate): each one a change to a WorldDesc
// and a line for the log.
// The model is immutable while stepping, so every change is applied by a rebuild that keeps the
// state (World::reconfigure).
#include <array>
#include <optional>
#include <string>
#include <string_view>

#include "haustra/world_desc.hpp"

namespace haustra::view {

// The skins, in the panel's order, and their names (the scene's mesh.skinning values, decision 0120).
inline constexpr std::array<SkinningMethod, 4> kSkins = {SkinningMethod::along_rod, SkinningMethod::cage,
                                                         SkinningMethod::cage_full, SkinningMethod::linear_blend};
inline constexpr std::array<std::string_view, 4> kSkinNames = {"along-rod", "cage", "cage-full", "linear-blend"};
std::string skin_name(SkinningMethod m);

struct KnobChange {
  WorldDesc desc;
  std::string what;  // "solver.mode newton -> lagged"
};

// Sets knob `name` to `value` (the script's and the panel's words: mode lagged|newton|fast,
// iterations N, filter on|off, law hooke|exp2, beads_per_node X, skin along-rod|cage|cage-full|linear-blend,
// gravity "x y z", contact X, rate scene|1khz). scene_dt is the scene's own dt (for rate scene). Throws haustra::Error
// naming the knob and what it accepts.
KnobChange set_knob(const WorldDesc& now, std::string_view name, std::string_view value, double scene_dt);

// The current value of a knob, as set_knob reads it.
std::string knob_value(const WorldDesc& desc, std::string_view name);

// Beads per node of the first segment with beads (0 when none).
double beads_per_node(const WorldDesc& desc);

}  // namespace haustra::view
