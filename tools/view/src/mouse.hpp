#pragma once
// The mouse as the grasper and the camera's handle: a press on the organ as drawn grasps there
// (the engine's own grasp takes the bead under the tip), a drag moves it in the view plane (Ctrl: along the view
// axis), a release lets go; elsewhere the left button orbits, the right pans, the wheel zooms.
#include <optional>

#include "viewer_state.hpp"

namespace haustra::view {

struct BeadHit {
  std::size_t bead = 0;
  Eigen::Vector3d point = Eigen::Vector3d::Zero(), normal = Eigen::Vector3d::UnitZ();
};
// The first bead sphere a ray meets.
std::optional<BeadHit> pick_bead(const Ray& ray, const std::vector<Eigen::Vector3d>& centres,
                                 const std::vector<double>& radii);
// What a press at a pixel meets first: the organ as drawn or a bead; `bead` the one nearest the point.
std::optional<BeadHit> pick(const ViewerState& v, double x, double y);

enum class Button { left, right, middle };
void mouse_press(ViewerState& v, Button button, double x, double y);
void mouse_move(ViewerState& v, double x, double y);
void mouse_release(ViewerState& v, Button button);
void mouse_scroll(ViewerState& v, double steps);

}  // namespace haustra::view
