#pragma once
// The parts of haustra.World, each bound by its own file onto the one class.
#include <pybind11/pybind11.h>

#include "py_world.hpp"

namespace haustra::python {

using WorldClass = pybind11::class_<PyWorld>;

void bind_lifecycle(WorldClass& c);       // world_binding.cpp: construction, step, checkpoints, segments
void bind_pickling(WorldClass& c);        // world_pickling.cpp: pickle, copy and deepcopy
void bind_world_views(WorldClass& c);     // world_views.cpp: zero-copy arrays over the engine's buffers
void bind_world_state(WorldClass& c);     // world_state.cpp: derived state, contact records
void bind_world_driving(WorldClass& c);   // world_driving.cpp: loads, attachments, instruments, parameters
void bind_world_readings(WorldClass& c);  // world_readings.cpp: small readings as dicts and numbers
void bind_world_writing(WorldClass& c);   // world_writing.cpp: state from arrays, many loads, loads per length
void bind_world_tissue(WorldClass& c);    // world_tissue.cpp: connective tissue's anchors, cutting

}  // namespace haustra::python
