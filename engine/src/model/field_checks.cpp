// Checks of one description field each (field_checks.hpp).
#include "model/field_checks.hpp"

#include <fmt/format.h>
#include <cmath>

#include "haustra/error.hpp"

namespace haustra::detail {

[[noreturn]] void fail(const std::string& field, const std::string& detail) {
  throw FieldError(ErrorCode::invalid_argument, field, detail);
}

void check_positive(const std::string& field, double v, const char* unit, double plausible_max, const char* hint,
                    double plausible_min) {
  if (!std::isfinite(v) || !(v > 0.0))
    fail(field, fmt::format("expected a positive finite value in {}, got {}", unit, v));
  if (v < plausible_min)
    fail(field, fmt::format("{} {} is below the plausible minimum {} {}{}", v, unit, plausible_min, unit,
                            hint != nullptr ? hint : ""));
  if (v > plausible_max)
    fail(field, fmt::format("{} {} is beyond the plausible maximum {} {}{}", v, unit, plausible_max, unit,
                            hint != nullptr ? hint : ""));
}

void check_range(const std::string& field, double v, double lo, double hi, const char* what) {
  if (!std::isfinite(v) || v < lo || v > hi)
    fail(field, fmt::format("expected {} in [{}, {}], got {}", what, lo, hi, v));
}

void check_int(const std::string& field, long long v, long long lo, long long hi) {
  if (v < lo || v > hi) fail(field, fmt::format("expected an integer in [{}, {}], got {}", lo, hi, v));
}

void check_vector(const std::string& field, const Eigen::Vector3d& v, bool nonzero) {
  if (!v.allFinite()) fail(field, "expected three finite numbers");
  if (v.cwiseAbs().maxCoeff() > kMaxVectorComponent)
    fail(field, fmt::format("({:.6g}, {:.6g}, {:.6g}) is beyond ±{:g} in a component (m, N, N·m or 1/m): no step holds "
                            "it",
                            v.x(), v.y(), v.z(), kMaxVectorComponent));
  if (nonzero && !(v.norm() > 0.0)) fail(field, "expected a non-zero vector");
}

}  // namespace haustra::detail
