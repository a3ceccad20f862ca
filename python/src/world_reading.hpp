#pragma once
// The world's small readings as Python values (dicts, lists, 3-vectors) and 3-vectors from Python.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Core>
#include <span>

#include "haustra/profile.hpp"
#include "haustra/world.hpp"
#include "typed.hpp"

namespace haustra::python {

// Any sequence of three finite-or-not numbers (the engine checks finiteness); else
// haustra.InvalidArgumentError naming `what`.
Eigen::Vector3d vector3(const pybind11::object& value, const char* what);
pybind11::array array3(const Eigen::Vector3d& v);

InstrumentDict instrument_dict(const InstrumentReading& r);
SegmentList segments_list(const World& world);
ProfileDict profile_dict(const FrameProfile& p);
EventList events_list(std::span<const Event> events);
ContactSummaryDict contacts_dict(const ContactReport& r);

}  // namespace haustra::python
