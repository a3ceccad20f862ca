#pragma once
// Named stages of a frame and the time each took (like Box2D's b2Profile).
#include <array>
#include <cstdint>
#include <string_view>

#include "haustra/report_fields.h"

namespace haustra {

// The stages, listed once with what each does in report_fields.h (HAUSTRA_STAGES), in pipeline order.
enum class Stage : std::uint8_t {
#define HAUSTRA_STAGE_ENUM(name, meaning) name,
  HAUSTRA_STAGES(HAUSTRA_STAGE_ENUM)
#undef HAUSTRA_STAGE_ENUM
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
