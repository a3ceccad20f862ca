// NumPy structured dtypes laid over the engine's own structs (FrameProfile, ContactReport,
// Contact): offsets measured on an instance, so a row is a byte copy of the struct and a field
// added to report_fields.h appears here without an edit.
#include <pybind11/numpy.h>

#include <string>

#include "haustra/profile.hpp"
#include "haustra/world.hpp"
#include "recording.hpp"

namespace py = pybind11;

namespace haustra::python {
namespace {

struct Fields {
  py::list names, formats, offsets;
  void add(const std::string& name, const py::object& format, std::size_t offset) {
    names.append(name);
    formats.append(format);
    offsets.append(offset);
  }
  py::dtype make(std::size_t itemsize) const {
    py::dict d;
    d["names"] = names;
    d["formats"] = formats;
    d["offsets"] = offsets;
    d["itemsize"] = itemsize;
    return py::dtype::from_args(d);
  }
};

template <class S, class M>
std::size_t offset_of(const S& s, const M& member) {
  return static_cast<std::size_t>(reinterpret_cast<const char*>(&member) - reinterpret_cast<const char*>(&s));
}

// Per stage, one field of type T, at consecutive places.
template <class T>
py::dtype by_stage() {
  Fields f;
  for (std::size_t s = 0; s < kStageCount; ++s)
    f.add(std::string(stage_name(static_cast<Stage>(s))), py::dtype::of<T>(), s * sizeof(T));
  return f.make(kStageCount * sizeof(T));
}

py::object vector3_format() { return py::make_tuple(py::dtype::of<double>(), 3); }

}  // namespace

py::dtype profile_dtype() {
  const FrameProfile p;
  Fields f;
  f.add("frame_seconds", py::dtype::of<double>(), offset_of(p, p.frame_seconds));
  f.add("seconds", by_stage<double>(), offset_of(p, p.seconds));
  f.add("calls", by_stage<std::uint32_t>(), offset_of(p, p.calls));
#define HAUSTRA_ADD_FIELD(type, name, initial, meaning) f.add(#name, py::dtype::of<type>(), offset_of(p, p.name));
  HAUSTRA_PROFILE_COUNTERS(HAUSTRA_ADD_FIELD)
#undef HAUSTRA_ADD_FIELD
  f.add("newton", py::dtype::of<bool>(), offset_of(p, p.newton));
  return f.make(sizeof(FrameProfile));
}

py::dtype contact_summary_dtype() {
  const ContactReport r;
  Fields f;
#define HAUSTRA_ADD_FIELD(type, name, initial, meaning) f.add(#name, py::dtype::of<type>(), offset_of(r, r.name));
  HAUSTRA_CONTACT_FIELDS(HAUSTRA_ADD_FIELD)
#undef HAUSTRA_ADD_FIELD
  return f.make(sizeof(ContactReport));
}

py::dtype contact_dtype() {
  static_assert(sizeof(ContactKind) == 1);
  const Contact c;
  Fields f;
  f.add("bead", py::dtype::of<std::uint32_t>(), offset_of(c, c.bead));
  f.add("other", py::dtype::of<std::uint32_t>(), offset_of(c, c.other));
  f.add("kind", py::dtype::of<std::uint8_t>(), offset_of(c, c.kind));
  f.add("point", vector3_format(), offset_of(c, c.point));
  f.add("normal", vector3_format(), offset_of(c, c.normal));
  f.add("force", vector3_format(), offset_of(c, c.force));
  f.add("direction", vector3_format(), offset_of(c, c.direction));
  f.add("stiffness", py::dtype::of<double>(), offset_of(c, c.stiffness));
  f.add("depth", py::dtype::of<double>(), offset_of(c, c.depth));
  f.add("coupled", py::dtype::of<bool>(), offset_of(c, c.coupled));
  return f.make(sizeof(Contact));
}

}  // namespace haustra::python
