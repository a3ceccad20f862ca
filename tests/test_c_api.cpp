// The C API, through its header only: every function, with good calls checked against what the
// scene implies and bad ones — wrong handles, NULL pointers, indices out of range, non-finite
// values, calls after destroy — each answered by its status and a message, none crashing.
#include <doctest/doctest.h>
#include <haustra/haustra.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <unistd.h>

namespace {

const char* kScene = R"(
[world]
dt = 0.01
[[segment]]
name = "colon"
nodes = 21
radius = 0.02
[segment.rest]
length = 0.4
[segment.beads]
count = 8
[segment.mesh]
source = "procedural"
[segment.mesh.procedural]
vertices = 1500
[[instrument]]
name = "grasper"
grasp_reach = 0.015
tip = [0.2, 0.0, 0.2]
)";

// A scene file of this process's own, removed at the end.
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

}  // namespace

TEST_CASE("C API: version and ABI check") {
  CHECK(std::string(haustra_version()).find('.') != std::string::npos);
  CHECK(haustra_check_abi(HAUSTRA_ABI_VERSION) == HAUSTRA_OK);
  CHECK(std::string(haustra_last_error()).empty());
  CHECK(haustra_check_abi(HAUSTRA_ABI_VERSION + 1) == HAUSTRA_ABI_MISMATCH);
  CHECK(says("ABI 2"));
  CHECK(std::string(haustra_stage_name(0)) == "instruments");
  CHECK(haustra_stage_name(HAUSTRA_STAGE_COUNT - 1) != nullptr);
  CHECK(haustra_stage_name(HAUSTRA_STAGE_COUNT) == nullptr);
  CHECK(haustra_stage_name(-1) == nullptr);
}

TEST_CASE("C API: a world from a scene, stepped, read without copies, driven by the host") {
  const SceneFile scene(kScene);
  haustra_world* w = nullptr;
  REQUIRE(haustra_world_create_from_scene(scene.path.c_str(), 1, &w) == HAUSTRA_OK);
  REQUIRE(w != nullptr);

  haustra_counts c{};
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
  haustra_instrument_reading r{};
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
  haustra_profile p{};
  REQUIRE(haustra_world_profile(w, &p) == HAUSTRA_OK);
  CHECK(p.frame_seconds > 0.0);
  CHECK(p.substeps >= 1);
  double stages = 0.0;
  for (double s : p.stage_seconds) stages += s;
  CHECK(stages > 0.0);
  CHECK(stages <= p.frame_seconds * 1.01);

  CHECK(haustra_world_destroy(w) == HAUSTRA_OK);
}

TEST_CASE("C API: wrong handles, NULL pointers, bad values and calls after destroy are refused") {
  const SceneFile scene(kScene);
  haustra_world* w = nullptr;
  REQUIRE(haustra_world_create_from_scene(scene.path.c_str(), 1, &w) == HAUSTRA_OK);
  haustra_counts c{};
  haustra_vec3_view v{};
  haustra_vec3f_view vf{};
  haustra_triangles_view tv{};
  haustra_instrument_reading r{};
  haustra_profile p{};
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

  // Indices out of range and values that are not finite.
  CHECK(haustra_world_set_node_load(w, 21, ok3, zero3) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(says("node 21 out of range (the world has 21)"));
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
  const SceneFile scene(R"(
[world]
gravity = [0.0, 0.0, 0.0]
[solver]
mode = "lagged"
on_instability = "stop"
[[segment]]
nodes = 41
radius = 0.02
[segment.rest]
length = 0.6
[segment.law]
bending = "elastic"
torsion = "elastic"
)");
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
