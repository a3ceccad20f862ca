#pragma once
// The inspector: the scene as a tree (organs and their pieces, connective tissue, instruments,
// obstacles, contact); a selection is highlighted in the view and its values are edited live.
#include <cstddef>
#include <string>
#include <string_view>

#include "viewer_state.hpp"

namespace haustra::view {

// Selects a part by the words a script uses (organ, anchors, instrument, plane, sphere, capsule,
// mesh; `none` clears): highlighted in the view, shown in the inspector. Returns what was
// selected, or why it could not be (an unknown word, an index past the scene's count).
std::string select_part(ViewerState& v, std::string_view kind, std::size_t index);

// One value edited, as the inspector's fields do: organ I youngs_modulus|relaxation_time V,
// instrument I stiffness|damping|force_limit V, contact 0 coefficient V. Checked here (a value no
// step can hold is refused at once, naming the field and the range), then posted to the physics
// thread, which announces the rebuild it needs on screen. Returns what was asked, or the refusal.
std::string edit_value(ViewerState& v, std::string_view kind, std::size_t index, std::string_view field, double value);

void draw_inspector(ViewerState& v);

}  // namespace haustra::view
