// The error codes' names.
#include "haustra/error.hpp"

namespace haustra {

const char* error_code_name(ErrorCode code) noexcept {
  switch (code) {
    case ErrorCode::invalid_argument: return "invalid_argument";
    case ErrorCode::io: return "io";
    case ErrorCode::parse: return "parse";
    case ErrorCode::invalid_geometry: return "invalid_geometry";
    case ErrorCode::unstable: return "unstable";
    case ErrorCode::internal: return "internal";
    case ErrorCode::busy: return "busy";
  }
  return "unknown";
}

}  // namespace haustra
