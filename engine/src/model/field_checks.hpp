#pragma once
// Checks of one description field each: the message names the field, what was expected and what
// was given (FieldError, so a scene loader can point at the line that set it).
#include <Eigen/Core>
#include <string>

namespace haustra::detail {

[[noreturn]] void fail(const std::string& field, const std::string& detail);
void check_positive(const std::string& field, double v, const char* unit, double plausible_max,
                    const char* hint = nullptr);
void check_range(const std::string& field, double v, double lo, double hi, const char* what);
void check_int(const std::string& field, long long v, long long lo, long long hi);
void check_vector(const std::string& field, const Eigen::Vector3d& v, bool nonzero);

}  // namespace haustra::detail
