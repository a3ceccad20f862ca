#pragma once
// The window's panels (Dear ImGui): frame time and the per-stage profile, the grasper's force
// plot, display toggles, the run-time knobs, pause / step / reset / checkpoints, and the log.
#include "viewer_state.hpp"

namespace haustra::view {

void draw_panels(ViewerState& v);

// Called inside an ImGui window: keeps it inside the viewer's window, under the menu bar, whatever
// the viewer's size (a panel left outside after a shrink comes back).
void keep_inside(const ViewerState& v);

// A knob change from the panel or the script: logged, and posted as a rebuild that keeps the state.
void turn_knob(ViewerState& v, const std::string& name, const std::string& value);

}  // namespace haustra::view
