// The speed/accuracy study's knobs of the reconstruction: float against double, the SE(3)
// exponential against the midpoint rule.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <numbers>

#include "haustra/embree_scene.hpp"
#include "haustra/kernels/rod_forward_sweep.hpp"
#include "haustra/kernels/tissue_law.hpp"
#include "haustra/scene.hpp"
#include "haustra/studies/skinning_study.hpp"
#include "haustra/world.hpp"

#include "tradeoff_knobs.hpp"

namespace haustra::validation::tradeoff {

using Clock = std::chrono::steady_clock;

// --- reconstruction: precision and the integrator ----------------------------------------------

namespace {

// The forward sweep in scalar type T, with the SE(3) exponential per section (each section a
// helix, exact for constant strain) or the midpoint rule (the section's rotation exact, its
// position a straight step along the midpoint tangent).
template <class T>
void sweep(std::span<const double> h, std::span<const double> q, bool midpoint, std::vector<Eigen::Vector3d>& out) {
  using V = Eigen::Matrix<T, 3, 1>;
  using Q = Eigen::Quaternion<T>;
  Q rot = Q::Identity();
  V pos = V::Zero();
  out[0] = pos.template cast<double>();
  for (std::size_t k = 0; k < h.size(); ++k) {
    const V u(static_cast<T>(0.5 * (q[4 * k] + q[4 * k + 4])), static_cast<T>(0.5 * (q[4 * k + 1] + q[4 * k + 5])),
              static_cast<T>(0.5 * (q[4 * k + 2] + q[4 * k + 6])));
    const T stretch = static_cast<T>(1.0 + 0.5 * (q[4 * k + 3] + q[4 * k + 7]));
    const T len = static_cast<T>(h[k]);
    const T angle = u.norm() * len;
    const V axis = angle > T(0) ? V(u / u.norm()) : V::UnitZ();
    const Q turn(Eigen::AngleAxis<T>(angle, axis));
    const V e3 = V::UnitZ();
    V step;
    if (midpoint) {
      const Q half(Eigen::AngleAxis<T>(T(0.5) * angle, axis));
      step = (half * e3) * (stretch * len);
    } else {
      // ∫₀ˡ exp(s[u]×) e3 ds: the closed form of the helix step.
      const T a = angle;
      const V w = axis;
      const T c1 = a > T(1e-4) ? (T(1) - std::cos(a)) / a : a / T(2);
      const T c2 = a > T(1e-4) ? (a - std::sin(a)) / a : a * a / T(6);
      step = (e3 + c1 * w.cross(e3) + c2 * w.cross(w.cross(e3))) * (stretch * len);
    }
    pos += rot * step;
    rot = (rot * turn).normalized();
    out[k + 1] = pos.template cast<double>();
  }
}

// A helix of the rectum's rest strains (κ = 8 /m, τ = −1.12 /m, 5 % stretch), 1.66 m.
void helix(int n, std::vector<double>& h, std::vector<double>& q) {
  h.assign(static_cast<std::size_t>(n - 1), 1.66 / (n - 1));
  q.assign(4 * static_cast<std::size_t>(n), 0.0);
  for (int k = 0; k < n; ++k) {
    q[4 * static_cast<std::size_t>(k) + 1] = 8.0;
    q[4 * static_cast<std::size_t>(k) + 2] = -1.124327;
    q[4 * static_cast<std::size_t>(k) + 3] = 0.05;
  }
}

template <class F>
double time_us(F f, int repeats) {
  std::vector<double> t;
  for (int i = 0; i < repeats; ++i) {
    const auto a = Clock::now();
    f();
    t.push_back(std::chrono::duration<double, std::micro>(Clock::now() - a).count());
  }
  return median(t);
}

std::vector<Eigen::Vector3d> engine_sweep(std::span<const double> h, std::span<const double> q, bool reference) {
  const std::size_t n = h.size() + 1;
  std::vector<double> b(n * 14);
  auto col = [&](std::size_t i) { return std::span<double>(b.data() + i * n, n); };
  kernels::RodPoses<double> poses{{col(0), col(1), col(2)},
                                  {col(3), col(4), col(5), col(6)},
                                  {col(7), col(8), col(9)},
                                  {col(10), col(11), col(12), col(13)}};
  const kernels::StrainView<const double> strain{q};
  if (reference)
    kernels::rod_forward_sweep_reference({}, h, strain, poses);
  else
    kernels::rod_forward_sweep({}, h, strain, poses);
  std::vector<Eigen::Vector3d> out(n);
  for (std::size_t k = 0; k < n; ++k) out[k] = poses.node_position.get(k);
  return out;
}

// The measured frame of the 0.2 m rod at rest with N nodes (default solver: one forward sweep a
// frame): what a sweep's change is added to.
double rod_frame_us(int n) {
  auto w = World::create(cantilever(n));
  for (int f = 0; f < 40; ++f) w->step();
  return frame_cost(*w, 30);
}

}  // namespace

TradeoffKnob knob_precision() {
  TradeoffKnob k{"float against double in the rod's reconstruction",
                 "the forward sweep (strains → poses) of a 1.66 m helix with the rectum's rest strains; the same "
                 "study code instantiated in float and double; the Newton solve stays in double (not built in float). "
                 "Frame: the 0.2 m rod's measured frame at this N with the sweep's time exchanged (one sweep a frame)",
                 "the engine's double sweep (`kernels/rod_forward_sweep`)",
                 "max node error (µm)",
                 "frame (µs), estimated",
                 {},
                 100};
  for (int n : {167, 10'000}) {
    std::vector<double> h, q;
    helix(n, h, q);
    const std::vector<Eigen::Vector3d> exact = engine_sweep(h, q, false);
    std::vector<Eigen::Vector3d> out(static_cast<std::size_t>(n));
    const int repeats = n > 1000 ? 50 : 2000;
    const double engine_us = time_us([&] { (void)engine_sweep(h, q, false); }, repeats);
    const double frame_us = rod_frame_us(n);
    TradeoffRow e;
    e.setting = fmt::format("double, engine kernel, N = {}", n);
    e.cost_us = frame_us;
    e.details = fmt::format("the rod's measured frame; sweep {:.1f} µs (with the study's buffer set-up)", engine_us);
    e.is_default = true;
    e.is_reference = true;
    k.rows.push_back(e);
    for (int precision = 0; precision < 2; ++precision) {
      TradeoffRow r;
      r.setting = fmt::format("{}, study sweep, N = {}", precision == 0 ? "double" : "float", n);
      if (precision == 0) {
        sweep<double>(h, q, false, out);
        r.cost_us = time_us([&] { sweep<double>(h, q, false, out); }, repeats);
      } else {
        sweep<float>(h, q, false, out);
        r.cost_us = time_us([&] { sweep<float>(h, q, false, out); }, repeats);
      }
      r.error = 1e6 * max_distance(out, exact);
      r.details = fmt::format("sweep {:.1f} µs", r.cost_us);
      r.cost_us = frame_us - engine_us + r.cost_us;
      k.rows.push_back(r);
    }
  }
  return k;
}

TradeoffKnob knob_integrator() {
  TradeoffKnob k{"SE(3) exponential against midpoint reconstruction",
                 "the forward sweep of the 1.66 m helix (κ = 8 /m, τ = −1.12 /m, ε = 5 %), N nodes. Frame: the 0.2 m "
                 "rod's measured frame at this N with the sweep's time exchanged (one sweep a frame)",
                 "the matrix exponential of each section's twist (`rod_forward_sweep_reference`): the exact helix",
                 "tip error (mm)",
                 "frame (µs), estimated",
                 {},
                 1};
  for (int n : {21, 41, 83, 167, 333, 667}) {
    std::vector<double> h, q;
    helix(n, h, q);
    const double frame_us = rod_frame_us(n);
    const double engine_us = time_us([&] { (void)engine_sweep(h, q, false); }, 2000);
    const Eigen::Vector3d exact = engine_sweep(h, q, true).back();
    std::vector<Eigen::Vector3d> out(static_cast<std::size_t>(n));
    for (int midpoint = 0; midpoint < 2; ++midpoint) {
      TradeoffRow r;
      r.setting = fmt::format("{}, N = {}", midpoint != 0 ? "midpoint" : "exponential", n);
      if (midpoint == 0) {
        const std::vector<Eigen::Vector3d> engine = engine_sweep(h, q, false);
        r.error = 1e3 * (engine.back() - exact).norm();
        r.cost_us = frame_us;
        r.details = fmt::format("the engine's kernel: the rod's measured frame; sweep {:.1f} µs", engine_us);
        r.is_default = n == 167;
      } else {
        sweep<double>(h, q, true, out);
        r.error = 1e3 * (out.back() - exact).norm();
        const double sweep_us = time_us([&] { sweep<double>(h, q, true, out); }, 2000);
        r.cost_us = frame_us - engine_us + sweep_us;
        r.details = fmt::format("study code; sweep {:.1f} µs", sweep_us);
      }
      k.rows.push_back(r);
    }
  }
  return k;
}

}  // namespace haustra::validation::tradeoff
