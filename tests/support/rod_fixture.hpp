#pragma once
// Random rods for kernel tests: section lengths, strains and loads drawn from a seeded generator,
// and buffers for poses and generalized forces, sized once.
#include <algorithm>
#include <random>
#include <vector>

#include "haustra/kernels/pose.hpp"
#include "haustra/kernels/rod_forward_sweep.hpp"
#include "haustra/kernels/spans.hpp"

namespace haustra::test {

struct RodBuffers {
  std::size_t n;
  std::vector<double> h, strain, px, py, pz, qw, qx, qy, qz, mx, my, mz, mw, mqx, mqy, mqz;
  std::vector<double> fx, fy, fz, tx, ty, tz;

  explicit RodBuffers(std::size_t nodes)
      : n(nodes),
        h(nodes - 1),
        strain(4 * nodes),
        px(nodes),
        py(nodes),
        pz(nodes),
        qw(nodes),
        qx(nodes),
        qy(nodes),
        qz(nodes),
        mx(nodes - 1),
        my(nodes - 1),
        mz(nodes - 1),
        mw(nodes - 1),
        mqx(nodes - 1),
        mqy(nodes - 1),
        mqz(nodes - 1),
        fx(nodes),
        fy(nodes),
        fz(nodes),
        tx(nodes),
        ty(nodes),
        tz(nodes) {}

  kernels::RodPoses<double> poses() { return {{px, py, pz}, {qw, qx, qy, qz}, {mx, my, mz}, {mw, mqx, mqy, mqz}}; }
  kernels::StrainView<double> strains() { return {strain}; }
  kernels::Vec3View<double> force() { return {fx, fy, fz}; }
  kernels::Vec3View<double> moment() { return {tx, ty, tz}; }

  // A curved, twisted, stretched rod with loads on every node.
  void randomize(std::uint32_t seed, double length = 1.0, double curvature = 3.0, double load = 1.0) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (auto& x : h) x = length / static_cast<double>(h.size()) * (1.0 + 0.3 * u(rng));
    for (std::size_t k = 0; k < n; ++k) {
      strain[4 * k] = curvature * u(rng);
      strain[4 * k + 1] = curvature * u(rng);
      strain[4 * k + 2] = curvature * u(rng);
      strain[4 * k + 3] = 0.1 * u(rng);
      fx[k] = load * u(rng);
      fy[k] = load * u(rng);
      fz[k] = load * u(rng);
      tx[k] = 0.1 * load * u(rng);
      ty[k] = 0.1 * load * u(rng);
      tz[k] = 0.1 * load * u(rng);
    }
  }

  void clear_loads() {
    for (auto* v : {&fx, &fy, &fz, &tx, &ty, &tz}) std::fill(v->begin(), v->end(), 0.0);
  }

  void sweep(const kernels::Pose& base = {}) {
    kernels::rod_forward_sweep(base, h, kernels::StrainView<const double>{strain}, poses());
  }
};

}  // namespace haustra::test
