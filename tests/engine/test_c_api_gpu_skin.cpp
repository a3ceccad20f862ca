// Skinning on the host's GPU through the C API (decisions 0110, 0122): the binding's buffers and a
// frame's ring data give the library's own mesh by the shader's sum (along the rod: its screws; a
// host before ABI 17: the linear form); a double-buffered world whose host skins on its GPU hands
// the render thread rings, not a mesh; refusals name their field.
#include <doctest/doctest.h>
#include <haustra/haustra.h>

#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "c_sized.hpp"
#include "gpu_skin_sum.hpp"

using haustra::test::shader_sum;

namespace {

bool gpu_says(const char* words) { return std::strstr(haustra_last_error(), words) != nullptr; }

// The largest distance of the shader's sum from the library's mesh, and how far the mesh moved.
std::pair<double, double> sum_against_mesh(haustra_world* w, const haustra_gpu_skin& g,
                                           const std::vector<float>& rings) {
  haustra_vec3f_view p;
  REQUIRE(haustra_world_mesh_positions(w, &p) == HAUSTRA_OK);
  REQUIRE(p.count == g.vertices);
  double worst = 0.0, moved = 0.0;
  for (size_t v = 0; v < g.vertices; ++v) {
    double x[3];
    shader_sum(g, rings, v, x);
    worst = std::max(worst, std::hypot(x[0] - p.x[v], x[1] - p.y[v], x[2] - p.z[v]));
    moved = std::max(moved, double(std::hypot(p.x[v] - g.rest_positions[3 * v], p.y[v] - g.rest_positions[3 * v + 1],
                                              p.z[v] - g.rest_positions[3 * v + 2])));
  }
  return {worst, moved};
}

// A chain of four pieces with procedural meshes, held at its base and sagging (as test_c_api.cpp's).
haustra_world* sagging_chain(int double_buffered, int on_gpu, int skinning = 0) {
  haustra_world_def def;
  REQUIRE(haustra_world_def_default(&def) == HAUSTRA_OK);
  CHECK(def.mesh_on_host_gpu == 0);
  def.threads = 1;
  def.floor = 1;
  def.floor_height = -0.5;
  def.double_buffered = double_buffered;
  def.mesh_on_host_gpu = on_gpu;
  haustra_segment_def chain;
  REQUIRE(haustra_segment_def_default(&chain) == HAUSTRA_OK);
  chain.nodes = 11;
  chain.chain_pieces = 4;
  chain.length = 0.4;
  chain.beads = 6;
  chain.mesh = 1;
  chain.mesh_vertices = 1000;
  chain.skinning = skinning;
  haustra_world* w = nullptr;
  REQUIRE(haustra_world_create(&def, &chain, 1, &w) == HAUSTRA_OK);
  for (int f = 0; f < 30; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  return w;
}

}  // namespace

TEST_CASE("C API: the GPU binding and a frame's rings give the library's mesh to 1e-6 m") {
  haustra_world* w = sagging_chain(0, 0);
  haustra_counts counts = sized<haustra_counts>();
  REQUIRE(haustra_world_counts(w, &counts) == HAUSTRA_OK);
  haustra_gpu_skin g = sized<haustra_gpu_skin>();
  REQUIRE(haustra_world_gpu_skin(w, &g) == HAUSTRA_OK);
  CHECK(g.vertices == counts.mesh_vertices);
  CHECK(g.rings > 0);
  CHECK(g.slots >= 4 * g.vertices);  // the cage (skinning 0): at least 4 rings each
  CHECK(g.max_slots >= 4);
  CHECK(g.ring_data_floats == 2 * HAUSTRA_GPU_RING_FLOATS * g.rings);
  std::vector<float> rings(g.ring_data_floats);
  CHECK(haustra_world_gpu_rings(w, rings.data(), rings.size() - 1) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(gpu_says("count"));
  REQUIRE(haustra_world_gpu_rings(w, rings.data(), rings.size()) == HAUSTRA_OK);
  const auto [worst, moved] = sum_against_mesh(w, g, rings);
  MESSAGE("the sagging chain moved up to " << moved << " m; the sum is " << worst << " m from the library's mesh");
  CHECK(moved > 0.02);
  CHECK(worst <= 1e-6);
  // Unit rest normals, and every slot's ring in range.
  for (size_t v = 0; v < g.vertices; ++v)
    CHECK(std::hypot(g.rest_normals[3 * v], g.rest_normals[3 * v + 1], g.rest_normals[3 * v + 2]) ==
          doctest::Approx(1.0).epsilon(1e-5));
  size_t bad = 0;
  for (size_t s = 0; s < g.slots; ++s) bad += g.slot_rings[s] >= g.rings ? 1 : 0;
  CHECK(bad == 0);
  REQUIRE(haustra_world_destroy(w) == HAUSTRA_OK);
}

// Decisions 0117, 0122 through the C API: the skin along the rod, each vertex on the screw between
// the rod's frames either side of its place; a host of ABI 16 (its smaller haustra_gpu_skin) gets
// the linear rigid-group form it knows, and the rings' rows alone.
TEST_CASE("C API: skinning = 1 (along the rod): a screw a vertex, the shader's sum is the library's mesh") {
  haustra_world* w = sagging_chain(0, 0, 1);
  haustra_gpu_skin g = sized<haustra_gpu_skin>();
  REQUIRE(haustra_world_gpu_skin(w, &g) == HAUSTRA_OK);
  CHECK(g.max_slots == 2);  // a screw takes two slots (procedural pieces: no vertex on a cut)
  CHECK(g.slots == 2 * g.vertices);
  std::vector<float> rings(g.ring_data_floats);
  REQUIRE(haustra_world_gpu_rings(w, rings.data(), rings.size()) == HAUSTRA_OK);
  // Given the screws, the rows alone would leave the shader reading past the host's buffer: refused.
  CHECK(haustra_world_gpu_rings(w, rings.data(), rings.size() / 2) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(gpu_says("gave this host the along-rod screws"));
  const auto [worst, moved] = sum_against_mesh(w, g, rings);
  MESSAGE("along the rod: moved up to " << moved << " m; the sum is " << worst << " m from the library's mesh");
  CHECK(moved > 0.02);
  CHECK(worst <= 1e-6);

  haustra_gpu_skin old = sized<haustra_gpu_skin>();
  old.struct_size = offsetof(haustra_gpu_skin, ring_data_floats);  // ABI 16's
  REQUIRE(haustra_world_gpu_skin(w, &old) == HAUSTRA_OK);
  CHECK(old.max_slots == 2);  // its two stations
  size_t screws = 0;
  for (size_t s = 0; s < old.slots; ++s) screws += (old.slot_rings[s] & HAUSTRA_GPU_SCREW_SLOT) != 0 ? 1 : 0;
  CHECK(screws == 0);
  std::vector<float> rows(HAUSTRA_GPU_RING_FLOATS * old.rings);
  REQUIRE(haustra_world_gpu_rings(w, rows.data(), rows.size()) == HAUSTRA_OK);  // the rows alone
  CHECK(std::memcmp(rows.data(), rings.data(), rows.size() * sizeof(float)) == 0);
  const auto [linear, moved_too] = sum_against_mesh(w, old, rows);
  MESSAGE("a host of ABI 16 (linear along the stations): " << linear << " m from the library's screws");
  CHECK(moved_too == moved);
  CHECK(linear > 1e-6);  // not the screws (measured 1.06e-4 m)
  CHECK(linear <= 1e-3);
  REQUIRE(haustra_world_destroy(w) == HAUSTRA_OK);

  haustra_world_def def;
  REQUIRE(haustra_world_def_default(&def) == HAUSTRA_OK);
  haustra_segment_def seg;
  REQUIRE(haustra_segment_def_default(&seg) == HAUSTRA_OK);
  CHECK(seg.skinning == 1);  // along the rod, the default since ABI 17 (decision 0120)
  seg.mesh = 1;
  seg.beads = 4;
  seg.skinning = 4;
  haustra_world* none = nullptr;
  CHECK(haustra_world_create(&def, &seg, 1, &none) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(
      gpu_says("skinning = 4: expected 1 (along the rod), 0 (the cage), 2 (the cage, every ring) or 3 (linear blend)"));
  CHECK(none == nullptr);
}

TEST_CASE("C API: a double-buffered world whose host skins on its GPU hands the render thread rings") {
  haustra_world* w = sagging_chain(1, 1);
  haustra_gpu_skin g = sized<haustra_gpu_skin>();
  REQUIRE(haustra_world_gpu_skin(w, &g) == HAUSTRA_OK);
  std::vector<float> rings(g.ring_data_floats);
  REQUIRE(haustra_world_gpu_rings(w, rings.data(), rings.size()) == HAUSTRA_OK);
  haustra_frame fr = sized<haustra_frame>();
  REQUIRE(haustra_world_acquire_frame(w, &fr) == HAUSTRA_OK);  // lockstep: the frame just stepped
  CHECK(fr.frame == 30);
  CHECK(fr.mesh_positions.count == 0);  // nothing skinned on the CPU
  CHECK(fr.mesh_normals.count == 0);
  REQUIRE(fr.gpu_rings != nullptr);
  REQUIRE(fr.gpu_ring_count == g.rings);
  CHECK(std::memcmp(fr.gpu_rings, rings.data(), rings.size() * sizeof(float)) == 0);
  REQUIRE(haustra_world_release_frame(w) == HAUSTRA_OK);
  // A host built before ABI 15 passes the frame's older size: served, without the rings.
  haustra_frame old{};
  old.struct_size = offsetof(haustra_frame, gpu_rings);
  REQUIRE(haustra_world_acquire_frame(w, &old) == HAUSTRA_OK);
  CHECK(old.frame == 30);
  REQUIRE(haustra_world_release_frame(w) == HAUSTRA_OK);
  REQUIRE(haustra_world_destroy(w) == HAUSTRA_OK);

  // A render thread reading rings while the world steps: whole frames, finite, never a mesh.
  w = sagging_chain(1, 1);
  std::atomic<bool> stepping{true};
  std::atomic<int> reads{0}, bad{0};
  std::thread render([&, rings_expected = g.rings] {
    while (stepping.load() || reads.load() == 0) {
      haustra_frame f = sized<haustra_frame>();
      if (haustra_world_acquire_frame(w, &f) != HAUSTRA_OK) {
        bad += 1;
        continue;
      }
      bool ok = f.gpu_ring_count == rings_expected && f.mesh_positions.count == 0;
      for (size_t k = 0; ok && k < 2 * HAUSTRA_GPU_RING_FLOATS * f.gpu_ring_count; ++k)
        ok = std::isfinite(f.gpu_rings[k]);
      bad += ok ? 0 : 1;
      reads += 1;
      if (haustra_world_release_frame(w) != HAUSTRA_OK) bad += 1;
    }
  });
  for (int f = 0; f < 20; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  stepping = false;
  render.join();
  CHECK(reads.load() > 0);
  CHECK(bad.load() == 0);
  REQUIRE(haustra_world_destroy(w) == HAUSTRA_OK);

  // Without mesh_on_host_gpu the render thread gets the mesh and no rings.
  w = sagging_chain(1, 0);
  REQUIRE(haustra_world_acquire_frame(w, &fr) == HAUSTRA_OK);
  CHECK(fr.mesh_positions.count > 0);
  CHECK(fr.gpu_rings == nullptr);
  CHECK(fr.gpu_ring_count == 0);
  REQUIRE(haustra_world_release_frame(w) == HAUSTRA_OK);
  REQUIRE(haustra_world_destroy(w) == HAUSTRA_OK);
}

TEST_CASE("C API: mesh_on_host_gpu is checked, and a world_def without it (a shorter struct_size) reads it as 0") {
  haustra_world_def def;
  REQUIRE(haustra_world_def_default(&def) == HAUSTRA_OK);
  haustra_segment_def seg;
  REQUIRE(haustra_segment_def_default(&seg) == HAUSTRA_OK);
  seg.nodes = 11;
  haustra_world* w = nullptr;
  def.mesh_on_host_gpu = 2;
  CHECK(haustra_world_create(&def, &seg, 1, &w) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(gpu_says("def.mesh_on_host_gpu = 2"));
  def.mesh_on_host_gpu = 1;
  def.mesh_every_frame = 1;
  CHECK(haustra_world_create(&def, &seg, 1, &w) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(gpu_says("mesh_every_frame"));
  CHECK(w == nullptr);
  def.mesh_every_frame = 0;
  def.struct_size = offsetof(haustra_world_def, mesh_on_host_gpu);  // a def that ends before the field: it reads 0
  REQUIRE(haustra_world_create(&def, &seg, 1, &w) == HAUSTRA_OK);
  haustra_gpu_skin g = sized<haustra_gpu_skin>();
  REQUIRE(haustra_world_gpu_skin(w, &g) == HAUSTRA_OK);  // no mesh: empty, not an error
  CHECK(g.vertices == 0);
  CHECK(g.rings == 0);
  CHECK(haustra_world_gpu_rings(w, nullptr, 0) == HAUSTRA_OK);
  g.struct_size = 3;
  CHECK(haustra_world_gpu_skin(w, &g) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(gpu_says("out.struct_size = 3"));
  REQUIRE(haustra_world_destroy(w) == HAUSTRA_OK);
  CHECK(haustra_abi_version() == HAUSTRA_ABI_VERSION);
  CHECK(haustra_check_abi(14) == HAUSTRA_ABI_MISMATCH);  // ABI 15 also changed haustra_profile (decision 0108)
  CHECK(haustra_check_abi(15) == HAUSTRA_OK);            // ABI 16 added haustra_segment_def.skinning at its end
  CHECK(haustra_check_abi(16) == HAUSTRA_OK);  // ABI 17: the same segment def (0120), ring_data_floats added (0122)
}
