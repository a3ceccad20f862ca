// The extension module haustra._haustra; the package's __init__.py re-exports it.
#include "bindings.hpp"
#include "typed.hpp"

namespace haustra::python {
void bind_studies(pybind11::module_& m);
}  // namespace haustra::python

PYBIND11_MODULE(_haustra, m) {
  m.doc() = "haustra: beads-on-string soft organs (Cosserat rod, beads, cage-driven mesh)";
  m.attr("__version__") = HAUSTRA_VERSION;  // the project's, as the C library's haustra_version()
  haustra::python::bind_errors(m);
  haustra::python::bind_world(m);
  haustra::python::bind_functions(m);
  haustra::python::bind_batch(m);
  haustra::python::bind_studies(m);
  // ContactKind's names, in its order: contact_records' kind indexes them.
  m.attr("CONTACT_KINDS") = pybind11::make_tuple("bead", "plane", "sphere", "capsule", "mesh", "instrument");
  haustra::python::add_text_signatures(m);  // last: every function is bound
}
