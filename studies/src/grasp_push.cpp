// Issue 25's grasp-and-push, frame by frame: the force on the grasper, its steps, how deep beads go.
#include "haustra/studies/grasp_push.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "haustra/error.hpp"
#include "haustra/world.hpp"

namespace haustra::validation {

GraspPush push_grasp(const SceneDesc& scene, std::size_t node, const Eigen::Vector3d& approach, double depth) {
  SceneDesc driven = scene;  // the push drives instrument 0: its own script is dropped, it waits far away
  driven.world.instruments.at(0).keyframes.clear();
  driven.world.instruments[0].tip = Eigen::Vector3d(0.0, 0.0, 10.0);
  auto w = create_world(driven);
  for (int f = 0; f < 50; ++f) w->step();  // settle
  const Eigen::Vector3d start = w->node_positions().get(node) + 0.025 * approach;
  w->set_instrument_pose(0, start, approach);
  w->set_instrument_grasp(0, true);
  GraspPush r;
  Eigen::Vector3d last = Eigen::Vector3d::Zero();
  try {
    for (int f = 1; f <= 3000; ++f) {
      const double s = std::min(1.0, f / 2700.0);
      w->set_instrument_pose(0, start - depth * s * approach, approach);
      w->step();
      const Eigen::Vector3d force = w->instrument(0).force;
      if (!force.allFinite()) throw Error(ErrorCode::internal, "the force on the grasper is not finite");
      r.largest = std::max(r.largest, force.norm());
      if (f > 1) r.steepest = std::max(r.steepest, (force - last).norm());
      last = force;
      r.deepest = std::max(r.deepest, w->contacts().max_environment_depth);
      r.frame_us.push_back(w->last_profile().frame_seconds * 1e6);
      r.frames = f;
    }
  } catch (const Error& e) {
    r.stop = fmt::format("stopped at frame {} ({})", r.frames + 1, error_code_name(e.code()));
  }
  for (const Event& e : w->events()) r.unstable_events += e.kind == Event::Kind::unstable ? 1 : 0;
  return r;
}

}  // namespace haustra::validation
