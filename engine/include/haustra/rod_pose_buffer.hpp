#pragma once
// Owning storage for one rod's poses (N+1 nodes, N midpoints), for callers that need a shape
// outside a world: building rest shapes, default attachment targets, tests.
#include <vector>

#include "haustra/kernels/spans.hpp"

namespace haustra {

class RodPoseBuffer {
 public:
  explicit RodPoseBuffer(std::size_t nodes) : nodes_(nodes), data_(14 * nodes, 0.0) {}

  [[nodiscard]] kernels::RodPoses<double> view() { return layout<double>(data_.data()); }
  [[nodiscard]] kernels::RodPoses<const double> view() const { return layout<const double>(data_.data()); }

 private:
  template <class T>
  [[nodiscard]] kernels::RodPoses<T> layout(T* data) const {
    auto col = [&](std::size_t i, std::size_t len) { return std::span<T>(data + i * nodes_, len); };
    const std::size_t n = nodes_;
    const std::size_t m = n - 1;
    return {{col(0, n), col(1, n), col(2, n)},
            {col(3, n), col(4, n), col(5, n), col(6, n)},
            {col(7, m), col(8, m), col(9, m)},
            {col(10, m), col(11, m), col(12, m), col(13, m)}};
  }

  std::size_t nodes_;
  std::vector<double> data_;
};

}  // namespace haustra
