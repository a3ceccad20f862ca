#pragma once
// The window's menus and what sits over the view: the main menu bar (File, View, Simulation,
// Help), File > Open's browser, the help overlay listing every key and mouse action, the notices
// (stops, slips, tears), the busy indicator during an import or a rebuild, and the colour scale.
#include "viewer_state.hpp"

namespace haustra::view {

// width, height: the framebuffer's, for captures started from the menu.
void draw_menu_bar(ViewerState& v, int width, int height);
void draw_open_dialog(ViewerState& v);
void draw_help(ViewerState& v);
void draw_overlays(ViewerState& v);

// The folder's entries the Open browser lists: sub-folders, scenes (.toml) and surfaces.
std::vector<std::string> list_openable(const std::filesystem::path& folder);

}  // namespace haustra::view
