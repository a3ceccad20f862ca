#pragma once
// The workbench's verbs, one function each, shared by the keys, the menus and the scripts:
// open, reload, capture, cameras, follow.
#include <string>

#include "viewer_state.hpp"

namespace haustra::view {

// Opens a scene file, or a surface (imported first); the window shows what happens meanwhile.
void open_path(ViewerState& v, const std::string& path);
// The open scene read again from its file (after an edit), back to frame 0.
void reload(ViewerState& v);
// Whether the open scene's file changed on disk since it was read (checked twice a second at most).
bool scene_file_changed(ViewerState& v);

// A PNG of the next frame drawn: `path`, or a new name in the capture folder. Returns the path.
std::string take_screenshot(ViewerState& v, const std::string& path = {});
// Starts a video (at the physics' own time: the physics steps only when the window draws) or stops
// the one being written. Returns what it did, for the log.
std::string toggle_video(ViewerState& v, int width, int height, const std::string& path = {});
// One frame of the video being written, after a draw.
void video_frame(ViewerState& v, int width, int height);

// The camera from the front (−y), the top, the side (+x), or the default view; then fitted.
enum class View { front, top, side, standard };
void set_view(ViewerState& v, View view);
// Keeps the camera's eye on the free side of every plane of the scene (never under the floor).
void keep_above_planes(ViewerState& v);
// The panels or the inspector opened or closed: the view panned so its middle stays in the middle
// of what the columns leave.
void keep_between_panels(ViewerState& v);
// The camera's target on the grasped node, or the selected part, while following.
void follow(ViewerState& v);

}  // namespace haustra::view
