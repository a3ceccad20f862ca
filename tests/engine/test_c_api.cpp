// The C API, through its header only: every function, with good calls checked against what the
// scene implies and bad ones — wrong handles, NULL pointers, indices out of range, non-finite
// values, calls after destroy — each answered by its status and a message, none crashing.
#include <doctest/doctest.h>
#include <haustra/haustra.h>

#include "c_sized.hpp"

#include "host_job_pool.hpp"

#include <unistd.h>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <string>
#include <thread>
#include <vector>

namespace {

// A scene file of this process's own, removed at the end.
// A scene of tests/scenes/, by name.
struct TestScene {
  std::filesystem::path path;
  explicit TestScene(const char* name)
      : path(std::filesystem::path(HAUSTRA_SOURCE_DIR) / "tests" / "scenes" / (std::string(name) + ".toml")) {}
};

struct SceneFile {
  std::filesystem::path path;
  explicit SceneFile(const std::string& text)
      : path(std::filesystem::temp_directory_path() /
             ("haustra-c-api-" + std::to_string(::getpid()) + "-" + std::to_string(next_id()) + ".toml")) {
    std::ofstream(path) << text;
  }
  ~SceneFile() { std::filesystem::remove(path); }
  static int next_id() {
    static int id = 0;
    return ++id;
  }
};

bool says(const char* words) { return std::strstr(haustra_last_error(), words) != nullptr; }

// A straight clamped segment (the defaults otherwise) with beads and a procedural organ.
haustra_segment_def organ_def(const char* name, int nodes, double length, int beads, int mesh_vertices) {
  haustra_segment_def seg;
  REQUIRE(haustra_segment_def_default(&seg) == HAUSTRA_OK);
  seg.name = name;
  seg.nodes = nodes;
  seg.length = length;
  seg.beads = beads;
  seg.mesh = 1;
  seg.mesh_vertices = mesh_vertices;
  return seg;
}

}  // namespace

TEST_CASE("C API: version and ABI check") {
  CHECK(std::string(haustra_version()).find('.') != std::string::npos);
  CHECK(haustra_check_abi(HAUSTRA_ABI_VERSION) == HAUSTRA_OK);
  CHECK(std::string(haustra_last_error()).empty());
  CHECK(haustra_check_abi(HAUSTRA_ABI_VERSION + 1) == HAUSTRA_ABI_MISMATCH);
  CHECK(says("ABI 15"));
  CHECK(std::string(haustra_stage_name(0)) == "instruments");
  CHECK(haustra_stage_name(HAUSTRA_STAGE_COUNT - 1) != nullptr);
  CHECK(haustra_stage_name(HAUSTRA_STAGE_COUNT) == nullptr);
  CHECK(haustra_stage_name(-1) == nullptr);
}

// One case of ~90 lines on purpose: a host's whole session through the C API, in the order a host
// writes it.
TEST_CASE("C API: a world from a scene, stepped, read without copies, driven by the host") {
  const TestScene scene("c-api-colon");
  haustra_world* w = nullptr;
  REQUIRE(haustra_world_create_from_scene(scene.path.c_str(), 1, &w) == HAUSTRA_OK);
  REQUIRE(w != nullptr);

  haustra_counts c = sized<haustra_counts>();
  REQUIRE(haustra_world_counts(w, &c) == HAUSTRA_OK);
  CHECK(c.segments == 1);
  CHECK(c.nodes == 21);
  CHECK(c.beads == 8);
  CHECK(c.instruments == 1);
  CHECK(c.mesh_vertices > 1000);
  CHECK(c.mesh_triangles > 1000);

  haustra_vec3_view nodes{};
  REQUIRE(haustra_world_node_positions(w, &nodes) == HAUSTRA_OK);
  CHECK(nodes.count == 21);
  CHECK(nodes.x[20] == doctest::Approx(0.4).epsilon(1e-9));  // straight along x at rest
  const double* radii = nullptr;
  size_t bead_count = 0;
  REQUIRE(haustra_world_bead_radii(w, &radii, &bead_count) == HAUSTRA_OK);
  CHECK(bead_count == 8);
  CHECK(radii[0] == doctest::Approx(0.02));

  // A hanging cantilever: after some frames the tip is below the base, and the view seen before
  // the steps (same buffers) shows it.
  for (int f = 0; f < 30; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  haustra_vec3_view after{};
  REQUIRE(haustra_world_node_positions(w, &after) == HAUSTRA_OK);
  CHECK(after.x == nodes.x);  // the same buffer, not a copy
  CHECK(after.z[20] < -0.01);
  double t = 0.0;
  uint64_t frame = 0;
  REQUIRE(haustra_world_time(w, &t, &frame) == HAUSTRA_OK);
  CHECK(frame == 30);
  CHECK(t == doctest::Approx(0.3));

  haustra_vec3f_view mesh{}, normals{};
  haustra_triangles_view tris{};
  REQUIRE(haustra_world_mesh_positions(w, &mesh) == HAUSTRA_OK);
  REQUIRE(haustra_world_mesh_normals(w, &normals) == HAUSTRA_OK);
  REQUIRE(haustra_world_mesh_triangles(w, &tris) == HAUSTRA_OK);
  CHECK(mesh.count == c.mesh_vertices);
  CHECK(tris.count == c.mesh_triangles);
  float lowest = 1e9f;
  for (size_t v = 0; v < mesh.count; ++v) {
    REQUIRE(std::isfinite(mesh.z[v]));
    lowest = std::min(lowest, mesh.z[v]);
    const float n2 = normals.x[v] * normals.x[v] + normals.y[v] * normals.y[v] + normals.z[v] * normals.z[v];
    REQUIRE(n2 == doctest::Approx(1.0f).epsilon(1e-4));
  }
  CHECK(lowest < static_cast<float>(after.z[20]));  // the mesh sags with the rod
  for (size_t i = 0; i < 3 * tris.count; ++i) REQUIRE(tris.indices[i] < mesh.count);

  // The host grasps the tip and lifts it; the grasper reads the tissue's pull.
  const double tip[3] = {after.x[20], after.y[20], after.z[20] + 0.025};
  const double up[3] = {0.0, 0.0, 1.0};
  REQUIRE(haustra_world_set_instrument_pose(w, 0, tip, up) == HAUSTRA_OK);
  REQUIRE(haustra_world_set_instrument_grasp(w, 0, 1) == HAUSTRA_OK);
  REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  haustra_instrument_reading r = sized<haustra_instrument_reading>();
  REQUIRE(haustra_world_instrument(w, 0, &r) == HAUSTRA_OK);
  CHECK(r.closed == 1);
  CHECK(r.grasping == 1);
  CHECK(r.grasped_segment == 0);
  CHECK(r.grasped_node >= 18);
  const double lifted[3] = {tip[0], tip[1], tip[2] + 0.05};
  REQUIRE(haustra_world_set_instrument_pose(w, 0, lifted, up) == HAUSTRA_OK);
  for (int f = 0; f < 10; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  REQUIRE(haustra_world_instrument(w, 0, &r) == HAUSTRA_OK);
  CHECK(r.force[2] < 0.0);  // the rod's weight pulls the grasper down
  CHECK(r.tip[2] == doctest::Approx(lifted[2]));

  const double load[3] = {0.0, 0.0, 0.01}, none[3] = {0.0, 0.0, 0.0};
  CHECK(haustra_world_set_node_load(w, 10, load, none) == HAUSTRA_OK);
  haustra_profile p = sized<haustra_profile>();
  REQUIRE(haustra_world_profile(w, &p) == HAUSTRA_OK);
  CHECK(p.frame_seconds > 0.0);
  CHECK(p.substeps >= 1);
  double stages = 0.0;
  for (double s : p.stage_seconds) stages += s;
  CHECK(stages > 0.0);
  CHECK(stages <= p.frame_seconds * 1.01);

  CHECK(haustra_world_destroy(w) == HAUSTRA_OK);
}

// One case of ~140 lines on purpose: a catalogue of refused calls against one world, each a line
// with the code it must return, ending with the calls after destroy.
TEST_CASE("C API: wrong handles, NULL pointers, bad values and calls after destroy are refused") {
  const TestScene scene("c-api-colon");
  haustra_world* w = nullptr;
  REQUIRE(haustra_world_create_from_scene(scene.path.c_str(), 1, &w) == HAUSTRA_OK);
  haustra_counts c = sized<haustra_counts>();
  haustra_vec3_view v{};
  haustra_vec3f_view vf{};
  haustra_triangles_view tv{};
  haustra_instrument_reading r = sized<haustra_instrument_reading>();
  haustra_profile p = sized<haustra_profile>();
  const double* radii = nullptr;
  size_t count = 0;
  const double ok3[3] = {0.0, 0.0, 1.0};
  const double nan3[3] = {std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0};
  const double inf3[3] = {0.0, std::numeric_limits<double>::infinity(), 0.0};
  const double zero3[3] = {0.0, 0.0, 0.0};

  // Creation.
  haustra_world* none = nullptr;
  CHECK(haustra_world_create_from_scene(nullptr, 1, &none) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("scene_path is NULL"));
  CHECK(haustra_world_create_from_scene(scene.path.c_str(), 1, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("out is NULL"));
  CHECK(haustra_world_create_from_scene(scene.path.c_str(), -2, &none) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("threads = -2"));
  CHECK(haustra_world_create_from_scene("/no/such/scene.toml", 1, &none) == HAUSTRA_IO);
  CHECK(says("/no/such/scene.toml"));
  {
    const SceneFile bad("[[segment]]\nnodes = 1\n");
    CHECK(haustra_world_create_from_scene(bad.path.c_str(), 1, &none) == HAUSTRA_INVALID_ARGUMENT);
    CHECK(says("segment[0].nodes"));
    CHECK(says(":2:"));  // the line
  }
  {
    const SceneFile bad("[[segment]\n");
    CHECK(haustra_world_create_from_scene(bad.path.c_str(), 1, &none) == HAUSTRA_PARSE);
    CHECK(says("not valid TOML"));
  }
  CHECK(none == nullptr);  // nothing written on failure

  // Wrong handles: NULL, something that is not a world, a destroyed world.
  haustra_world* fake = reinterpret_cast<haustra_world*>(&c);
  haustra_world* dead = nullptr;
  REQUIRE(haustra_world_create_from_scene(scene.path.c_str(), 1, &dead) == HAUSTRA_OK);
  REQUIRE(haustra_world_destroy(dead) == HAUSTRA_OK);
  for (haustra_world* h : {static_cast<haustra_world*>(nullptr), fake, dead}) {
    INFO("handle " << static_cast<const void*>(h));
    CHECK(haustra_world_step(h) == HAUSTRA_INVALID_HANDLE);
    CHECK((says("NULL") || says("not a live world")));
    CHECK(haustra_world_counts(h, &c) == HAUSTRA_INVALID_HANDLE);
    CHECK(haustra_world_time(h, nullptr, nullptr) == HAUSTRA_INVALID_HANDLE);
    CHECK(haustra_world_node_positions(h, &v) == HAUSTRA_INVALID_HANDLE);
    CHECK(haustra_world_bead_radii(h, &radii, &count) == HAUSTRA_INVALID_HANDLE);
    CHECK(haustra_world_mesh_positions(h, &vf) == HAUSTRA_INVALID_HANDLE);
    CHECK(haustra_world_mesh_normals(h, &vf) == HAUSTRA_INVALID_HANDLE);
    CHECK(haustra_world_mesh_triangles(h, &tv) == HAUSTRA_INVALID_HANDLE);
    CHECK(haustra_world_set_node_load(h, 0, ok3, ok3) == HAUSTRA_INVALID_HANDLE);
    CHECK(haustra_world_set_instrument_pose(h, 0, ok3, ok3) == HAUSTRA_INVALID_HANDLE);
    CHECK(haustra_world_set_instrument_grasp(h, 0, 1) == HAUSTRA_INVALID_HANDLE);
    CHECK(haustra_world_instrument(h, 0, &r) == HAUSTRA_INVALID_HANDLE);
    CHECK(haustra_world_profile(h, &p) == HAUSTRA_INVALID_HANDLE);
    haustra_frame fr = sized<haustra_frame>();
    CHECK(haustra_world_acquire_frame(h, &fr) == HAUSTRA_INVALID_HANDLE);
    CHECK(haustra_world_release_frame(h) == HAUSTRA_INVALID_HANDLE);
    CHECK(haustra_world_save_checkpoint(h, "/tmp/x.ckpt") == HAUSTRA_INVALID_HANDLE);
    CHECK(haustra_world_restore_checkpoint(h, "/tmp/x.ckpt") == HAUSTRA_INVALID_HANDLE);
    haustra_segment_info si = sized<haustra_segment_info>();
    CHECK(haustra_world_segment(h, 0, &si) == HAUSTRA_INVALID_HANDLE);
    haustra_segment_def sd;
    REQUIRE(haustra_segment_def_default(&sd) == HAUSTRA_OK);
    CHECK(haustra_world_add_segment(h, &sd, nullptr) == HAUSTRA_INVALID_HANDLE);
    CHECK(haustra_world_remove_segment(h, 0) == HAUSTRA_INVALID_HANDLE);
    CHECK(haustra_world_destroy(h) == HAUSTRA_INVALID_HANDLE);
  }

  // NULL outputs.
  CHECK(haustra_world_counts(w, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_time(w, nullptr, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_node_positions(w, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_bead_radii(w, nullptr, &count) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_bead_radii(w, &radii, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_mesh_positions(w, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_mesh_normals(w, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_mesh_triangles(w, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_instrument(w, 0, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_profile(w, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("out is NULL"));
  CHECK(haustra_world_segment(w, 0, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("out is NULL"));
  CHECK(haustra_world_add_segment(w, nullptr, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("segment is NULL"));

  // Indices out of range and values that are not finite.
  CHECK(haustra_world_set_node_load(w, 21, ok3, zero3) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(
      says("haustra_world_set_node_load: World::set_external_load: node index 21 out of range (the world has 21 "
           "nodes)"));
  CHECK(haustra_world_set_node_load(w, 3, nan3, zero3) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("force = (nan, 0, 0)"));
  CHECK(haustra_world_set_node_load(w, 3, zero3, inf3) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("moment"));
  CHECK(haustra_world_set_node_load(w, 3, nullptr, zero3) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_set_instrument_pose(w, 1, ok3, ok3) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("instrument index 1 out of range"));
  CHECK(haustra_world_set_instrument_pose(w, 0, nan3, ok3) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_set_instrument_pose(w, 0, ok3, zero3) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("non-zero direction"));
  CHECK(haustra_world_set_instrument_grasp(w, 5, 1) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_instrument(w, 5, &r) == HAUSTRA_INVALID_ARGUMENT);
  haustra_segment_info info = sized<haustra_segment_info>();
  CHECK(haustra_world_segment(w, 1, &info) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("segment index 1 out of range"));
  CHECK(haustra_world_remove_segment(w, 1) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("segment index 1 out of range"));
  {
    haustra_segment_def bad;
    REQUIRE(haustra_segment_def_default(&bad) == HAUSTRA_OK);
    bad.name = "colon";  // taken
    CHECK(haustra_world_add_segment(w, &bad, nullptr) == HAUSTRA_INVALID_ARGUMENT);
    CHECK(says("used twice"));
    bad.name = "other";
    bad.struct_size = 4;
    CHECK(haustra_world_add_segment(w, &bad, nullptr) == HAUSTRA_INVALID_ARGUMENT);
    CHECK(says("struct_size = 4"));
    REQUIRE(haustra_segment_def_default(&bad) == HAUSTRA_OK);
    bad.chain_pieces = 0;
    CHECK(haustra_world_add_segment(w, &bad, nullptr) == HAUSTRA_INVALID_ARGUMENT);
    CHECK(says("chain.pieces"));
  }
  REQUIRE(haustra_world_counts(w, &c) == HAUSTRA_OK);
  CHECK(c.segments == 1);  // the refused additions added nothing

  // The refusals changed nothing: the world steps on from its rest state as if they never came.
  uint64_t frame = 99;
  REQUIRE(haustra_world_time(w, nullptr, &frame) == HAUSTRA_OK);
  CHECK(frame == 0);
  REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  CHECK(std::string(haustra_last_error()).empty());
  CHECK(haustra_world_destroy(w) == HAUSTRA_OK);
  CHECK(haustra_world_destroy(w) == HAUSTRA_INVALID_HANDLE);  // twice
}

TEST_CASE("C API: an unstable frame is refused, the buffers keep the last good frame and the world steps on") {
  const TestScene scene("lagged-elastic-colon");
  haustra_world* w = nullptr;
  REQUIRE(haustra_world_create_from_scene(scene.path.c_str(), 1, &w) == HAUSTRA_OK);
  REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  haustra_vec3_view v{};
  REQUIRE(haustra_world_node_positions(w, &v) == HAUSTRA_OK);
  // The paper's lagged scheme cannot hold an elastic rod under this pull: within a few frames a
  // frame diverges and is refused.
  const double pull[3] = {5.0, 0.0, 0.0}, none[3] = {0.0, 0.0, 0.0};
  REQUIRE(haustra_world_set_node_load(w, 40, pull, none) == HAUSTRA_OK);
  haustra_status status = HAUSTRA_OK;
  double tip_before = 0.0;
  for (int f = 0; f < 10 && status == HAUSTRA_OK; ++f) {
    tip_before = v.x[40];
    status = haustra_world_step(w);
  }
  REQUIRE(status == HAUSTRA_UNSTABLE);
  CHECK(says("unstable at frame"));
  CHECK(says("last good frame"));
  CHECK(v.x[40] == tip_before);
  for (size_t k = 0; k < v.count; ++k) REQUIRE(std::isfinite(v.x[k]));
  REQUIRE(haustra_world_set_node_load(w, 40, none, none) == HAUSTRA_OK);
  CHECK(haustra_world_step(w) == HAUSTRA_OK);
  CHECK(haustra_world_destroy(w) == HAUSTRA_OK);
}

namespace {

// Node and mesh buffers of a world, as bits.
std::vector<unsigned char> buffer_bits(const haustra_world* w) {
  std::vector<unsigned char> out;
  auto put = [&](const auto* data, size_t n) {
    const auto* b = reinterpret_cast<const unsigned char*>(data);
    out.insert(out.end(), b, b + n * sizeof(*data));
  };
  haustra_vec3_view n{};
  haustra_vec3f_view m{}, nn{};
  REQUIRE(haustra_world_node_positions(w, &n) == HAUSTRA_OK);
  REQUIRE(haustra_world_mesh_positions(w, &m) == HAUSTRA_OK);
  REQUIRE(haustra_world_mesh_normals(w, &nn) == HAUSTRA_OK);
  put(n.x, n.count), put(n.y, n.count), put(n.z, n.count);
  put(m.x, m.count), put(m.y, m.count), put(m.z, m.count), put(nn.x, nn.count);
  return out;
}

std::uint64_t fnv(const void* data, size_t bytes, std::uint64_t h = 1469598103934665603ull) {
  const auto* b = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < bytes; ++i) h = (h ^ b[i]) * 1099511628211ull;
  return h;
}

std::uint64_t frame_hash(const haustra_vec3_view& n, const haustra_vec3f_view& m) {
  std::uint64_t h = fnv(n.x, n.count * sizeof(double));
  h = fnv(n.z, n.count * sizeof(double), h);
  return fnv(m.z, m.count * sizeof(float), h);
}

}  // namespace

// One case of ~90 lines on purpose: a host's whole session (define, create, step, read, destroy) in
// the order a host writes it.
TEST_CASE("C API: a world from definitions alone, no scene file") {
  haustra_world_def def;
  REQUIRE(haustra_world_def_default(&def) == HAUSTRA_OK);
  CHECK(def.struct_size == sizeof(haustra_world_def));
  CHECK(def.dt == doctest::Approx(1.0 / 60.0));
  CHECK(def.gravity[2] == doctest::Approx(-9.81));
  CHECK(def.newton == 1);
  CHECK(def.recover == 1);
  def.threads = 1;
  def.floor = 1;
  def.floor_height = -0.3;

  haustra_segment_def seg[2];
  REQUIRE(haustra_segment_def_default(&seg[0]) == HAUSTRA_OK);
  REQUIRE(haustra_segment_def_default(&seg[1]) == HAUSTRA_OK);
  CHECK(seg[0].nodes == 167);
  CHECK(seg[0].youngs_modulus == doctest::Approx(33.2e3));
  // A clamped cantilever with beads and a procedural organ.
  seg[0].name = "cantilever";
  seg[0].nodes = 21;
  seg[0].length = 0.4;
  seg[0].beads = 8;
  seg[0].mesh = 1;
  seg[0].mesh_vertices = 1500;
  // A free rod along a measured-style polyline: an L in the floor's plane, above it.
  const double polyline[] = {0.0, 0.3, 0.0, 0.2, 0.3, 0.0, 0.3, 0.35, 0.0, 0.3, 0.5, 0.0};
  seg[1].name = "free";
  seg[1].nodes = 25;
  seg[1].centreline = polyline;
  seg[1].centreline_points = 4;
  seg[1].free_base = 1;
  seg[1].beads = 10;

  haustra_world* w = nullptr;
  REQUIRE(haustra_world_create(&def, seg, 2, &w) == HAUSTRA_OK);
  haustra_counts c = sized<haustra_counts>();
  REQUIRE(haustra_world_counts(w, &c) == HAUSTRA_OK);
  CHECK(c.segments == 2);
  CHECK(c.nodes == 46);
  CHECK(c.beads == 18);
  CHECK(c.mesh_vertices > 1000);
  haustra_vec3_view n{};
  REQUIRE(haustra_world_node_positions(w, &n) == HAUSTRA_OK);
  CHECK(n.x[20] == doctest::Approx(0.4));                // the cantilever's tip at rest
  CHECK(n.y[45] == doctest::Approx(0.5).epsilon(1e-6));  // the polyline's end
  for (int f = 0; f < 120; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  CHECK(n.z[20] < -0.05);  // the cantilever sags
  double lowest = 1.0;
  for (size_t k = 21; k < 46; ++k) lowest = std::min(lowest, n.z[k]);
  CHECK(lowest < -0.2);         // the free rod fell towards the floor...
  CHECK(lowest > -0.3 - 0.02);  // ...and the floor holds it (bead radius 0.02)
  CHECK(haustra_world_destroy(w) == HAUSTRA_OK);

  // Bad definitions: each refused with the field named, nothing created.
  haustra_world* none = nullptr;
  haustra_world_def bad_def = def;
  bad_def.struct_size = 8;
  CHECK(haustra_world_create(&bad_def, seg, 2, &none) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("def.struct_size = 8"));
  CHECK(haustra_world_create(nullptr, seg, 2, &none) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_create(&def, nullptr, 2, &none) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("segments is NULL"));
  CHECK(haustra_world_create(&def, seg, 2, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  haustra_segment_def bad[2] = {seg[0], seg[1]};
  bad[1].radius = 20.0;  // millimetres by mistake
  CHECK(haustra_world_create(&def, bad, 2, &none) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("segment[1].radius"));
  bad[1] = seg[1];
  bad[1].struct_size = 0;
  CHECK(haustra_world_create(&def, bad, 2, &none) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("segments[1].struct_size"));
  bad[1] = seg[1];
  const double doubled[] = {0.0, 0.3, 0.0, 0.0, 0.3, 0.0, 0.3, 0.5, 0.0};
  bad[1].centreline = doubled;
  bad[1].centreline_points = 3;
  CHECK(haustra_world_create(&def, bad, 2, &none) == HAUSTRA_INVALID_GEOMETRY);
  CHECK(says("segments[1].centreline"));
  bad[1] = seg[1];
  bad[1].mesh = 7;
  CHECK(haustra_world_create(&def, bad, 2, &none) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("segments[1].mesh = 7"));
  bad[1].mesh = 2;
  bad[1].mesh_file = "/no/such/organ.obj";
  CHECK(haustra_world_create(&def, bad, 2, &none) == HAUSTRA_IO);
  CHECK(says("/no/such/organ.obj"));
  haustra_world_def bad_jobs = def;
  bad_jobs.jobs.enqueue = &HostJobPool::enqueue;  // without wait
  CHECK(haustra_world_create(&bad_jobs, seg, 2, &none) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("enqueue and wait"));
  CHECK(none == nullptr);
  CHECK(haustra_world_def_default(nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_segment_def_default(nullptr) == HAUSTRA_INVALID_ARGUMENT);
}

TEST_CASE("C API: the same bits with 1 thread, 2 threads and the host job system's threads") {
  const TestScene scene("c-api-two-segments");
  auto run = [&](int threads, HostJobPool* pool) {
    haustra_world_def def;
    REQUIRE(haustra_world_def_default(&def) == HAUSTRA_OK);
    def.threads = threads;
    if (pool != nullptr) def.jobs = haustra_job_system{&HostJobPool::enqueue, &HostJobPool::wait, pool, threads};
    haustra_world* w = nullptr;
    REQUIRE(haustra_world_create_from_scene_def(scene.path.c_str(), &def, &w) == HAUSTRA_OK);
    for (int f = 0; f < 40; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
    const std::vector<unsigned char> bits = buffer_bits(w);
    REQUIRE(haustra_world_destroy(w) == HAUSTRA_OK);
    return bits;
  };
  const std::vector<unsigned char> one = run(1, nullptr);
  CHECK(run(2, nullptr) == one);
  HostJobPool pool(2);
  CHECK(run(2, &pool) == one);
  CHECK(pool.tasks_run() > 0);
  haustra_world* none = nullptr;
  CHECK(haustra_world_create_from_scene_def(nullptr, nullptr, &none) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_create_from_scene_def(scene.path.c_str(), nullptr, nullptr) == HAUSTRA_INVALID_ARGUMENT);
}

TEST_CASE("C API: a render thread reads completed frames while the world steps (double-buffered)") {
  const TestScene scene("c-api-two-segments");
  constexpr int kFrames = 150;
  // The reference: what every frame holds, from a world stepped alone.
  std::map<uint64_t, uint64_t> expected;
  {
    haustra_world* w = nullptr;
    REQUIRE(haustra_world_create_from_scene(scene.path.c_str(), 1, &w) == HAUSTRA_OK);
    for (int f = 0; f <= kFrames; ++f) {
      haustra_vec3_view n{};
      haustra_vec3f_view m{};
      REQUIRE(haustra_world_node_positions(w, &n) == HAUSTRA_OK);
      REQUIRE(haustra_world_mesh_positions(w, &m) == HAUSTRA_OK);
      expected[static_cast<uint64_t>(f)] = frame_hash(n, m);
      if (f < kFrames) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
    }
    REQUIRE(haustra_world_destroy(w) == HAUSTRA_OK);
  }
  haustra_world_def def;
  REQUIRE(haustra_world_def_default(&def) == HAUSTRA_OK);
  def.threads = 1;
  def.double_buffered = 1;
  haustra_world* w = nullptr;
  REQUIRE(haustra_world_create_from_scene_def(scene.path.c_str(), &def, &w) == HAUSTRA_OK);
  std::atomic<bool> stepping{true};
  std::atomic<int> reads{0}, wrong{0}, went_back{0}, failures{0};
  std::thread render([&] {
    uint64_t last = 0;
    while (stepping.load()) {
      haustra_frame fr = sized<haustra_frame>();
      if (haustra_world_acquire_frame(w, &fr) != HAUSTRA_OK) {
        failures += 1;
        continue;
      }
      // Whole frames only: what the reader holds is exactly some completed frame, and stays so
      // while the world steps on.
      const uint64_t before = frame_hash(fr.nodes, fr.mesh_positions);
      std::this_thread::yield();
      if (frame_hash(fr.nodes, fr.mesh_positions) != before || expected.at(fr.frame) != before) wrong += 1;
      if (fr.frame < last) went_back += 1;
      last = fr.frame;
      reads += 1;
      if (haustra_world_release_frame(w) != HAUSTRA_OK) failures += 1;
    }
  });
  for (int f = 0; f < kFrames; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  stepping = false;
  render.join();
  CHECK(reads.load() > 0);
  CHECK(wrong.load() == 0);
  CHECK(went_back.load() == 0);
  CHECK(failures.load() == 0);
  haustra_frame last = sized<haustra_frame>();
  REQUIRE(haustra_world_acquire_frame(w, &last) == HAUSTRA_OK);
  CHECK(last.frame == kFrames);
  CHECK(last.time == doctest::Approx(kFrames * 0.01));
  CHECK(haustra_world_acquire_frame(w, &last) == HAUSTRA_INVALID_ARGUMENT);  // twice without release
  CHECK(says("already acquired"));
  REQUIRE(haustra_world_release_frame(w) == HAUSTRA_OK);
  CHECK(haustra_world_release_frame(w) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("no frame is acquired"));
  CHECK(haustra_world_acquire_frame(w, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  REQUIRE(haustra_world_destroy(w) == HAUSTRA_OK);

  haustra_world* single = nullptr;
  REQUIRE(haustra_world_create_from_scene(scene.path.c_str(), 1, &single) == HAUSTRA_OK);
  haustra_frame fr = sized<haustra_frame>();
  CHECK(haustra_world_acquire_frame(single, &fr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("double_buffered"));
  CHECK(haustra_world_release_frame(single) == HAUSTRA_INVALID_ARGUMENT);
  REQUIRE(haustra_world_destroy(single) == HAUSTRA_OK);
}

TEST_CASE("C API: deadline mode counts the frames over the budget, the mesh made every frame or when read") {
  const TestScene scene("c-api-two-segments");
  haustra_world_def def;
  REQUIRE(haustra_world_def_default(&def) == HAUSTRA_OK);
  CHECK(def.frame_budget == 0.0);
  CHECK(def.mesh_every_frame == 0);
  def.threads = 1;
  def.frame_budget = 1e-9;  // no frame meets it
  def.mesh_every_frame = 1;
  haustra_world* w = nullptr;
  REQUIRE(haustra_world_create_from_scene_def(scene.path.c_str(), &def, &w) == HAUSTRA_OK);
  for (int f = 0; f < 4; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  haustra_profile p = sized<haustra_profile>();
  REQUIRE(haustra_world_profile(w, &p) == HAUSTRA_OK);
  CHECK(p.late == 1);
  uint64_t late = 0;
  REQUIRE(haustra_world_late_frames(w, &late) == HAUSTRA_OK);
  CHECK(late == 4);
  REQUIRE(haustra_world_set_frame_budget(w, 0.0) == HAUSTRA_OK);  // off
  REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  REQUIRE(haustra_world_profile(w, &p) == HAUSTRA_OK);
  CHECK(p.late == 0);
  CHECK(haustra_world_set_frame_budget(w, -1.0) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("frame_budget"));
  CHECK(haustra_world_late_frames(w, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  // The same frames with the mesh made when read: the same bits.
  haustra_world_def lazy_def = def;
  lazy_def.mesh_every_frame = 0;
  haustra_world* lazy = nullptr;
  REQUIRE(haustra_world_create_from_scene_def(scene.path.c_str(), &lazy_def, &lazy) == HAUSTRA_OK);
  for (int f = 0; f < 5; ++f) REQUIRE(haustra_world_step(lazy) == HAUSTRA_OK);
  CHECK(buffer_bits(lazy) == buffer_bits(w));
  REQUIRE(haustra_world_destroy(lazy) == HAUSTRA_OK);
  REQUIRE(haustra_world_destroy(w) == HAUSTRA_OK);
  haustra_world_def bad = def;
  bad.mesh_every_frame = 2;
  haustra_world* none = nullptr;
  CHECK(haustra_world_create_from_scene_def(scene.path.c_str(), &bad, &none) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("mesh_every_frame"));
}

// A scene of tests/scenes/ as text, with `from` replaced by `to`.
std::string scene_text_with(const char* name, const std::string& from, const std::string& to) {
  std::ifstream in(TestScene(name).path);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  text.replace(text.find(from), from.size(), to);
  return text;
}

// The two-segment scene with run-time parameters written into its text instead.
std::string two_segments_with(const std::string& world_lines, const std::string& b_lines) {
  std::string text = scene_text_with("c-api-two-segments", "", "");
  const std::string dt = "dt = 0.01\n";
  text.replace(text.find(dt), dt.size(), world_lines);
  const std::string b = "name = \"b\"\n";
  text.insert(text.find(b) + b.size(), b_lines);
  return text;
}

TEST_CASE("C API: gravity, dt and a segment's material changed between steps give a world built with them") {
  const SceneFile built(two_segments_with("dt = 0.005\ngravity = [0.5, 0.0, -6.0]\n",
                                          "youngs_modulus = 52000.0\npoisson_ratio = 0.3\ndensity = 1200.0\n"
                                          "relaxation_time = 0.4\n"));
  const TestScene plain("c-api-two-segments");
  haustra_world* changed = nullptr;
  haustra_world* reference = nullptr;
  REQUIRE(haustra_world_create_from_scene(plain.path.c_str(), 1, &changed) == HAUSTRA_OK);
  REQUIRE(haustra_world_create_from_scene(built.path.c_str(), 1, &reference) == HAUSTRA_OK);
  double g[3] = {};
  REQUIRE(haustra_world_gravity(changed, g) == HAUSTRA_OK);
  CHECK(g[2] == -9.81);
  double dt = 0.0;
  REQUIRE(haustra_world_dt(changed, &dt) == HAUSTRA_OK);
  CHECK(dt == 0.01);
  haustra_material m = sized<haustra_material>();
  REQUIRE(haustra_world_material(changed, 1, &m) == HAUSTRA_OK);
  CHECK(m.youngs_modulus == 33200.0);
  CHECK(m.relaxation_time == 1.0);

  const double gravity[3] = {0.5, 0.0, -6.0};
  REQUIRE(haustra_world_set_gravity(changed, gravity) == HAUSTRA_OK);
  REQUIRE(haustra_world_set_dt(changed, 0.005) == HAUSTRA_OK);
  m.youngs_modulus = 52000.0;
  m.poisson_ratio = 0.3;
  m.density = 1200.0;
  m.relaxation_time = 0.4;
  REQUIRE(haustra_world_set_material(changed, 1, &m) == HAUSTRA_OK);
  REQUIRE(haustra_world_gravity(changed, g) == HAUSTRA_OK);
  CHECK(g[0] == 0.5);
  REQUIRE(haustra_world_dt(changed, &dt) == HAUSTRA_OK);
  CHECK(dt == 0.005);
  haustra_material read = sized<haustra_material>();
  REQUIRE(haustra_world_material(changed, 1, &read) == HAUSTRA_OK);
  CHECK(read.youngs_modulus == 52000.0);
  CHECK(read.density == 1200.0);
  REQUIRE(haustra_world_material(changed, 0, &read) == HAUSTRA_OK);
  CHECK(read.youngs_modulus == 33200.0);  // the other segment's stands
  for (int f = 0; f < 8; ++f) {
    REQUIRE(haustra_world_step(changed) == HAUSTRA_OK);
    REQUIRE(haustra_world_step(reference) == HAUSTRA_OK);
  }
  CHECK(buffer_bits(changed) == buffer_bits(reference));

  // Refused with the field, the world as it was.
  const std::vector<unsigned char> before = buffer_bits(changed);
  const double heavy[3] = {0.0, 0.0, -1e30}, nan3[3] = {0.0, std::nan(""), 0.0};
  CHECK(haustra_world_set_gravity(changed, heavy) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("gravity"));
  CHECK(haustra_world_set_gravity(changed, nan3) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_set_gravity(changed, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_gravity(changed, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_set_dt(changed, -0.01) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("dt"));
  CHECK(haustra_world_dt(changed, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  haustra_material bad = m;
  bad.youngs_modulus = -1.0;
  CHECK(haustra_world_set_material(changed, 1, &bad) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("youngs_modulus"));
  CHECK(haustra_world_set_material(changed, 2, &m) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("out of range"));
  CHECK(haustra_world_set_material(changed, 1, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_material(changed, 1, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_set_instrument_coupling(changed, 0, 1000.0, 2.0, 8.0) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("instrument"));
  REQUIRE(haustra_world_material(changed, 1, &read) == HAUSTRA_OK);
  CHECK(read.youngs_modulus == 52000.0);
  CHECK(buffer_bits(changed) == before);
  REQUIRE(haustra_world_destroy(changed) == HAUSTRA_OK);
  REQUIRE(haustra_world_destroy(reference) == HAUSTRA_OK);
  CHECK(haustra_world_set_dt(changed, 0.01) == HAUSTRA_INVALID_HANDLE);
}

TEST_CASE("C API: a grasp's coupling changed between steps gives a world built with it") {
  const std::string rigid = "coupling_stiffness = 0.0";
  const SceneFile plain(scene_text_with("c-api-colon", rigid, "coupling_stiffness = 1000.0"));
  const SceneFile built(
      scene_text_with("c-api-colon", rigid, "coupling_stiffness = 300.0\ncoupling_damping = 0.5\nforce_limit = 0.05"));
  haustra_world* changed = nullptr;
  haustra_world* reference = nullptr;
  REQUIRE(haustra_world_create_from_scene(plain.path.c_str(), 1, &changed) == HAUSTRA_OK);
  REQUIRE(haustra_world_create_from_scene(built.path.c_str(), 1, &reference) == HAUSTRA_OK);
  REQUIRE(haustra_world_set_instrument_coupling(changed, 0, 300.0, 0.5, 0.05) == HAUSTRA_OK);
  // Grasp the tip and lift it: the coupling (a weak spring, saturating at 0.05 N) carries it.
  haustra_world* both[2] = {changed, reference};
  for (haustra_world* w : both) {
    haustra_vec3_view n{};
    REQUIRE(haustra_world_node_positions(w, &n) == HAUSTRA_OK);
    const double tip[3] = {n.x[20], n.y[20], n.z[20] + 0.025}, up[3] = {0.0, 0.0, 1.0};
    REQUIRE(haustra_world_set_instrument_pose(w, 0, tip, up) == HAUSTRA_OK);
    REQUIRE(haustra_world_set_instrument_grasp(w, 0, 1) == HAUSTRA_OK);
    REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
    const double lifted[3] = {tip[0], tip[1], tip[2] + 0.08};
    REQUIRE(haustra_world_set_instrument_pose(w, 0, lifted, up) == HAUSTRA_OK);
    for (int f = 0; f < 10; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  }
  haustra_instrument_reading a = sized<haustra_instrument_reading>(), b = sized<haustra_instrument_reading>();
  REQUIRE(haustra_world_instrument(changed, 0, &a) == HAUSTRA_OK);
  REQUIRE(haustra_world_instrument(reference, 0, &b) == HAUSTRA_OK);
  CHECK(a.grasping == 1);
  CHECK(std::abs(a.force[2]) <= 0.05 * (1 + 1e-9));  // the limit holds
  CHECK(std::memcmp(a.force, b.force, sizeof a.force) == 0);
  CHECK(buffer_bits(changed) == buffer_bits(reference));
  CHECK(haustra_world_set_instrument_coupling(changed, 0, -1.0, 0.5, 0.05) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("stiffness"));
  CHECK(haustra_world_set_instrument_coupling(changed, 1, 300.0, 0.5, 0.05) == HAUSTRA_INVALID_ARGUMENT);
  // Where it was last commanded (the capsule, a proxy, is where it could get to; decision 0096).
  CHECK(std::memcmp(a.commanded_tip, b.commanded_tip, sizeof a.commanded_tip) == 0);
  CHECK(a.commanded_tip[2] > a.tip[2] - 0.08);
  CHECK(a.cutting == 0);
  REQUIRE(haustra_world_set_instrument_cutting(changed, 0, 1) == HAUSTRA_OK);
  REQUIRE(haustra_world_instrument(changed, 0, &a) == HAUSTRA_OK);
  CHECK(a.cutting == 1);
  CHECK(haustra_world_set_instrument_cutting(changed, 3, 1) == HAUSTRA_INVALID_ARGUMENT);
  REQUIRE(haustra_world_destroy(changed) == HAUSTRA_OK);
  REQUIRE(haustra_world_destroy(reference) == HAUSTRA_OK);
}

TEST_CASE("C API: checkpoint to a file, restore, step on: the same bits") {
  const TestScene scene("c-api-two-segments");
  const std::string file =
      (std::filesystem::temp_directory_path() / ("haustra-c-api-" + std::to_string(::getpid()) + ".ckpt")).string();
  haustra_world* w = nullptr;
  REQUIRE(haustra_world_create_from_scene(scene.path.c_str(), 1, &w) == HAUSTRA_OK);
  for (int f = 0; f < 20; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  REQUIRE(haustra_world_save_checkpoint(w, file.c_str()) == HAUSTRA_OK);
  for (int f = 0; f < 20; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  const std::vector<unsigned char> at40 = buffer_bits(w);
  REQUIRE(haustra_world_restore_checkpoint(w, file.c_str()) == HAUSTRA_OK);
  uint64_t frame = 0;
  REQUIRE(haustra_world_time(w, nullptr, &frame) == HAUSTRA_OK);
  CHECK(frame == 20);
  for (int f = 0; f < 20; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  CHECK(buffer_bits(w) == at40);

  // Refusals: NULL, a missing file, another world's checkpoint; the world is left as it was.
  CHECK(haustra_world_save_checkpoint(w, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_restore_checkpoint(w, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_restore_checkpoint(w, "/no/such/file.ckpt") == HAUSTRA_IO);
  CHECK(says("/no/such/file.ckpt"));
  CHECK(haustra_world_save_checkpoint(w, "/no/such/dir/file.ckpt") == HAUSTRA_IO);
  const TestScene other("c-api-colon");
  haustra_world* o = nullptr;
  REQUIRE(haustra_world_create_from_scene(other.path.c_str(), 1, &o) == HAUSTRA_OK);
  CHECK(haustra_world_restore_checkpoint(o, file.c_str()) == HAUSTRA_PARSE);
  CHECK(says("saved from a world of 2 segments"));
  REQUIRE(haustra_world_time(o, nullptr, &frame) == HAUSTRA_OK);
  CHECK(frame == 0);
  REQUIRE(haustra_world_destroy(o) == HAUSTRA_OK);
  REQUIRE(haustra_world_destroy(w) == HAUSTRA_OK);
  std::filesystem::remove(file);
}

// One case of ~90 lines on purpose: one world whose segments are added and removed in turn, each
// step checked against the state the previous one left.
TEST_CASE("C API: chained segments, each one's info, segments added and removed between frames") {
  haustra_world_def def;
  REQUIRE(haustra_world_def_default(&def) == HAUSTRA_OK);
  def.threads = 1;
  def.floor = 1;
  def.floor_height = -0.5;
  def.double_buffered = 1;
  haustra_segment_def chain;
  REQUIRE(haustra_segment_def_default(&chain) == HAUSTRA_OK);
  CHECK(chain.chain_pieces == 1);
  chain.name = "gut";
  chain.nodes = 11;
  chain.chain_pieces = 4;  // 4 × 10 sections: 41 nodes
  chain.length = 0.4;
  chain.beads = 6;  // per piece: every second node, 21 in all
  chain.mesh = 1;
  chain.mesh_vertices = 1000;

  haustra_world* w = nullptr;
  REQUIRE(haustra_world_create(&def, &chain, 1, &w) == HAUSTRA_OK);
  haustra_counts c = sized<haustra_counts>();
  REQUIRE(haustra_world_counts(w, &c) == HAUSTRA_OK);
  CHECK(c.segments == 4);
  CHECK(c.nodes == 41);
  CHECK(c.beads == 21);
  size_t vertices = 0, beads = 0;
  for (size_t s = 0; s < 4; ++s) {
    haustra_segment_info info = sized<haustra_segment_info>();
    REQUIRE(haustra_world_segment(w, s, &info) == HAUSTRA_OK);
    CHECK(std::string(info.name) == "gut-" + std::to_string(s + 1));
    CHECK(info.node_offset == 10 * s);  // joint nodes shared
    CHECK(info.node_count == 11);
    CHECK(info.bead_offset == beads);
    beads += info.bead_count;
    CHECK(info.mesh_vertex_offset == vertices);
    CHECK(info.mesh_vertex_count > 500);
    vertices += info.mesh_vertex_count;
    CHECK(info.chain == 0);
    CHECK(info.length == doctest::Approx(0.1));
  }
  CHECK(beads == 21);
  CHECK(vertices == c.mesh_vertices);
  for (int f = 0; f < 30; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);

  // A straight rod joins, 1 m away; the chain steps on. A render thread's frame blocks the change.
  haustra_segment_def rod;
  REQUIRE(haustra_segment_def_default(&rod) == HAUSTRA_OK);
  rod.name = "rod";
  rod.nodes = 21;
  rod.length = 0.4;
  rod.base_position[1] = 1.0;
  haustra_frame frame = sized<haustra_frame>();
  REQUIRE(haustra_world_acquire_frame(w, &frame) == HAUSTRA_OK);
  CHECK(haustra_world_add_segment(w, &rod, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("release it before changing what the world holds"));
  REQUIRE(haustra_world_release_frame(w) == HAUSTRA_OK);
  size_t index = 99;
  REQUIRE(haustra_world_add_segment(w, &rod, &index) == HAUSTRA_OK);
  CHECK(index == 4);
  REQUIRE(haustra_world_counts(w, &c) == HAUSTRA_OK);
  CHECK(c.segments == 5);
  CHECK(c.nodes == 62);
  uint64_t now = 0;
  REQUIRE(haustra_world_time(w, nullptr, &now) == HAUSTRA_OK);
  CHECK(now == 30);                                               // the clock goes on
  REQUIRE(haustra_world_acquire_frame(w, &frame) == HAUSTRA_OK);  // frames take the new sizes
  CHECK(frame.nodes.count == 62);
  CHECK(frame.mesh_positions.count == c.mesh_vertices);
  CHECK(frame.nodes.y[61] == doctest::Approx(1.0));
  REQUIRE(haustra_world_release_frame(w) == HAUSTRA_OK);
  REQUIRE(haustra_world_step(w) == HAUSTRA_OK);

  // The chain is removed whole, through its first segment; the rod moves down to index 0.
  CHECK(haustra_world_remove_segment(w, 2) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("removed whole, through its first segment 'gut-1'"));
  REQUIRE(haustra_world_remove_segment(w, 0) == HAUSTRA_OK);
  REQUIRE(haustra_world_counts(w, &c) == HAUSTRA_OK);
  CHECK(c.segments == 1);
  CHECK(c.nodes == 21);
  CHECK(c.mesh_vertices == 0);
  haustra_segment_info info = sized<haustra_segment_info>();
  REQUIRE(haustra_world_segment(w, 0, &info) == HAUSTRA_OK);
  CHECK(std::string(info.name) == "rod");
  CHECK(info.mesh_vertex_count == 0);
  REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  CHECK(haustra_world_destroy(w) == HAUSTRA_OK);
}

TEST_CASE("C API: segments added and removed while a render thread reads frames") {
  haustra_world_def def;
  REQUIRE(haustra_world_def_default(&def) == HAUSTRA_OK);
  def.threads = 2;
  def.double_buffered = 1;
  haustra_segment_def seg = organ_def("first", 21, 0.4, 7, 1000);
  haustra_world* w = nullptr;
  REQUIRE(haustra_world_create(&def, &seg, 1, &w) == HAUSTRA_OK);
  std::atomic<bool> stepping{true};
  std::atomic<int> reads{0}, torn{0};
  std::thread render([&] {
    while (stepping.load()) {
      haustra_frame fr = sized<haustra_frame>();
      if (haustra_world_acquire_frame(w, &fr) != HAUSTRA_OK) continue;
      // A frame is whole: its node count is one the world had (21 or 42), and every value is set.
      if (fr.nodes.count != 21 && fr.nodes.count != 42) torn += 1;
      for (size_t k = 0; k < fr.nodes.count; ++k)
        if (!std::isfinite(fr.nodes.x[k] + fr.nodes.y[k] + fr.nodes.z[k])) torn += 1;
      reads += 1;
      std::this_thread::yield();
      haustra_world_release_frame(w);
      // A renderer draws between frames; a reader that never let go would starve the changes.
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
  });
  auto change = [&](auto&& call) {                       // refused while the reader holds a frame: try again
    for (int attempt = 0; attempt < 20000; ++attempt) {  // up to ~10 s on a loaded machine
      const haustra_status s = call();
      if (s == HAUSTRA_OK) return true;
      if (!says("release it before")) return false;
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
    return false;
  };
  for (int f = 0; f < 10; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  haustra_segment_def second = seg;
  second.name = "second";
  second.base_position[1] = 0.5;
  CHECK(change([&] { return haustra_world_add_segment(w, &second, nullptr); }));
  for (int f = 0; f < 10; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  CHECK(change([&] { return haustra_world_remove_segment(w, 0); }));
  for (int f = 0; f < 10; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  stepping = false;
  render.join();
  CHECK(reads.load() > 0);
  CHECK(torn.load() == 0);
  haustra_counts c = sized<haustra_counts>();
  REQUIRE(haustra_world_counts(w, &c) == HAUSTRA_OK);
  CHECK(c.segments == 1);
  REQUIRE(haustra_world_destroy(w) == HAUSTRA_OK);
}

TEST_CASE("C API: an EXP2 segment pulled at its tip stretches to A sigma(eps) = F, and is refused without Newton") {
  haustra_world_def def;
  REQUIRE(haustra_world_def_default(&def) == HAUSTRA_OK);
  def.threads = 1;
  def.gravity[0] = def.gravity[1] = def.gravity[2] = 0.0;
  haustra_segment_def seg;
  REQUIRE(haustra_segment_def_default(&seg) == HAUSTRA_OK);
  CHECK(seg.tissue == 0);
  CHECK(seg.exp2_alpha == 8.0);
  seg.nodes = 21;
  seg.length = 0.2;
  seg.tissue = 1;
  // σ(ε) straight from eq. 1 with the defaults, over the default tube (R = 2 cm, 3 mm wall).
  const double strain = 0.3;
  const double area = 2.0 * 3.141592653589793 * seg.radius * seg.wall_thickness;
  const double force =
      area * (seg.exp2_beta * (std::exp(seg.exp2_alpha * strain * strain) - 1.0) + seg.exp2_gamma * strain);
  haustra_world* w = nullptr;
  REQUIRE(haustra_world_create(&def, &seg, 1, &w) == HAUSTRA_OK);
  const double f[3] = {force, 0.0, 0.0};
  const double m[3] = {0.0, 0.0, 0.0};
  REQUIRE(haustra_world_set_node_load(w, 20, f, m) == HAUSTRA_OK);
  for (int i = 0; i < 20; ++i) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  haustra_vec3_view p{};
  REQUIRE(haustra_world_node_positions(w, &p) == HAUSTRA_OK);
  CHECK(p.x[20] == doctest::Approx(0.2 * (1.0 + strain)).epsilon(1e-9));
  REQUIRE(haustra_world_destroy(w) == HAUSTRA_OK);

  def.newton = 0;
  CHECK(haustra_world_create(&def, &seg, 1, &w) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("tissue.response"));
  def.newton = 1;
  seg.tissue = 2;
  CHECK(haustra_world_create(&def, &seg, 1, &w) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("tissue = 2"));
}

TEST_CASE(
    "C API: skinning 1, 0, 2, 3 give the scene's along-rod, cage, cage-full, linear-blend - the retired fields are "
    "refused if set") {
  // Decision 0120: one choice of skin. A cantilever with beads 2 cm apart and a procedural organ,
  // bending under gravity, from definitions and from a scene file with the same skin.
  haustra_world_def def;
  REQUIRE(haustra_world_def_default(&def) == HAUSTRA_OK);
  def.threads = 1;
  const haustra_segment_def plain = organ_def("organ", 41, 0.4, 20, 1500);
  CHECK(plain.skinning == 1);          // along the rod, the default
  CHECK(plain.rings_per_vertex == 4);  // the retired fields at the values they are ignored at
  CHECK(plain.weight_left_out == 0.02);
  CHECK(plain.max_rings_per_vertex == 0);
  CHECK(plain.mean_rings_per_vertex == 0.0);
  CHECK(plain.skin_cost_limit == 0.0);
  auto stepped = [](haustra_world* w) {
    for (int f = 0; f < 20; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
    std::vector<unsigned char> bits = buffer_bits(w);
    REQUIRE(haustra_world_destroy(w) == HAUSTRA_OK);
    return bits;
  };
  const auto scene_text = [](const std::string& mesh_line) {
    return "[world]\nthreads = 1\n[[segment]]\nname = \"organ\"\nnodes = 41\n[segment.rest]\nlength = 0.4\n"
           "[segment.beads]\ncount = 20\n[segment.mesh]\nsource = \"procedural\"\n" +
           mesh_line + "\n[segment.mesh.procedural]\nvertices = 1500\n";
  };
  haustra_world* w = nullptr;
  std::vector<std::vector<unsigned char>> skins;
  for (const auto& [value, name] :
       std::vector<std::pair<int, std::string>>{{1, "along-rod"}, {0, "cage"}, {2, "cage-full"}, {3, "linear-blend"}}) {
    CAPTURE(name);
    haustra_segment_def seg = plain;
    seg.skinning = value;
    REQUIRE(haustra_world_create(&def, &seg, 1, &w) == HAUSTRA_OK);
    skins.push_back(stepped(w));
    const SceneFile scene(scene_text("skinning = \"" + name + "\""));
    REQUIRE(haustra_world_create_from_scene(scene.path.c_str(), 1, &w) == HAUSTRA_OK);
    CHECK(stepped(w) == skins.back());
  }
  CHECK(skins[0] != skins[1]);  // each skin is its own mesh
  CHECK(skins[1] != skins[2]);
  CHECK(skins[3] != skins[0]);
  REQUIRE(haustra_world_create(&def, &plain, 1, &w) == HAUSTRA_OK);
  CHECK(stepped(w) == skins[0]);

  // A retired field set to anything but its old default: refused naming it and `skinning`.
  struct Retired {
    const char* key;
    void (*set)(haustra_segment_def&);
  };
  const Retired retired[] = {
      {"rings_per_vertex", [](haustra_segment_def& s) { s.rings_per_vertex = 0; }},
      {"max_rings_per_vertex", [](haustra_segment_def& s) { s.max_rings_per_vertex = 7; }},
      {"mean_rings_per_vertex", [](haustra_segment_def& s) { s.mean_rings_per_vertex = 7.0; }},
      {"weight_left_out", [](haustra_segment_def& s) { s.weight_left_out = 0.0; }},
      {"skin_cost_limit", [](haustra_segment_def& s) { s.skin_cost_limit = 2.0; }},
  };
  haustra_world* none = nullptr;
  for (const Retired& r : retired) {
    CAPTURE(r.key);
    haustra_segment_def seg = plain;
    r.set(seg);
    CHECK(haustra_world_create(&def, &seg, 1, &none) == HAUSTRA_INVALID_ARGUMENT);
    CHECK(says((std::string("segments[0].") + r.key).c_str()));
    CHECK(says("use skinning: 1 along the rod, 0 the cage, 2 the cage with every ring, 3 linear blend"));
    seg.mesh = 0;  // no mesh: nothing to skin, the field is not read
    REQUIRE(haustra_world_create(&def, &seg, 1, &w) == HAUSTRA_OK);
    REQUIRE(haustra_world_destroy(w) == HAUSTRA_OK);
    const SceneFile scene(scene_text(std::string(r.key) + " = 4"));
    CHECK(haustra_world_create_from_scene(scene.path.c_str(), 1, &none) != HAUSTRA_OK);
    CHECK(says((std::string("segment[0].mesh.") + r.key).c_str()));
    CHECK(says("decision 0120"));
  }
  // A struct the host zeroed itself and filled with what it needs (decision 0124): the retired
  // fields all 0, never set, are ignored; skinning 0 is the cage, as the header says.
  haustra_segment_def zeroed = plain;
  zeroed.rings_per_vertex = 0;
  zeroed.max_rings_per_vertex = 0;
  zeroed.mean_rings_per_vertex = 0.0;
  zeroed.weight_left_out = 0.0;
  zeroed.skin_cost_limit = 0.0;
  zeroed.skinning = 0;
  REQUIRE(haustra_world_create(&def, &zeroed, 1, &w) == HAUSTRA_OK);
  CHECK(stepped(w) == skins[1]);
  zeroed.skin_cost_limit = 2.0;  // one of them set: the host meant it, refused naming it
  CHECK(haustra_world_create(&def, &zeroed, 1, &none) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("segments[0].skin_cost_limit = 2"));
  haustra_segment_def blank;  // zeroed and nothing else set: refused for its nodes, not a retired field
  std::memset(&blank, 0, sizeof blank);
  blank.struct_size = sizeof blank;
  blank.mesh = 1;
  CHECK(haustra_world_create(&def, &blank, 1, &none) == HAUSTRA_INVALID_ARGUMENT);
  CHECK_FALSE(says("rings_per_vertex"));
  CHECK(says("nodes"));
  haustra_segment_def bad = plain;
  bad.skinning = 4;
  CHECK(haustra_world_create(&def, &bad, 1, &none) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("skinning = 4"));
  CHECK(says("or 3 (linear blend)"));
  CHECK(none == nullptr);
}

TEST_CASE("C API: connective tissue from a segment's definition, its anchors and tensions, cut in a sphere") {
  haustra_world_def def;
  REQUIRE(haustra_world_def_default(&def) == HAUSTRA_OK);
  def.threads = 1;
  haustra_segment_def seg;
  REQUIRE(haustra_segment_def_default(&seg) == HAUSTRA_OK);
  CHECK(seg.anchor_stiffness == 0.0);  // no tissue unless asked for
  CHECK(seg.anchor_support == 0.0);
  CHECK(seg.anchor_damping == 50.0);
  CHECK(seg.anchor_strength == 1000.0);
  seg.nodes = 21;
  seg.length = 0.5;
  seg.free_base = 1;
  seg.drag = 1.0;
  seg.anchor_stiffness = 1000.0;  // the tether
  seg.anchor_support = 4000.0;    // and what lies below: together 5 kN/m² against sinking
  seg.anchor_strength = 0.0;
  haustra_world* w = nullptr;
  REQUIRE(haustra_world_create(&def, &seg, 1, &w) == HAUSTRA_OK);
  const uint32_t* nodes = nullptr;
  const uint8_t* intact = nullptr;
  size_t count = 0;
  REQUIRE(haustra_world_anchors(w, &nodes, &intact, &count) == HAUSTRA_OK);
  REQUIRE(count == 21);
  CHECK(nodes[20] == 20);
  for (int f = 0; f < 60; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  // Each anchor carries its node's weight: the tether's part of the sag, 1/5 of it.
  std::vector<double> tension(count);
  REQUIRE(haustra_world_anchor_tensions(w, tension.data(), count) == HAUSTRA_OK);
  const double weight = 1050.0 * 2.0 * 3.141592653589793 * 0.02 * 0.003 * 9.81 * 0.025;  // N per node (2.5 cm)
  CHECK(tension[10] == doctest::Approx(weight / 5.0).epsilon(1e-6));
  // A cut 2 cm from the wall round the middle node: its anchor and its neighbours' (2.5 cm apart).
  haustra_vec3_view n{};
  REQUIRE(haustra_world_node_positions(w, &n) == HAUSTRA_OK);
  const double centre[3] = {n.x[10], n.y[10], n.z[10]};
  size_t cut = 0;
  REQUIRE(haustra_world_cut_tissue(w, centre, 0.03, &cut) == HAUSTRA_OK);
  CHECK(cut == 3);
  CHECK(intact[9] == 0);
  CHECK(intact[10] == 0);
  CHECK(intact[11] == 0);
  CHECK(intact[12] == 1);
  REQUIRE(haustra_world_anchor_tensions(w, tension.data(), count) == HAUSTRA_OK);
  CHECK(tension[10] == 0.0);
  // Refused: a wrong count, a NULL, a radius that is not positive, non-finite centres.
  CHECK(haustra_world_anchor_tensions(w, tension.data(), count - 1) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("anchor_tensions"));
  CHECK(haustra_world_anchors(w, nullptr, &intact, &count) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_cut_tissue(w, centre, 0.0, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("radius"));
  const double nan_centre[3] = {std::nan(""), 0.0, 0.0};
  CHECK(haustra_world_cut_tissue(w, nan_centre, 0.01, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_destroy(w) == HAUSTRA_OK);
  // A tissue field out of range names it.
  seg.anchor_support = -1.0;
  haustra_world* none = nullptr;
  CHECK(haustra_world_create(&def, &seg, 1, &none) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("anchors[0].support"));
}
