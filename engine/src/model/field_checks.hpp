#pragma once
// Checks of one description field each: the message names the field, what was expected and what
// was given (FieldError, so a scene loader can point at the line that set it).
#include <Eigen/Core>
#include <string>

namespace haustra::detail {

// Every vector of a description (positions in m, forces in N, moments in N·m, curvatures in 1/m)
// within ±1e5 in each component (an instrument's force limit is at most 1e5 N too): beyond it no
// step holds (a floor 1e300 m up, a load of 1e30 N).
inline constexpr double kMaxVectorComponent = 1e5;
// An instrument keyframe's time, s: within ±1e9 (32 years).
inline constexpr double kMaxKeyframeTime = 1e9;
// A mesh file's scale, file units to metres: (0, 1e5] (the scaled vertices are bounded as positions).
inline constexpr double kMaxMeshScale = 1e5;

[[noreturn]] void fail(const std::string& field, const std::string& detail);
// A positive finite value within [plausible_min, plausible_max] (plausible_min 0: any above 0).
void check_positive(const std::string& field, double v, const char* unit, double plausible_max,
                    const char* hint = nullptr, double plausible_min = 0.0);
void check_range(const std::string& field, double v, double lo, double hi, const char* what);
void check_int(const std::string& field, long long v, long long lo, long long hi);
// Finite, within ±kMaxVectorComponent, and non-zero when asked.
void check_vector(const std::string& field, const Eigen::Vector3d& v, bool nonzero);

}  // namespace haustra::detail
