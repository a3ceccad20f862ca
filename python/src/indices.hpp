#pragma once
// Index arguments of haustra.World's methods (node, segment, attachment, instrument): a Python int,
// 0 ≤ i < count or, counting from the end, −count ≤ i < 0 (decision 0088). Anything else raises
// haustra.InvalidIndexError naming the call, the argument, the value and the valid range.
#include <cstddef>
#include <cstdint>

#include "haustra/error.hpp"
#include "haustra/world.hpp"

namespace haustra::python {

// An index out of range: haustra.InvalidIndexError (an InvalidArgumentError and an IndexError).
class IndexOutOfRange : public Error {
 public:
  explicit IndexOutOfRange(const std::string& message) : Error(ErrorCode::invalid_argument, message) {}
};

// `call`: the method's name, as the message's prefix.
std::size_t node_index(const World& world, std::int64_t node, const char* call);
std::size_t segment_index(const World& world, std::int64_t segment, const char* call);
std::size_t instrument_index(const World& world, std::int64_t instrument, const char* call);
// The segment's index resolved first; its attachments are the scene's, then one grasp slot per instrument.
std::size_t attachment_index(const World& world, std::size_t segment, std::int64_t attachment, const char* call);

}  // namespace haustra::python
