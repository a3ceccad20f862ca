#pragma once
// Read-only NumPy arrays over the world's own buffers, without copies. Each array's base holds
// World::buffers_keeper(), so the memory outlives the world and any rebuild (add/remove segment).
#include <pybind11/numpy.h>

#include <array>
#include <cstdint>
#include <memory>
#include <span>

#include "haustra/kernels/spans.hpp"

namespace haustra::python {

using Keeper = std::shared_ptr<const void>;

// (n, 3) over a Vec3View's one block (x then y then z): strides (1, n) elements.
pybind11::array vec3_array(kernels::Vec3View<const double> v, const Keeper& keeper);
pybind11::array vec3_array(kernels::Vec3View<const float> v, const Keeper& keeper);
// (n, 4) over a RotationView's one block (w, x, y, z): strides (1, n) elements.
pybind11::array rotation_array(kernels::RotationView<const double> r, const Keeper& keeper);
// (n, columns) over a row-major block, or (n,) when columns is 0.
pybind11::array rows_array(std::span<const double> data, std::size_t columns, const Keeper& keeper);
pybind11::array rows_array(std::span<const std::uint32_t> data, std::size_t columns, const Keeper& keeper);
pybind11::array triangles_array(std::span<const std::array<std::uint32_t, 3>> triangles, const Keeper& keeper);

}  // namespace haustra::python
