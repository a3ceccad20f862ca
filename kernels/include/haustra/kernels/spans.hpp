#pragma once
// Views over structure-of-arrays buffers. Kernels read and write through these; the caller owns
// the memory. A Vec3 view is three parallel arrays (x[], y[], z[]), a rotation view four (w, x, y, z
// of unit quaternions), a strain view one array of 4 doubles per node (κ1, κ2, τ, ε interleaved,
// so that the four components of one node travel together through the sweeps and the solve).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cassert>
#include <cstddef>
#include <span>

namespace haustra::kernels {

inline constexpr std::size_t kStrainComponents = 4;  // κ1, κ2, τ, ε

template <class T>
struct Vec3View {
  std::span<T> x, y, z;

  [[nodiscard]] std::size_t size() const { return x.size(); }
  [[nodiscard]] Eigen::Vector3d get(std::size_t i) const { return {x[i], y[i], z[i]}; }
  void set(std::size_t i, const Eigen::Vector3d& v) const requires(!std::is_const_v<T>) {
    x[i] = v.x();
    y[i] = v.y();
    z[i] = v.z();
  }
  [[nodiscard]] Vec3View subview(std::size_t offset, std::size_t count) const {
    return {x.subspan(offset, count), y.subspan(offset, count), z.subspan(offset, count)};
  }
  operator Vec3View<const T>() const  // NOLINT(google-explicit-constructor): const view of a mutable one
      requires(!std::is_const_v<T>) {
    return {x, y, z};
  }
};

template <class T>
struct RotationView {
  std::span<T> w, x, y, z;

  [[nodiscard]] std::size_t size() const { return w.size(); }
  [[nodiscard]] Eigen::Quaterniond get(std::size_t i) const { return {w[i], x[i], y[i], z[i]}; }
  void set(std::size_t i, const Eigen::Quaterniond& q) const requires(!std::is_const_v<T>) {
    w[i] = q.w();
    x[i] = q.x();
    y[i] = q.y();
    z[i] = q.z();
  }
  [[nodiscard]] RotationView subview(std::size_t offset, std::size_t count) const {
    return {w.subspan(offset, count), x.subspan(offset, count), y.subspan(offset, count), z.subspan(offset, count)};
  }
  operator RotationView<const T>() const  // NOLINT(google-explicit-constructor)
      requires(!std::is_const_v<T>) {
    return {w, x, y, z};
  }
};

// Four doubles per node: data[4k + c], c = 0 κ1, 1 κ2, 2 τ, 3 ε.
template <class T>
struct StrainView {
  std::span<T> data;

  [[nodiscard]] std::size_t size() const { return data.size() / kStrainComponents; }
  [[nodiscard]] Eigen::Vector4d get(std::size_t k) const {
    return {data[4 * k], data[4 * k + 1], data[4 * k + 2], data[4 * k + 3]};
  }
  void set(std::size_t k, const Eigen::Vector4d& v) const requires(!std::is_const_v<T>) {
    for (std::size_t c = 0; c < kStrainComponents; ++c) data[4 * k + c] = v[static_cast<Eigen::Index>(c)];
  }
  [[nodiscard]] T& at(std::size_t k, std::size_t c) const { return data[4 * k + c]; }
  [[nodiscard]] StrainView subview(std::size_t node_offset, std::size_t node_count) const {
    return {data.subspan(kStrainComponents * node_offset, kStrainComponents * node_count)};
  }
  operator StrainView<const T>() const  // NOLINT(google-explicit-constructor)
      requires(!std::is_const_v<T>) {
    return {data};
  }
};

// The geometry of one rod as the sweeps see it: N+1 nodes, N sections. Section k joins node k to
// node k+1; its midpoint pose is where its generalized forces are evaluated (second-order accurate).
template <class T>
struct RodPoses {
  Vec3View<T> node_position;      // N+1
  RotationView<T> node_rotation;  // N+1, body to world, columns d1 d2 d3
  Vec3View<T> mid_position;       // N (entries for sections)
  RotationView<T> mid_rotation;   // N

  [[nodiscard]] std::size_t node_count() const { return node_position.size(); }
  // Nodes [first, first + count) and the sections between them.
  [[nodiscard]] RodPoses subview(std::size_t first, std::size_t count) const {
    return {node_position.subview(first, count), node_rotation.subview(first, count),
            mid_position.subview(first, count - 1), mid_rotation.subview(first, count - 1)};
  }
  operator RodPoses<const T>() const  // NOLINT(google-explicit-constructor)
      requires(!std::is_const_v<T>) {
    return {node_position, node_rotation, mid_position, mid_rotation};
  }
};

}  // namespace haustra::kernels
