#pragma once
// Issue 25's grasp-and-push (scenes/grasp-push.toml): a grasp driven into what lies under or beside
// a rod, measured frame by frame. Shared by the study's coupling knob and the tests.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "haustra/scene.hpp"

namespace haustra::validation {

struct GraspPush {
  double deepest = 0.0;   // m: the deepest bead in the environment
  double largest = 0.0;   // N: the force on the grasper
  double steepest = 0.0;  // N: its largest change from one frame to the next
  int frames = 0;         // pushed frames run
  std::string stop;       // why the push stopped early ("" when it ran to the end)
  int unstable_events = 0;
  std::vector<double> frame_us;  // each pushed frame's time
};

// Drops instrument 0's own script (it waits far away), lets the scene settle 50 frames, puts its
// jaws 2.5 cm from node `node` along `approach` (a unit vector from the node to the jaws) and closes
// them, then drives the grasp point `depth` m along −approach over 2,700 frames and holds it 300 more.
GraspPush push_grasp(const SceneDesc& scene, std::size_t node, const Eigen::Vector3d& approach, double depth);

}  // namespace haustra::validation
