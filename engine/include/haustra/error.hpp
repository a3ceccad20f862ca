#pragma once
// The engine's error type: a code a program can branch on and a message a person can act on
// (which file, which field, what was expected). The C API turns these into codes + messages.
#include <stdexcept>
#include <string>

namespace haustra {

enum class ErrorCode : int {
  invalid_argument = 1,  // a value outside its range, a wrong index, a call in the wrong order
  io = 2,                // a file that cannot be read or written
  parse = 3,             // a file that is not what its format says
  invalid_geometry = 4,  // a centreline or mesh the model cannot be built from
  unstable = 5,          // the simulation diverged and could not recover (state kept at last good frame)
  internal = 6,
  // (7 and 8 are the C API's own: an invalid handle, an ABI mismatch)
  busy = 9,  // another thread is stepping or changing the world, or a call came from inside its step
};

class Error : public std::runtime_error {
 public:
  Error(ErrorCode code, const std::string& message) : std::runtime_error(message), code_(code) {}
  [[nodiscard]] ErrorCode code() const noexcept { return code_; }

 private:
  ErrorCode code_;
};

// An error about one field of a description, named by its scene-file path
// (e.g. "segment[0].youngs_modulus"), so a scene loader can point at the line that set it.
class FieldError : public Error {
 public:
  FieldError(ErrorCode code, std::string field, std::string detail)
      : Error(code, field + ": " + detail), field_(std::move(field)), detail_(std::move(detail)) {}
  // With the message spelled out in full, e.g. prefixed by the file and line of the field.
  FieldError(ErrorCode code, std::string field, std::string detail, const std::string& message)
      : Error(code, message), field_(std::move(field)), detail_(std::move(detail)) {}
  [[nodiscard]] const std::string& field() const noexcept { return field_; }
  [[nodiscard]] const std::string& detail() const noexcept { return detail_; }

 private:
  std::string field_;
  std::string detail_;
};

[[nodiscard]] const char* error_code_name(ErrorCode code) noexcept;

}  // namespace haustra
