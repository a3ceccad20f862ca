// Zero-copy arrays: NumPy points at the engine's memory; a capsule holding the keeper is the base.
#include "views.hpp"

#include "haustra/error.hpp"

namespace py = pybind11;

namespace haustra::python {
namespace {

py::capsule base_of(const Keeper& keeper) {
  return py::capsule(new Keeper(keeper), [](void* p) { delete static_cast<Keeper*>(p); });
}

template <class T>
py::array read_only(std::vector<py::ssize_t> shape, std::vector<py::ssize_t> strides, const T* data,
                    const Keeper& keeper) {
  py::array a(py::dtype::of<T>(), std::move(shape), std::move(strides), data, base_of(keeper));
  a.attr("setflags")(py::arg("write") = false);
  return a;
}

template <class T>
py::array vec3_of(kernels::Vec3View<const T> v, const Keeper& keeper) {
  const auto n = static_cast<py::ssize_t>(v.size());
  if (v.size() > 0 && (v.y.data() != v.x.data() + v.size() || v.z.data() != v.y.data() + v.size()))
    throw Error(ErrorCode::internal, "a Vec3View that is not one block (x, y, z): cannot be viewed without a copy");
  const auto item = static_cast<py::ssize_t>(sizeof(T));
  return read_only<T>({n, 3}, {item, n * item}, v.x.data(), keeper);
}

template <class T>
py::array rows_of(std::span<const T> data, std::size_t columns, const Keeper& keeper) {
  const auto item = static_cast<py::ssize_t>(sizeof(T));
  if (columns == 0) return read_only<T>({static_cast<py::ssize_t>(data.size())}, {item}, data.data(), keeper);
  const auto c = static_cast<py::ssize_t>(columns);
  return read_only<T>({static_cast<py::ssize_t>(data.size() / columns), c}, {c * item, item}, data.data(), keeper);
}

}  // namespace

py::array vec3_array(kernels::Vec3View<const double> v, const Keeper& keeper) { return vec3_of(v, keeper); }
py::array rotation_array(kernels::RotationView<const double> r, const Keeper& keeper) {
  const auto n = static_cast<py::ssize_t>(r.size());
  if (r.size() > 0 && (r.x.data() != r.w.data() + r.size() || r.y.data() != r.x.data() + r.size() ||
                       r.z.data() != r.y.data() + r.size()))
    throw Error(ErrorCode::internal,
                "a RotationView that is not one block (w, x, y, z): cannot be viewed without a copy");
  const auto item = static_cast<py::ssize_t>(sizeof(double));
  return read_only<double>({n, 4}, {item, n * item}, r.w.data(), keeper);
}
py::array vec3_array(kernels::Vec3View<const float> v, const Keeper& keeper) { return vec3_of(v, keeper); }
py::array rows_array(std::span<const double> data, std::size_t columns, const Keeper& keeper) {
  return rows_of(data, columns, keeper);
}
py::array rows_array(std::span<const std::uint32_t> data, std::size_t columns, const Keeper& keeper) {
  return rows_of(data, columns, keeper);
}
py::array triangles_array(std::span<const std::array<std::uint32_t, 3>> triangles, const Keeper& keeper) {
  static_assert(sizeof(std::array<std::uint32_t, 3>) == 3 * sizeof(std::uint32_t));
  return rows_of(
      std::span<const std::uint32_t>(reinterpret_cast<const std::uint32_t*>(triangles.data()), 3 * triangles.size()), 3,
      keeper);
}

}  // namespace haustra::python
