// Text signatures for inspect.signature: CPython reads a builtin's signature from a docstring that
// starts "name(a, b=1)\n--\n\n"; pybind11 writes "name(a: int, b: int = 1) -> R\n\n...". This pass
// prepends the former, made from the latter, to every function and method, and keeps the typed
// line after it (the stub generator and help() read it).
#include <Python.h>

#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

#include "typed.hpp"

namespace py = pybind11;

namespace haustra::python {
namespace {

// The parameter list between the first "(" and its ")" split at top-level commas.
std::vector<std::string> parameters_of(std::string_view typed, std::size_t open, std::size_t& close) {
  std::vector<std::string> out;
  int depth = 0;
  std::string current;
  for (std::size_t i = open + 1; i < typed.size(); ++i) {
    const char c = typed[i];
    if (depth == 0 && (c == ',' || c == ')')) {
      if (!current.empty()) out.push_back(current);
      current.clear();
      if (c == ')') {
        close = i;
        return out;
      }
      continue;
    }
    if (c == '(' || c == '[' || c == '{') ++depth;
    if (c == ')' || c == ']' || c == '}') --depth;
    if (!(current.empty() && c == ' ')) current += c;
  }
  close = std::string_view::npos;
  return {};
}

// "n: int = 1" → "n=1"; a default CPython cannot evaluate (a pybind11 repr like <...>) → unknown.
bool untyped(const std::string& parameter, std::string& out) {
  const std::size_t colon = parameter.find(':');
  const std::string name = parameter.substr(0, colon);
  const std::size_t equals = parameter.find(" = ");
  if (equals == std::string::npos) {
    out = name;
    return true;
  }
  const std::string value = parameter.substr(equals + 3);
  if (value.empty() || value.front() == '<') return false;
  out = name + "=" + value;
  return true;
}

// The text signature for a pybind11 docstring, or "" when it has none we can state.
std::string text_signature(std::string_view doc) {
  const std::size_t open = doc.find('(');
  const std::size_t line_end = doc.find('\n');
  if (open == std::string_view::npos || open > line_end || doc.substr(0, open).find(' ') != std::string_view::npos)
    return "";
  std::size_t close = 0;
  const std::vector<std::string> parameters = parameters_of(doc, open, close);
  if (close == std::string_view::npos || close > line_end) return "";
  std::string sig = std::string(doc.substr(0, open)) + "(";
  for (std::size_t i = 0; i < parameters.size(); ++i) {
    std::string p;
    if (!untyped(parameters[i], p) || p.starts_with("*")) return "";
    sig += (i > 0 ? ", " : "") + p;
  }
  return sig + ")\n--\n\n";
}

// No "$self": pybind11's functions are bound to their record (m_self), so CPython would drop a
// "$" parameter even from the unbound method; a plain self is dropped only where Python binds it.
void sign(PyObject* function) {
  if (function == nullptr || !PyCFunction_Check(function)) return;
  PyMethodDef* def = reinterpret_cast<PyCFunctionObject*>(function)->m_ml;
  if (def == nullptr || def->ml_doc == nullptr || std::strstr(def->ml_doc, "\n--\n\n") != nullptr) return;
  const std::string prefix = text_signature(def->ml_doc);
  if (prefix.empty()) return;
  const std::string doc = prefix + def->ml_doc;
  char* old = const_cast<char*>(def->ml_doc);
  def->ml_doc = strdup(doc.c_str());  // pybind11 frees ml_doc with free() when the function goes
  std::free(old);
}

void sign_class(const py::handle& type) {
  const py::dict members = type.attr("__dict__");
  for (const auto& [name, member] : members) {
    PyObject* m = member.ptr();
    if (PyInstanceMethod_Check(m))
      sign(PyInstanceMethod_Function(m));
    else if (py::isinstance(member, py::module_::import("builtins").attr("staticmethod")))
      sign(member.attr("__func__").ptr());
  }
}

}  // namespace

void add_text_signatures(py::module_& m) {
  for (const auto& [name, member] : py::dict(m.attr("__dict__"))) {
    if (PyCFunction_Check(member.ptr()))
      sign(member.ptr());
    else if (PyType_Check(member.ptr()) && py::hasattr(member, "__module__") &&
             py::str(member.attr("__module__")).cast<std::string>() == py::str(m.attr("__name__")).cast<std::string>())
      sign_class(member);
  }
}

}  // namespace haustra::python
