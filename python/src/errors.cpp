// The engine's errors as Python exceptions: haustra.Error (code, field, message) and a subclass
// per code that also derives from the built-in a Python user would catch (ValueError, OSError).
#include <pybind11/pybind11.h>

#include "bindings.hpp"
#include "haustra/error.hpp"
#include "indices.hpp"

namespace py = pybind11;

namespace haustra::python {
namespace {

// Exception classes live as long as the interpreter: their handles are never released.
struct ExceptionTypes {
  py::handle base, invalid_argument, invalid_index, io, parse, geometry, unstable, internal, busy;
};
ExceptionTypes& types() {
  static ExceptionTypes t;
  return t;
}

py::handle new_type(py::module_& m, const char* name, py::tuple bases, const char* doc) {
  const std::string qualified = std::string("haustra.") + name;
  PyObject* type = PyErr_NewExceptionWithDoc(qualified.c_str(), doc, bases.ptr(), nullptr);
  if (type == nullptr) throw py::error_already_set();
  m.add_object(name, py::handle(type));  // the module takes its own reference; ours stays
  return type;
}

py::handle type_of(ErrorCode code) {
  const ExceptionTypes& t = types();
  switch (code) {
    case ErrorCode::invalid_argument: return t.invalid_argument;
    case ErrorCode::io: return t.io;
    case ErrorCode::parse: return t.parse;
    case ErrorCode::invalid_geometry: return t.geometry;
    case ErrorCode::unstable: return t.unstable;
    case ErrorCode::internal: return t.internal;
    case ErrorCode::busy: return t.busy;
  }
  return t.base;
}

void raise(ErrorCode code, const char* message, const std::string* field, bool index = false) {
  const py::handle type = index ? types().invalid_index : type_of(code);
  py::object error = py::reinterpret_borrow<py::object>(type)(message);
  error.attr("code") = error_code_name(code);
  error.attr("field") = field != nullptr ? py::object(py::str(*field)) : py::object(py::none());
  PyErr_SetObject(type.ptr(), error.ptr());
}

}  // namespace

void set_python_error(const Error& e) {
  const auto* field = dynamic_cast<const FieldError*>(&e);
  raise(e.code(), e.what(), field != nullptr ? &field->field() : nullptr,
        dynamic_cast<const IndexOutOfRange*>(&e) != nullptr);
}

void bind_errors(py::module_& m) {
  ExceptionTypes& t = types();
  t.base =
      new_type(m, "Error", py::make_tuple(py::handle(PyExc_RuntimeError)),
               "An error from the engine. `code` names its kind ('invalid_argument', 'io', 'parse', "
               "'invalid_geometry', 'unstable', 'internal', 'busy'); `field` the scene field it is about, or None. "
               "The message names the file, line and field where there is one.");
  auto sub = [&](const char* name, PyObject* builtin, const char* doc) {
    return new_type(m, name, builtin != nullptr ? py::make_tuple(t.base, py::handle(builtin)) : py::make_tuple(t.base),
                    doc);
  };
  t.invalid_argument = sub("InvalidArgumentError", PyExc_ValueError, "A value out of its range, a wrong index.");
  // Both a haustra error and the built-in a Python user catches for a bad index (decision 0088).
  t.invalid_index = new_type(m, "InvalidIndexError", py::make_tuple(t.invalid_argument, py::handle(PyExc_IndexError)),
                             "An index argument out of range (a node, segment, attachment or instrument): the message "
                             "names the call, the argument, the value given and the valid range.");
  t.io = sub("FileError", PyExc_OSError, "A file that cannot be read or written.");
  t.parse = sub("ParseError", PyExc_ValueError, "A file (or description) that is not what its format says.");
  t.geometry = sub("GeometryError", PyExc_ValueError, "A centreline or mesh the model cannot be built from.");
  t.unstable = sub("UnstableError", nullptr,
                   "The simulation diverged and could not recover; the world stays at its last good frame.");
  t.internal = sub("InternalError", nullptr, "A bug in the engine.");
  t.busy = sub("BusyError", nullptr,
               "Another thread is stepping or changing this world (one thread at a time, decision 0100); nothing "
               "was changed: call again once its call returns.");

  py::register_exception_translator([](std::exception_ptr thrown) {
    try {
      if (thrown) std::rethrow_exception(thrown);
    } catch (const IndexOutOfRange& e) {
      raise(e.code(), e.what(), nullptr, true);
    } catch (const FieldError& e) {
      raise(e.code(), e.what(), &e.field());
    } catch (const Error& e) {
      raise(e.code(), e.what(), nullptr);
    }
  });
}

}  // namespace haustra::python
