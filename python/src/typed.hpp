#pragma once
// Python objects whose names in pybind11's signatures say what they hold: a dict named for its
// TypedDict in haustra.types, an array named for its dtype. The generated stubs and help() show
// these names; at run time they are plain dicts, lists and NumPy arrays.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

namespace haustra::python {

#define HAUSTRA_TYPED_OBJECT(Class, Base, Check)          \
  class Class : public pybind11::Base {                   \
   public:                                                \
    PYBIND11_OBJECT_DEFAULT(Class, pybind11::Base, Check) \
  };

inline bool any_object(PyObject* /*unused*/) { return true; }

// A dict with the keys of one TypedDict of haustra/types.py.
HAUSTRA_TYPED_OBJECT(ProfileDict, dict, PyDict_Check)
HAUSTRA_TYPED_OBJECT(InstrumentDict, dict, PyDict_Check)
HAUSTRA_TYPED_OBJECT(ContactSummaryDict, dict, PyDict_Check)
HAUSTRA_TYPED_OBJECT(EnergyDict, dict, PyDict_Check)
HAUSTRA_TYPED_OBJECT(MemoryDict, dict, PyDict_Check)
HAUSTRA_TYPED_OBJECT(RecordingDict, dict, PyDict_Check)
HAUSTRA_TYPED_OBJECT(MaybeRecording, object, any_object)  // a RecordingDict or None
// Anything NumPy reads as an array (a list, a tuple, an array): the engine checks its shape.
HAUSTRA_TYPED_OBJECT(ArrayLike, object, any_object)
// A list of such dicts.
HAUSTRA_TYPED_OBJECT(SegmentList, list, PyList_Check)
HAUSTRA_TYPED_OBJECT(EventList, list, PyList_Check)
HAUSTRA_TYPED_OBJECT(ValidationList, list, PyList_Check)
// A NumPy array of one dtype.
HAUSTRA_TYPED_OBJECT(Float64Array, array, pybind11::detail::npy_api::get().PyArray_Check_)
HAUSTRA_TYPED_OBJECT(Float32Array, array, pybind11::detail::npy_api::get().PyArray_Check_)
HAUSTRA_TYPED_OBJECT(UInt32Array, array, pybind11::detail::npy_api::get().PyArray_Check_)
HAUSTRA_TYPED_OBJECT(BoolArray, array, pybind11::detail::npy_api::get().PyArray_Check_)
HAUSTRA_TYPED_OBJECT(ContactArray, array, pybind11::detail::npy_api::get().PyArray_Check_)

#undef HAUSTRA_TYPED_OBJECT

// Gives every function and method of the module a text signature (CPython's "name(a, b=1)\n--\n\n"
// docstring prefix, built from pybind11's typed one), so inspect.signature and help() work.
void add_text_signatures(pybind11::module_& m);

}  // namespace haustra::python

namespace pybind11::detail {
#define HAUSTRA_TYPE_NAME(Class, Name)              \
  template <>                                       \
  struct handle_type_name<haustra::python::Class> { \
    static constexpr auto name = const_name(Name);  \
  };
HAUSTRA_TYPE_NAME(ProfileDict, "haustra.types.Profile")
HAUSTRA_TYPE_NAME(InstrumentDict, "haustra.types.Instrument")
HAUSTRA_TYPE_NAME(ContactSummaryDict, "haustra.types.ContactSummary")
HAUSTRA_TYPE_NAME(EnergyDict, "haustra.types.Energy")
HAUSTRA_TYPE_NAME(MemoryDict, "haustra.types.MemoryEstimate")
HAUSTRA_TYPE_NAME(RecordingDict, "dict[str, numpy.typing.NDArray[typing.Any]]")
HAUSTRA_TYPE_NAME(MaybeRecording, "typing.Optional[dict[str, numpy.typing.NDArray[typing.Any]]]")
HAUSTRA_TYPE_NAME(ArrayLike, "numpy.typing.ArrayLike")
HAUSTRA_TYPE_NAME(SegmentList, "list[haustra.types.Segment]")
HAUSTRA_TYPE_NAME(EventList, "list[haustra.types.Event]")
HAUSTRA_TYPE_NAME(ValidationList, "list[haustra.types.ValidationCase]")
HAUSTRA_TYPE_NAME(Float64Array, "numpy.typing.NDArray[numpy.float64]")
HAUSTRA_TYPE_NAME(Float32Array, "numpy.typing.NDArray[numpy.float32]")
HAUSTRA_TYPE_NAME(UInt32Array, "numpy.typing.NDArray[numpy.uint32]")
HAUSTRA_TYPE_NAME(BoolArray, "numpy.typing.NDArray[numpy.bool_]")
HAUSTRA_TYPE_NAME(ContactArray, "numpy.typing.NDArray[numpy.void]")
#undef HAUSTRA_TYPE_NAME
}  // namespace pybind11::detail
