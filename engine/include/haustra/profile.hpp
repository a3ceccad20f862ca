#pragma once
// Named stages of a frame and the time each took (like Box2D's b2Profile).
#include <array>
#include <cstdint>
#include <string_view>

#include "haustra/report_fields.h"

namespace haustra {

enum class Stage : std::uint8_t {
  instruments,     // scripted poses, grasps and releases
  snapshot,        // a substep's start: the strains, poses and bases its drag and potential measure from
  collide,         // beads follow nodes; broad and narrow phase → contact candidates
  contacts,        // penalty forces (and their stiffness) at the current positions
  proxy,           // instruments' capsules where their couplings and contacts balance (0096)
  loads,           // gravity + external loads + contacts → node forces
  free_base,       // rigid drag of free bases
  backward_sweep,  // node forces → generalized forces R
  condense,        // Newton: linearize and condense the system tip → base (or the banded LU's fallback);
                   // a split rod's parts also make their responses here, each in its own task (0087)
  solve,           // lagged: prefactored M and the strain law; Newton: the coupled unknowns' responses
                   // (a split rod's: folded with the join's result), multipliers and the step
  line_search,     // Newton: the step's fraction that lowers the frame's incremental potential
  constraints,     // lagged: attachments, implicit through the Schur complement
  forward_sweep,   // strains → node poses
  filter,          // inertia filter
  contraction,     // lagged: the next step from the new strains, to see that the iteration contracts
  guard,           // finite values and bounds
  report,          // penetrations and instrument forces at the frame's end
  cage,            // cage rings follow the rod
  skin,            // the organ meshes follow the rings (rigid-group MVC); a chain's cuts welded
  normals,         // per-vertex normals of the skinned meshes
  count
};

inline constexpr std::size_t kStageCount = static_cast<std::size_t>(Stage::count);

[[nodiscard]] std::string_view stage_name(Stage s) noexcept;

struct FrameProfile {
  std::array<double, kStageCount> seconds{};  // wall time per stage in this frame
  std::array<std::uint32_t, kStageCount> calls{};
  double frame_seconds = 0.0;
  HAUSTRA_PROFILE_COUNTERS(HAUSTRA_DECLARE_FIELD)  // substeps, iterations, retries, ... (report_fields.h)
  bool newton = false;                             // the frame that was kept ran Newton iterations
};

}  // namespace haustra
