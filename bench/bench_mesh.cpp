// Google Benchmark: skinning the organ mesh (the rigid-group kernel and its scalar reference) from
// 10,000 to 1,000,000 vertices beside a STREAM triad in the same run, so that bytes per second can
// be set against what this machine streams; and whole frames of `drop` with one part of the model switched off at a
// time.
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <random>
#include <vector>

#include "haustra/kernels/cage_rings.hpp"
#include "haustra/kernels/mesh_normals.hpp"
#include "haustra/kernels/skinning.hpp"
#include "haustra/scene.hpp"
#include "haustra/world.hpp"
#include "model/skin_binding.hpp"
#include "model/world_model.hpp"
#include "segment_rows.hpp"

namespace {

using namespace haustra;
using namespace haustra::kernels;

constexpr std::size_t kSlots = 4;

// Bytes one skinned vertex moves: rest position, output index, K rings' 4 coefficients (and the
// ring index shared by 8 lanes), the written position.
constexpr double kBytesPerVertex = 12.0 + 4.0 + kSlots * 16.0 + kSlots * 4.0 / 8.0 + 12.0;

struct Binding {
  std::vector<float> rx, ry, rz, coef, delta, ox, oy, oz;
  std::vector<std::uint32_t> vertex, ring, slot_start;
  std::size_t blocks;
  explicit Binding(std::size_t vertices) : blocks((vertices + kSkinLanes - 1) / kSkinLanes) {
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    const std::size_t rings = 109;  // the CT colon's cage
    rx.resize(blocks * kSkinLanes);
    ry.resize(rx.size());
    rz.resize(rx.size());
    ox.resize(rx.size());
    oy.resize(rx.size());
    oz.resize(rx.size());
    vertex.resize(rx.size());
    for (std::size_t i = 0; i < rx.size(); ++i) {
      rx[i] = u(rng);
      ry[i] = u(rng);
      rz[i] = u(rng);
      vertex[i] = static_cast<std::uint32_t>(i);  // vertices in ring-set order, as the binding packs them
    }
    coef.resize(blocks * kSlots * kSkinCoefficients * kSkinLanes);
    for (auto& c : coef) c = 0.25f * u(rng);
    ring.resize(blocks * kSlots);
    for (std::size_t b = 0; b < blocks; ++b)
      for (std::size_t s = 0; s < kSlots; ++s)
        ring[b * kSlots + s] = static_cast<std::uint32_t>((b * rings / blocks + s) % rings);
    for (std::size_t b = 0; b <= blocks; ++b) slot_start.push_back(static_cast<std::uint32_t>(b * kSlots));
    delta.resize(kRingDeltaFloats * rings);
    for (auto& d : delta) d = 0.01f * u(rng);
  }
  [[nodiscard]] SkinBindingView view() const { return {slot_start, rx, ry, rz, vertex, ring, coef}; }
};

void counters(benchmark::State& state, double vertices) {
  state.counters["vertices/s"] =
      benchmark::Counter(vertices * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["bytes/s"] = benchmark::Counter(kBytesPerVertex * vertices * static_cast<double>(state.iterations()),
                                                 benchmark::Counter::kIsRate);
}

void BM_SkinRigidGroups(benchmark::State& state) {
  Binding b(static_cast<std::size_t>(state.range(0)));
  for (auto _ : state) {
    skin_rigid_groups(b.view(), b.delta, 0, b.blocks, {b.ox, b.oy, b.oz});
    benchmark::DoNotOptimize(b.ox.data());
    benchmark::ClobberMemory();
  }
  counters(state, static_cast<double>(state.range(0)));
}

void BM_SkinScalarReference(benchmark::State& state) {
  Binding b(static_cast<std::size_t>(state.range(0)));
  for (auto _ : state) {
    skin_rigid_groups_reference(b.view(), b.delta, {b.ox, b.oy, b.oz});
    benchmark::DoNotOptimize(b.ox.data());
    benchmark::ClobberMemory();
  }
  counters(state, static_cast<double>(state.range(0)));
}

// A tube of `vertices` (1,000 around and as many rings as it takes), two triangles per quad: the
// layout a procedural organ has (ring by ring), for the normals stage.
struct Tube {
  std::vector<float> x, y, z, nx, ny, nz;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<std::uint32_t> corner_start, corner_pairs;
  explicit Tube(std::size_t vertices) {
    const std::size_t around = std::min<std::size_t>(1000, vertices / 10), rings = vertices / around;
    for (std::size_t r = 0; r < rings; ++r)
      for (std::size_t a = 0; a < around; ++a) {
        const double t = 2.0 * 3.141592653589793 * static_cast<double>(a) / static_cast<double>(around);
        x.push_back(static_cast<float>(0.02 * std::cos(t)));
        y.push_back(static_cast<float>(0.02 * std::sin(t) + 0.001 * std::sin(0.1 * static_cast<double>(r))));
        z.push_back(static_cast<float>(0.001 * static_cast<double>(r)));
      }
    auto at = [&](std::size_t r, std::size_t a) { return static_cast<std::uint32_t>(r * around + a % around); };
    for (std::size_t r = 0; r + 1 < rings; ++r)
      for (std::size_t a = 0; a < around; ++a) {
        triangles.push_back({at(r, a), at(r, a + 1), at(r + 1, a)});
        triangles.push_back({at(r, a + 1), at(r + 1, a + 1), at(r + 1, a)});
      }
    nx.resize(x.size());
    ny.resize(x.size());
    nz.resize(x.size());
    corner_start.resize(x.size() + 1);
    corner_pairs.resize(6 * triangles.size());
    vertex_corner_pairs(triangles, x.size(), corner_start, corner_pairs);
    append_normal_blocks(corner_start, corner_pairs, 0, x.size(), slot_start, slots, gather_pairs);
  }
  std::vector<std::uint32_t> slot_start, gather_pairs;
  std::vector<NormalSlot> slots;
  [[nodiscard]] NormalBlocksView blocks() const { return {slot_start, slots, gather_pairs}; }
};

// The normals stage's kernel: 8 vertices at a time over their corner-pair slots. Bytes per vertex:
// its position and its normal, its block's slot records (12 B each) and gathered pairs shared by 8
// (the neighbours' positions are the ring's and the next ring's, in cache).
void BM_Normals(benchmark::State& state) {
  Tube t(static_cast<std::size_t>(state.range(0)));
  const double n = static_cast<double>(t.x.size());
  const double bytes =
      24.0 + (12.0 * static_cast<double>(t.slots.size()) + 4.0 * static_cast<double>(t.gather_pairs.size()) +
              4.0 * static_cast<double>(t.slot_start.size())) /
                 n;
  for (auto _ : state) {
    vertex_normals_blocked(t.blocks(), 0, t.corner_start, t.corner_pairs, t.x, t.y, t.z, 0, t.x.size(),
                           {t.nx, t.ny, t.nz});
    benchmark::DoNotOptimize(t.nx.data());
    benchmark::ClobberMemory();
  }
  state.counters["vertices/s"] =
      benchmark::Counter(n * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["bytes/s"] =
      benchmark::Counter(bytes * n * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

// The same sums one vertex at a time (the blocked form's tail).
void BM_NormalsByVertex(benchmark::State& state) {
  Tube t(static_cast<std::size_t>(state.range(0)));
  const double n = static_cast<double>(t.x.size());
  for (auto _ : state) {
    vertex_normals(t.corner_start, t.corner_pairs, t.x, t.y, t.z, 0, t.x.size(), {t.nx, t.ny, t.nz});
    benchmark::DoNotOptimize(t.nx.data());
    benchmark::ClobberMemory();
  }
  state.counters["vertices/s"] =
      benchmark::Counter(n * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

// Its reference, the two passes the stage took before: every triangle's normal, then each
// vertex's sum of its triangles' (CSR).
void BM_NormalsTwoPassReference(benchmark::State& state) {
  Tube t(static_cast<std::size_t>(state.range(0)));
  const std::size_t n = t.x.size(), nt = t.triangles.size();
  std::vector<float> fx(nt), fy(nt), fz(nt);
  std::vector<std::uint32_t> start(n + 1, 0), tri;
  for (const auto& tr : t.triangles)
    for (std::uint32_t v : tr) ++start[v + 1];
  for (std::size_t v = 0; v < n; ++v) start[v + 1] += start[v];
  tri.resize(start.back());
  std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
  for (std::size_t i = 0; i < nt; ++i)
    for (std::uint32_t v : t.triangles[i]) tri[fill[v]++] = static_cast<std::uint32_t>(i);
  for (auto _ : state) {
    face_normals_reference(t.triangles, t.x, t.y, t.z, 0, nt, {fx, fy, fz});
    vertex_normals_reference(start, tri, fx, fy, fz, 0, n, {t.nx, t.ny, t.nz});
    benchmark::DoNotOptimize(t.nx.data());
    benchmark::ClobberMemory();
  }
  state.counters["vertices/s"] =
      benchmark::Counter(static_cast<double>(n) * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

// STREAM triad over float arrays: the machine's streaming bandwidth, measured in the same run.
void BM_StreamTriad(benchmark::State& state) {
  const auto n = static_cast<std::size_t>(state.range(0));
  std::vector<float> a(n, 0.0f), b(n, 1.0f), c(n, 2.0f);
  const float s = 0.5f;
  for (auto _ : state) {
    for (std::size_t i = 0; i < n; ++i) a[i] = b[i] + s * c[i];
    benchmark::DoNotOptimize(a.data());
    benchmark::ClobberMemory();
  }
  state.counters["bytes/s"] = benchmark::Counter(
      12.0 * static_cast<double>(n) * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

// A dense cage: one piece of the small intestine at 2 mm sections (51 nodes, 26 beads over 10 cm,
// radius 12.5 mm, 50,000 vertices), bound with fixed K = 4 (arg 0) and with the scene's
// `skinning = "cage"` (decision 0048's rule, arg 1), skinned on one thread; the ratio of the two
// rows of one run is what the cage costs per vertex against 4 rings.
void BM_SkinDenseCage(benchmark::State& state) {
  struct Bound {
    detail::SkinBinding fixed, chosen;
    std::size_t rings = 0, vertices = 0;
  };
  static const Bound bound = [] {
    WorldDesc d;
    d.threads = 1;
    SegmentDesc s;
    s.nodes = 51;
    s.rest.length = 0.1;
    s.cross_section.radius = 0.0125;
    s.beads.enabled = true;
    s.beads.count = 26;
    s.beads.radius = 0.0125;
    s.mesh.enabled = true;
    s.mesh.procedural.vertices = 50'000;
    s.mesh.cage.ring_vertices = 12;
    s.mesh.skinning = SkinningMethod::cage;
    d.segments.push_back(s);
    const detail::WorldModel m = detail::build_world_model(d);
    const detail::SegmentMesh& mesh = m.meshes_of[0];
    Bound b;
    SkinReport report;
    TriangleMesh rest;  // where the vertices are does not change the rings they keep, nor the cost
    for (const auto& v : mesh.cage.mesh_binding) rest.vertices.push_back(v);
    b.fixed = detail::bind_mean_value(mesh.cage, rest, 4, 0.0, report);
    b.chosen = mesh.binding;
    b.rings = mesh.cage.ring_station.size();
    b.vertices = mesh.binding.vertices;
    return b;
  }();
  const detail::SkinBinding& binding = state.range(0) == 0 ? bound.fixed : bound.chosen;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-0.01f, 0.01f);
  std::vector<float> delta(kRingDeltaFloats * bound.rings);
  for (auto& x : delta) x = u(rng);
  std::vector<float> ox(bound.vertices), oy(bound.vertices), oz(bound.vertices);
  for (auto _ : state) {
    skin_rigid_groups(binding.view(), delta, 0, binding.blocks(), {ox, oy, oz});
    benchmark::ClobberMemory();
  }
  state.SetLabel(state.range(0) == 0 ? "K = 4" : "at most 7 rings (decision 0083)");
  state.counters["slots/vertex"] =
      static_cast<double>(binding.slot_start.back()) * kSkinLanes / static_cast<double>(bound.vertices);
  state.counters["vertices/s"] = benchmark::Counter(
      static_cast<double>(bound.vertices) * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

// What each optional stage costs (issue 6: a scene models only what it needs): `drop` with its
// 10,000-vertex organ mesh, then with one thing switched off. Arg: which. The difference to "all"
// is what that part of the model costs per frame.
void BM_StageCost(benchmark::State& state) {
  static const std::vector<std::vector<std::string>> variants = {
      {"segment.mesh.source=procedural"},                          // 0: all
      {},                                                          // 1: no mesh
      {"segment.mesh.source=procedural", "contact.self=false"},    // 2: no self-contact
      {"segment.mesh.source=procedural", "filter.enabled=false"},  // 3: no inertia filter
      {"segment.mesh.source=procedural", "segment.law.bending=elastic", "segment.law.torsion=elastic"},  // 4: elastic
  };
  const auto which = static_cast<std::size_t>(state.range(0));
  SceneDesc scene = load_scene(std::string(HAUSTRA_SOURCE_DIR) + "/scenes/drop.toml", variants[which]);
  scene.world.threads = 1;
  std::unique_ptr<World> w = create_world(scene);
  for (int f = 0; f < 60; ++f) w->step();
  for (auto _ : state) w->step();
  static const char* const names[] = {"all", "no mesh", "no self-contact", "no filter", "elastic"};
  state.SetLabel(names[which]);
}

// Issue 5's many-segment target: `BM_Segments`' rows with a 10,000-vertex procedural organ on
// each rod. Args: segments, threads.
void BM_SegmentsWithMesh(benchmark::State& state) {
  const WorldDesc d =
      bench::segment_rows(static_cast<std::size_t>(state.range(0)), static_cast<int>(state.range(1)), 10'000);
  auto w = World::create(d);
  for (int f = 0; f < 3; ++f) w->step();
  for (auto _ : state) w->step();
  const double frames = static_cast<double>(state.iterations());
  state.counters["nodes/s"] =
      benchmark::Counter(static_cast<double>(w->node_count()) * frames, benchmark::Counter::kIsRate);
  state.counters["vertices/s"] =
      benchmark::Counter(static_cast<double>(w->mesh_buffer_size()) * frames, benchmark::Counter::kIsRate);
}

}  // namespace

BENCHMARK(BM_SegmentsWithMesh)
    ->ArgsProduct({{1, 16, 64}, {1, 2}})
    ->ArgNames({"segments", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(1.0)
    ->UseRealTime();
BENCHMARK(BM_StageCost)->DenseRange(0, 4)->Unit(benchmark::kMicrosecond)->Iterations(150);
BENCHMARK(BM_SkinDenseCage)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SkinRigidGroups)->Arg(10'000)->Arg(100'000)->Arg(1'000'000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SkinScalarReference)->Arg(10'000)->Arg(1'000'000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Normals)->Arg(10'000)->Arg(100'000)->Arg(1'000'000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_NormalsByVertex)->Arg(10'000)->Arg(1'000'000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_NormalsTwoPassReference)->Arg(10'000)->Arg(1'000'000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_StreamTriad)->Arg(1'000'000)->Arg(10'000'000)->Unit(benchmark::kMicrosecond);
BENCHMARK_MAIN();
