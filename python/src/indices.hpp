#pragma once
// Index arguments of haustra.World's methods (node, segment, attachment, instrument): a Python int,
// 0 ≤ i < count or, counting from the end, −count ≤ i < 0 (decision 0088). Anything else raises
// haustra.InvalidIndexError naming the call, the argument, the value and the valid range.
#include <pybind11/pybind11.h>

#include <cstddef>
#include <cstdint>
#include <string>

#include "haustra/error.hpp"
#include "haustra/world.hpp"

namespace haustra::python {

// An index argument as Python gave it: any int (or an object with __index__, as NumPy's integers),
// its value when it fits in 64 bits; otherwise its decimal digits, so that the range error names it
// like any other (an int beyond 64 bits was pybind11's TypeError).
struct IndexArg {
  std::int64_t value = 0;
  std::string beyond;  // empty when value holds the int
};

// An index out of range: haustra.InvalidIndexError (an InvalidArgumentError and an IndexError).
class IndexOutOfRange : public Error {
 public:
  explicit IndexOutOfRange(const std::string& message) : Error(ErrorCode::invalid_argument, message) {}
};

// `call`: the method's name, as the message's prefix.
std::size_t node_index(const World& world, const IndexArg& node, const char* call);
std::size_t segment_index(const World& world, const IndexArg& segment, const char* call);
std::size_t instrument_index(const World& world, const IndexArg& instrument, const char* call);
// The segment's index resolved first; its attachments are the scene's, then one grasp slot per instrument.
std::size_t attachment_index(const World& world, std::size_t segment, const IndexArg& attachment, const char* call);

}  // namespace haustra::python

namespace pybind11::detail {

// Python int → IndexArg: what pybind11's int64 took (ints, bools, __index__; not floats), at any size.
template <>
struct type_caster<haustra::python::IndexArg> {
  PYBIND11_TYPE_CASTER(haustra::python::IndexArg, const_name("int"));
  bool load(handle src, bool /*convert*/) {
    if (!src || PyFloat_Check(src.ptr()) || !PyIndex_Check(src.ptr())) return false;
    const object number = reinterpret_steal<object>(PyNumber_Index(src.ptr()));
    if (!number) {
      PyErr_Clear();
      return false;
    }
    int overflow = 0;
    const long long v = PyLong_AsLongLongAndOverflow(number.ptr(), &overflow);
    if (overflow == 0 && !(v == -1 && PyErr_Occurred())) {
      value = {static_cast<std::int64_t>(v), {}};
      return true;
    }
    PyErr_Clear();
    value = {0, str(number).cast<std::string>()};
    return true;
  }
};

}  // namespace pybind11::detail
