// Google Benchmark: the broad phase (brute force, grid) and the narrow phase alone,
// from the paper's 55 beads to 100,000, at constant bead density. The counter "time/bead" is the
// cost per bead: flat for the grid and the narrow phase, linear in the count for brute force
// (quadratic in total). Compare within one run: this machine is shared and noisy.
//
// The beads form bowel-like chains: 55 beads of radius 1 cm, 1.5 cm apart along a smooth random
// walk (neighbours overlap, as on a real segment), folded into a cube whose volume grows with the
// count, (4 cm)³ per bead, so every bead has a similar number of neighbours at every size.
//
// Each iteration takes the next of several configurations (20,000 beads' worth in all): timed on
// one configuration over and over, a small set is learnt by the branch predictor and looks twice
// as fast as it is inside a frame, where the solver runs between two collision passes.
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "haustra/kernels/broad_phase.hpp"
#include "haustra/kernels/contact_geometry.hpp"

namespace {

using namespace haustra::kernels;

constexpr double kRadius = 0.01;
constexpr double kSpacing = 0.015;
constexpr double kMargin = 0.005;
constexpr std::size_t kChain = 55;

struct Beads {
  std::vector<double> x, y, z, r;
  [[nodiscard]] SphereSet set() const { return {x, y, z, r}; }
  [[nodiscard]] std::size_t size() const { return x.size(); }
};

Beads chains(std::size_t count, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> turn(0.0, 0.35);
  const double side = 0.04 * std::cbrt(static_cast<double>(count));
  Beads b;
  Eigen::Vector3d p = Eigen::Vector3d::Zero(), dir = Eigen::Vector3d::UnitX();
  for (std::size_t i = 0; i < count; ++i) {
    if (i % kChain == 0) {  // a new chain somewhere in the cube
      p = Eigen::Vector3d(u(rng), u(rng), u(rng)) * side;
      dir = Eigen::Vector3d(turn(rng), turn(rng), turn(rng)).normalized();
    } else {
      dir = (dir + Eigen::Vector3d(turn(rng), turn(rng), turn(rng))).normalized();
      p += kSpacing * dir;
      for (int a = 0; a < 3; ++a)  // reflect off the walls
        if (p[a] < 0.0 || p[a] > side) {
          p[a] = std::clamp(p[a], 0.0, side);
          dir[a] = -dir[a];
        }
    }
    b.x.push_back(p.x());
    b.y.push_back(p.y());
    b.z.push_back(p.z());
    b.r.push_back(kRadius);
  }
  return b;
}

std::vector<Beads> configurations(std::size_t count) {
  const std::size_t k = std::max<std::size_t>(1, 20000 / count);
  std::vector<Beads> all;
  for (std::size_t i = 0; i < k; ++i) all.push_back(chains(count, static_cast<std::uint32_t>(count + 7919 * i)));
  return all;
}

void per_bead(benchmark::State& state, std::size_t beads, std::size_t pairs) {
  state.counters["time/bead"] = benchmark::Counter(
      static_cast<double>(beads), benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.counters["pairs/bead"] = static_cast<double>(pairs) / static_cast<double>(beads);
}

// Runs `method` once with a generous buffer, then times it with the buffer sized.
template <class Method>
void run(benchmark::State& state, Method method) {
  const std::vector<Beads> all = configurations(static_cast<std::size_t>(state.range(0)));
  std::vector<SpherePair> out(8 * all[0].size());
  std::size_t pairs = 0;
  for (const Beads& b : all) {
    const std::size_t n = method(b, out);
    if (n > out.size()) out.resize(n);
    pairs += method(b, out);
  }
  std::size_t next = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(method(all[next], out));
    next = next + 1 == all.size() ? 0 : next + 1;
  }
  per_bead(state, all[0].size(), pairs / all.size());
}

void BM_BroadPhaseBrute(benchmark::State& state) {
  run(state, [](const Beads& b, std::span<SpherePair> out) { return broad_phase_brute(b.set(), kMargin, out); });
}

void BM_BroadPhaseGrid(benchmark::State& state) {
  SphereGrid grid;
  run(state, [&](const Beads& b, std::span<SpherePair> out) {
    grid.build(b.set(), kMargin);
    return grid.query(b.set(), 0, b.size(), out);
  });
}

// The narrow phase over the broad phase's pairs: overlap, separating direction and the paper's
// penalty, summed into per-bead forces.
void BM_NarrowPhase(benchmark::State& state) {
  const std::vector<Beads> all = configurations(static_cast<std::size_t>(state.range(0)));
  std::vector<std::vector<SpherePair>> pair_sets;
  std::size_t total = 0;
  for (const Beads& b : all) {
    SphereGrid grid;
    grid.build(b.set(), kMargin);
    std::vector<SpherePair> pairs(8 * b.size());
    std::size_t n = grid.query(b.set(), 0, b.size(), pairs);
    if (n > pairs.size()) {
      pairs.resize(n);
      n = grid.query(b.set(), 0, b.size(), pairs);
    }
    pairs.resize(n);
    total += n;
    pair_sets.push_back(std::move(pairs));
  }
  const std::size_t count = all[0].size();
  std::vector<double> fx(count), fy(count), fz(count);
  const double coefficient_times_e = 50.0 * 33.2e3;
  std::size_t next = 0;
  for (auto _ : state) {
    const Beads& b = all[next];
    const std::vector<SpherePair>& pairs = pair_sets[next];
    next = next + 1 == all.size() ? 0 : next + 1;
    std::fill(fx.begin(), fx.end(), 0.0);
    std::fill(fy.begin(), fy.end(), 0.0);
    std::fill(fz.begin(), fz.end(), 0.0);
    for (const SpherePair& p : pairs) {
      const SphereContact c =
          sphere_sphere({b.x[p.a], b.y[p.a], b.z[p.a]}, b.r[p.a], {b.x[p.b], b.y[p.b], b.z[p.b]}, b.r[p.b]);
      if (c.depth <= 0.0) continue;
      const Eigen::Vector3d f = contact_penalty(c.depth, coefficient_times_e, 2.0).force * c.normal;
      fx[p.a] += f.x();
      fy[p.a] += f.y();
      fz[p.a] += f.z();
      fx[p.b] -= f.x();
      fy[p.b] -= f.y();
      fz[p.b] -= f.z();
    }
    benchmark::DoNotOptimize(fx.data());
  }
  per_bead(state, count, total / all.size());
}

void counts(benchmark::internal::Benchmark* b, long long largest) {
  for (long long n : {55LL, 220LL, 1000LL, 5000LL, 20000LL, 100000LL})
    if (n <= largest) b->Arg(n);
  b->Unit(benchmark::kMicrosecond);
}

}  // namespace

// Brute force stops at 20,000 beads (2·10⁸ pair tests a call): its trend is plain by then.
BENCHMARK(BM_BroadPhaseBrute)->Apply([](benchmark::internal::Benchmark* b) { counts(b, 20000); });
BENCHMARK(BM_BroadPhaseGrid)->Apply([](benchmark::internal::Benchmark* b) { counts(b, 100000); });
BENCHMARK(BM_NarrowPhase)->Apply([](benchmark::internal::Benchmark* b) { counts(b, 100000); });

BENCHMARK_MAIN();
