#pragma once
// What the Python module's files share: each binds one part of the API into the module.
#include <pybind11/pybind11.h>

#include "haustra/error.hpp"

namespace haustra::python {

void bind_errors(pybind11::module_& m);  // errors.cpp: haustra.Error and one subclass per code
void bind_world(pybind11::module_& m);   // world_binding.cpp: haustra.World
void bind_functions(pybind11::module_& m);
void bind_batch(
    pybind11::module_& m);  // batch_binding.cpp: haustra.Batch  // functions.cpp: validate, save_mesh, estimate_memory

// errors.cpp: sets the Python error for an engine error (its haustra.Error subclass, code, field).
void set_python_error(const Error& e);

}  // namespace haustra::python
