// Mouse gestures turned into camera moves and grasp commands for the physics thread.
#include "mouse.hpp"

#include <fmt/format.h>

#include <cmath>
#include <numbers>

#include "actions.hpp"

namespace haustra::view {
namespace {

constexpr double kCutRadius = 0.01;  // m: the dissection tool cuts the tissue within this of the pointer

}  // namespace

std::optional<BeadHit> pick_bead(const Ray& ray, const std::vector<Eigen::Vector3d>& centres,
                                 const std::vector<double>& radii) {
  std::optional<BeadHit> best;
  double best_t = 1e300;
  for (std::size_t i = 0; i < centres.size() && i < radii.size(); ++i) {
    const Eigen::Vector3d oc = ray.origin - centres[i];
    const double b = oc.dot(ray.direction), c = oc.squaredNorm() - radii[i] * radii[i];
    const double disc = b * b - c;
    if (disc < 0.0) continue;
    const double t = -b - std::sqrt(disc);
    if (t <= 0.0 || t >= best_t) continue;
    best_t = t;
    const Eigen::Vector3d p = ray.origin + t * ray.direction;
    best = BeadHit{i, p, (p - centres[i]).normalized()};
  }
  return best;
}

std::optional<BeadHit> pick(const ViewerState& v, double x, double y) {
  if (!v.model) return std::nullopt;
  const Ray ray = v.camera.ray(x, y);
  std::optional<BeadHit> hit = pick_bead(ray, v.bead_centres, v.model->bead_radii);
  const std::optional<OrganHit> organ = v.scene ? v.scene->pick_organ(ray) : std::nullopt;
  if (organ && (!hit || organ->distance < (hit->point - ray.origin).norm())) {
    std::size_t nearest = 0;
    for (std::size_t i = 1; i < v.bead_centres.size(); ++i)
      if ((v.bead_centres[i] - organ->point).squaredNorm() < (v.bead_centres[nearest] - organ->point).squaredNorm())
        nearest = i;
    hit = BeadHit{nearest, organ->point, organ->normal};
  }
  if (hit && v.bead_centres.empty()) return std::nullopt;  // a segment without beads cannot be grasped
  return hit;
}

void mouse_press(ViewerState& v, Button button, double x, double y) {
  MouseState& m = v.mouse;
  m.x = x;
  m.y = y;
  if (button == Button::right) {
    m.mode = MouseState::Mode::panning;
    return;
  }
  if (button == Button::middle) return;
  InputEvent e{"press", v.frame, x, y, false, 0, Eigen::Vector3d::Zero(), v.camera};
  const auto hit = pick(v, x, y);
  if (!hit) {
    m.mode = MouseState::Mode::orbiting;
    v.events.push_back(e);
    return;
  }
  if (m.shift) {  // the dissection tool: cut the tissue where the press meets the organ, and along the drag
    m.mode = MouseState::Mode::cutting;
    m.hit = hit->point;
    v.sim.post(CutAt{m.hit, kCutRadius});
    e.on_organ = true;
    e.bead = hit->bead;
    e.hit = hit->point;
    v.events.push_back(e);
    v.note(fmt::format("cutting at bead {} (node {})", hit->bead, v.model->bead_nodes[hit->bead]));
    return;
  }
  // The grasper's tip just outside the bead, its shaft towards the eye: the engine's grasp takes
  // the nearest bead surface within reach of the tip, which is this one.
  const InstrumentDesc& grasper = v.model->desc.instruments[v.model->mouse];
  const double clearance = grasper.radius + 1e-4;
  m.mode = MouseState::Mode::grasping;
  m.hit = hit->point;
  m.offset = clearance * hit->normal;
  // Where the skin lies farther from its bead than the grasp reaches (a wide organ on small beads),
  // the tip goes to the bead's surface under the press instead.
  const Eigen::Vector3d centre = v.bead_centres[hit->bead];
  const double radius = v.model->bead_radii[hit->bead];
  if ((hit->point + m.offset - centre).norm() - radius > 0.8 * grasper.grasp_reach) {
    const Eigen::Vector3d out = (hit->point - centre).normalized();
    m.offset = centre + (radius + clearance) * out - hit->point;
  }
  m.bead = hit->bead;
  v.draw.show_mouse = true;
  v.sim.post(GraspAt{m.hit + m.offset, -v.camera.forward()});
  e.on_organ = true;
  e.bead = hit->bead;
  e.hit = hit->point;
  v.events.push_back(e);
  v.note(fmt::format("grasp at bead {} (node {})", hit->bead, v.model->bead_nodes[hit->bead]));
}

void mouse_move(ViewerState& v, double x, double y) {
  MouseState& m = v.mouse;
  const double dx = x - m.x, dy = y - m.y;
  m.x = x;
  m.y = y;
  switch (m.mode) {
    case MouseState::Mode::grasping: {
      if (m.ctrl) {  // along the view axis: up the screen pushes away from the eye
        const double metres_per_pixel = 2.0 * (m.hit - v.camera.eye()).norm() *
                                        std::tan(0.5 * v.camera.fov_degrees * std::numbers::pi / 180.0) /
                                        v.camera.height;
        m.hit += -dy * metres_per_pixel * v.camera.forward();
      } else {  // in the plane through the grasped point, facing the eye
        m.hit = intersect_plane(v.camera.ray(x, y), m.hit, v.camera.forward());
      }
      v.sim.post(MoveTip{m.hit + m.offset});
      break;
    }
    case MouseState::Mode::cutting:
      m.hit = intersect_plane(v.camera.ray(x, y), m.hit, v.camera.forward());
      v.sim.post(CutAt{m.hit, kCutRadius});
      break;
    case MouseState::Mode::orbiting:
      v.camera.orbit(dx, dy);
      keep_above_planes(v);  // at once: the eye never goes under the floor, not even for a frame
      break;
    case MouseState::Mode::panning: v.camera.pan(dx, dy); break;
    case MouseState::Mode::idle: break;
  }
}

void mouse_release(ViewerState& v, Button button) {
  MouseState& m = v.mouse;
  if (m.mode == MouseState::Mode::grasping && button == Button::left) {
    v.sim.post(Release{});
    v.draw.show_mouse = false;
    v.note("released");
  }
  if (button != Button::middle) {
    if (button == Button::left) v.events.push_back({"release", v.frame, m.x, m.y, false, 0, m.hit, v.camera});
    m.mode = MouseState::Mode::idle;
  }
}

void mouse_scroll(ViewerState& v, double steps) { v.camera.zoom(steps); }

}  // namespace haustra::view
