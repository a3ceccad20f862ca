#pragma once
// Python values to the scene format: a world described as a dict with the keys of a scene file
// (docs/scene-format.md) becomes TOML text for the scene reader, so a dict and a file are checked
// by the same code and fail with the same field names.
#include <pybind11/pybind11.h>

#include <string>
#include <vector>

namespace haustra::python {

// {"world": {"dt": 0.01}, "segment": [{"nodes": 50}]} -> TOML. Throws haustra::Error naming the
// key path of a value TOML cannot hold.
std::string toml_text(const pybind11::dict& description);

// {"segment.nodes": 333, "solver.mode": "lagged"} -> {"segment.nodes=333", "solver.mode=\"lagged\""}.
std::vector<std::string> override_strings(const pybind11::dict& overrides);

}  // namespace haustra::python
