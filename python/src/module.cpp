// The extension module haustra._haustra; the package's __init__.py re-exports it.
#include "bindings.hpp"

PYBIND11_MODULE(_haustra, m) {
  m.doc() = "haustra: beads-on-string soft organs (Cosserat rod, beads, cage-driven mesh)";
  haustra::python::bind_errors(m);
  haustra::python::bind_world(m);
  haustra::python::bind_functions(m);
}
