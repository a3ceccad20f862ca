// What a host's own scene graph needs of the C API (issue 36, item 6; decision 0106), through the
// header only: instruments, obstacles, attachments and ranges of tissue added and removed between
// frames; the nodes' frames and velocities, the beads' nodes, the contacts; structs that carry
// their size; the estimate a host asks for before it builds.
#include <doctest/doctest.h>
#include <haustra/haustra.h>

#include <unistd.h>
#include "c_sized.hpp"

#include <cmath>
#include <cstddef>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace {

// A clamped colon over a floor with a grasper above its middle, written for this process.
struct PartsScene {
  std::filesystem::path path =
      std::filesystem::temp_directory_path() /
      ("haustra-c-parts-" + std::to_string(::getpid()) + "-" + std::to_string(next()) + ".toml");
  explicit PartsScene(const std::string& extra = "") {
    std::ofstream(path) << "[world]\ndt = 0.01\n"
                           "[[environment.plane]]\nname = \"floor\"\npoint = [0.0, 0.0, -0.1]\n"
                           "[[segment]]\nname = \"colon\"\nnodes = 21\nradius = 0.02\n"
                           "[segment.rest]\nlength = 0.4\n[segment.beads]\ncount = 11\n"
                           "[[instrument]]\nname = \"grasper\"\ngrasp_reach = 0.015\ntip = [0.2, 0.0, 0.2]\n"
                        << extra;
  }
  ~PartsScene() { std::filesystem::remove(path); }
  PartsScene(const PartsScene&) = delete;
  PartsScene& operator=(const PartsScene&) = delete;
  static int next() {
    static int n = 0;
    return ++n;
  }
};

bool said(const char* words) { return std::strstr(haustra_last_error(), words) != nullptr; }

haustra_world* made(const PartsScene& scene) {
  haustra_world* w = nullptr;
  REQUIRE(haustra_world_create_from_scene(scene.path.c_str(), 1, &w) == HAUSTRA_OK);
  return w;
}

void step_frames(haustra_world* w, int frames) {
  for (int f = 0; f < frames; ++f) {
    const haustra_status s = haustra_world_step(w);
    const std::string message = haustra_last_error();
    INFO(message);
    REQUIRE(s == HAUSTRA_OK);
  }
}

std::vector<double> node_bits(const haustra_world* w) {
  haustra_vec3_view v{};
  REQUIRE(haustra_world_node_positions(w, &v) == HAUSTRA_OK);
  std::vector<double> out(v.x, v.x + v.count);
  out.insert(out.end(), v.y, v.y + v.count);
  out.insert(out.end(), v.z, v.z + v.count);
  return out;
}

haustra_counts counted(const haustra_world* w) {
  haustra_counts c = sized<haustra_counts>();
  REQUIRE(haustra_world_counts(w, &c) == HAUSTRA_OK);
  return c;
}

haustra_instrument_reading instrument_of(const haustra_world* w, size_t instrument) {
  haustra_instrument_reading r = sized<haustra_instrument_reading>();
  REQUIRE(haustra_world_instrument(w, instrument, &r) == HAUSTRA_OK);
  return r;
}

// The grasper closed on the colon's middle node (10) from 1 cm above it.
void grasp_middle(haustra_world* w, size_t instrument) {
  haustra_vec3_view v{};
  REQUIRE(haustra_world_node_positions(w, &v) == HAUSTRA_OK);
  const double tip[3] = {v.x[10], v.y[10], v.z[10] + 0.03}, up[3] = {0.0, 0.0, 1.0};
  REQUIRE(haustra_world_set_instrument_pose(w, instrument, tip, up) == HAUSTRA_OK);
  REQUIRE(haustra_world_set_instrument_grasp(w, instrument, 1) == HAUSTRA_OK);
}

}  // namespace

TEST_CASE(
    "C API: an instrument, obstacles, an attachment and tissue added, then removed: the world steps on bit for "
    "bit, its grasp held throughout") {
  const PartsScene scene;
  haustra_world* w = made(scene);
  haustra_world* reference = made(scene);
  for (haustra_world* x : {w, reference}) {
    step_frames(x, 3);
    grasp_middle(x, 0);
    step_frames(x, 10);
  }
  REQUIRE(instrument_of(w, 0).grasping == 1);

  haustra_instrument_def retractor;
  REQUIRE(haustra_instrument_def_default(&retractor) == HAUSTRA_OK);
  retractor.name = "retractor";
  retractor.tip[0] = 2.0;
  retractor.tip[2] = 2.0;
  size_t index = 99;
  REQUIRE(haustra_world_add_instrument(w, &retractor, &index) == HAUSTRA_OK);
  CHECK(index == 1);
  haustra_obstacle_def sphere;
  REQUIRE(haustra_obstacle_def_default(&sphere) == HAUSTRA_OK);
  sphere.kind = HAUSTRA_OBSTACLE_SPHERE;
  sphere.point[0] = 3.0;
  REQUIRE(haustra_world_add_obstacle(w, &sphere, &index) == HAUSTRA_OK);
  CHECK(index == 0);
  haustra_obstacle_def wall;
  REQUIRE(haustra_obstacle_def_default(&wall) == HAUSTRA_OK);  // a second plane, far below
  wall.point[2] = -5.0;
  REQUIRE(haustra_world_add_obstacle(w, &wall, &index) == HAUSTRA_OK);
  CHECK(index == 1);
  haustra_attachment_def held;
  REQUIRE(haustra_attachment_def_default(&held) == HAUSTRA_OK);
  held.node = 15;
  held.active = 0;
  REQUIRE(haustra_world_add_attachment(w, 0, &held, &index) == HAUSTRA_OK);
  CHECK(index == 0);
  haustra_anchors_def tissue;
  REQUIRE(haustra_anchors_def_default(&tissue) == HAUSTRA_OK);
  tissue.from = 0.7;
  REQUIRE(haustra_world_add_anchors(w, 0, &tissue, &index) == HAUSTRA_OK);
  CHECK(index == 0);

  const haustra_counts c = counted(w);
  CHECK(c.instruments == 2);
  CHECK(c.obstacles[HAUSTRA_OBSTACLE_PLANE] == 2);
  CHECK(c.obstacles[HAUSTRA_OBSTACLE_SPHERE] == 1);
  CHECK(c.anchors == 7);  // nodes 14..20: from 0.7 of the length to its tip
  // The colon's attachments: the one added, then a grasp slot per instrument; the grasper's moved up
  // by one and still holds the middle node.
  size_t attachments = 0;
  REQUIRE(haustra_world_attachment_count(w, 0, &attachments) == HAUSTRA_OK);
  CHECK(attachments == 3);
  haustra_attachment_reading a = sized<haustra_attachment_reading>();
  REQUIRE(haustra_world_attachment(w, 0, 1, &a) == HAUSTRA_OK);
  CHECK(a.grasp_slot == 1);  // a coupled grasp holds through its spring, not this slot's constraint
  CHECK(a.instrument == 0);
  REQUIRE(haustra_world_attachment(w, 0, 0, &a) == HAUSTRA_OK);
  CHECK(a.grasp_slot == 0);
  CHECK(a.active == 0);
  CHECK(a.node == 15);
  CHECK(instrument_of(w, 0).grasping == 1);
  CHECK(node_bits(w) == node_bits(reference));

  // Out again, in another order than they came.
  REQUIRE(haustra_world_remove_obstacle(w, HAUSTRA_OBSTACLE_PLANE, 1) == HAUSTRA_OK);
  REQUIRE(haustra_world_remove_anchors(w, 0, 0) == HAUSTRA_OK);
  REQUIRE(haustra_world_remove_instrument(w, 1) == HAUSTRA_OK);
  REQUIRE(haustra_world_remove_attachment(w, 0, 0) == HAUSTRA_OK);
  REQUIRE(haustra_world_remove_obstacle(w, HAUSTRA_OBSTACLE_SPHERE, 0) == HAUSTRA_OK);
  const haustra_counts after = counted(w);
  CHECK(after.instruments == 1);
  CHECK(after.obstacles[HAUSTRA_OBSTACLE_PLANE] == 1);
  CHECK(after.obstacles[HAUSTRA_OBSTACLE_SPHERE] == 0);
  CHECK(after.anchors == 0);
  CHECK(instrument_of(w, 0).grasping == 1);
  for (int f = 0; f < 20; ++f) {
    REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
    REQUIRE(haustra_world_step(reference) == HAUSTRA_OK);
    INFO("frame " << f);
    REQUIRE(node_bits(w) == node_bits(reference));
    const haustra_instrument_reading r = instrument_of(w, 0), q = instrument_of(reference, 0);
    REQUIRE(std::memcmp(&r, &q, sizeof r) == 0);
  }
  CHECK(haustra_world_destroy(w) == HAUSTRA_OK);
  CHECK(haustra_world_destroy(reference) == HAUSTRA_OK);
}

TEST_CASE(
    "C API: parts added at run time act: a sphere the organ falls on, a second grasper, a held tip, tissue "
    "that pulls, and removing a grasper lets go of what it held") {
  const PartsScene scene;
  haustra_world* w = made(scene);
  haustra_obstacle_def sphere;
  REQUIRE(haustra_obstacle_def_default(&sphere) == HAUSTRA_OK);
  sphere.kind = HAUSTRA_OBSTACLE_SPHERE;
  sphere.point[0] = 0.3;
  sphere.point[2] = -0.09;  // on the floor under the colon's tip part, which sags onto it
  sphere.radius = 0.02;
  REQUIRE(haustra_world_add_obstacle(w, &sphere, nullptr) == HAUSTRA_OK);
  step_frames(w, 60);
  std::vector<haustra_contact> list(64);
  list[0].struct_size = sizeof(haustra_contact);
  size_t listed = 0, total = 0;
  REQUIRE(haustra_world_contacts(w, list.data(), list.size(), &listed, &total) == HAUSTRA_OK);
  CHECK(listed <= total);
  int on_sphere = 0;
  for (size_t i = 0; i < listed; ++i)
    if (list[i].kind == HAUSTRA_CONTACT_SPHERE && list[i].depth > 0.0) {
      ++on_sphere;
      CHECK(list[i].other == 0);
      const double push = list[i].force[0] * list[i].normal[0] + list[i].force[1] * list[i].normal[1] +
                          list[i].force[2] * list[i].normal[2];
      CHECK(push > 0.0);  // the sphere pushes the bead out
    }
  CHECK(on_sphere > 0);

  // A second grasper, added, grasps; the first is removed while grasping and lets go.
  grasp_middle(w, 0);
  step_frames(w, 5);
  REQUIRE(instrument_of(w, 0).grasping == 1);
  haustra_instrument_def second;
  REQUIRE(haustra_instrument_def_default(&second) == HAUSTRA_OK);
  second.grasp_reach = 0.015;
  size_t index = 0;
  REQUIRE(haustra_world_add_instrument(w, &second, &index) == HAUSTRA_OK);
  REQUIRE(index == 1);
  haustra_vec3_view v{};
  REQUIRE(haustra_world_node_positions(w, &v) == HAUSTRA_OK);
  const double tip[3] = {v.x[4], v.y[4], v.z[4] + 0.03}, up[3] = {0.0, 0.0, 1.0};
  REQUIRE(haustra_world_set_instrument_pose(w, 1, tip, up) == HAUSTRA_OK);
  REQUIRE(haustra_world_set_instrument_grasp(w, 1, 1) == HAUSTRA_OK);
  step_frames(w, 5);
  CHECK(instrument_of(w, 1).grasping == 1);
  CHECK(instrument_of(w, 1).grasped_node == 4);
  REQUIRE(haustra_world_remove_instrument(w, 0) == HAUSTRA_OK);
  CHECK(counted(w).instruments == 1);
  const haustra_instrument_reading kept = instrument_of(w, 0);  // the second, now first
  CHECK(kept.grasping == 1);
  CHECK(kept.grasped_node == 4);
  size_t attachments = 0;
  REQUIRE(haustra_world_attachment_count(w, 0, &attachments) == HAUSTRA_OK);
  CHECK(attachments == 1);  // the remaining grasper's slot

  // The tip held 5 cm above where it rests: it goes there.
  haustra_attachment_def held;
  REQUIRE(haustra_attachment_def_default(&held) == HAUSTRA_OK);
  held.has_target = 1;
  held.target[0] = 0.4;
  held.target[2] = 0.05;
  REQUIRE(haustra_world_add_attachment(w, 0, &held, &index) == HAUSTRA_OK);
  CHECK(index == 0);
  step_frames(w, 30);
  REQUIRE(haustra_world_node_positions(w, &v) == HAUSTRA_OK);
  CHECK(std::abs(v.x[20] - 0.4) < 1e-4);
  CHECK(std::abs(v.z[20] - 0.05) < 1e-4);
  haustra_attachment_reading a = sized<haustra_attachment_reading>();
  REQUIRE(haustra_world_attachment(w, 0, 0, &a) == HAUSTRA_OK);
  CHECK(a.node == 20);
  CHECK(a.force[2] > 0.0);  // it holds the tip up
  // Moved by the host: lower, and then let go.
  const double lower[3] = {0.4, 0.0, 0.0};
  REQUIRE(haustra_world_set_attachment_target(w, 0, 0, lower) == HAUSTRA_OK);
  step_frames(w, 30);
  REQUIRE(haustra_world_node_positions(w, &v) == HAUSTRA_OK);
  CHECK(std::abs(v.z[20]) < 1e-4);
  REQUIRE(haustra_world_set_attachment_active(w, 0, 0, 0) == HAUSTRA_OK);
  // The grasp slot is the instrument's to move.
  CHECK(haustra_world_set_attachment_active(w, 0, 1, 0) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(said("grasp slot"));

  // Tissue over the whole colon, holding each node towards where it rests: lifted and sagging, it pulls.
  haustra_anchors_def tissue;
  REQUIRE(haustra_anchors_def_default(&tissue) == HAUSTRA_OK);
  tissue.name = "mesocolon";
  REQUIRE(haustra_world_add_anchors(w, 0, &tissue, &index) == HAUSTRA_OK);
  size_t ranges = 0;
  REQUIRE(haustra_world_anchor_ranges(w, 0, &ranges) == HAUSTRA_OK);
  CHECK(ranges == 1);
  CHECK(counted(w).anchors == 21);
  const double lifted[3] = {tip[0], tip[1], tip[2] + 0.04};
  REQUIRE(haustra_world_set_instrument_pose(w, 0, lifted, up) == HAUSTRA_OK);
  step_frames(w, 20);
  std::vector<double> tensions(21);
  REQUIRE(haustra_world_anchor_tensions(w, tensions.data(), tensions.size()) == HAUSTRA_OK);
  CHECK(tensions[4] > 0.0);
  CHECK(haustra_world_destroy(w) == HAUSTRA_OK);
}

TEST_CASE("C API: a part the builder refuses is named by its field, and the world is left as it was") {
  const PartsScene scene;
  haustra_world* w = made(scene);
  step_frames(w, 2);
  const std::vector<double> before = node_bits(w);
  haustra_instrument_def in;
  REQUIRE(haustra_instrument_def_default(&in) == HAUSTRA_OK);
  in.radius = 2.0;
  CHECK(haustra_world_add_instrument(w, &in, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(said("instrument[1].radius"));
  in.radius = 0.004;
  in.proxy = 2;
  CHECK(haustra_world_add_instrument(w, &in, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(said("def.proxy = 2"));
  haustra_obstacle_def o;
  REQUIRE(haustra_obstacle_def_default(&o) == HAUSTRA_OK);
  o.kind = 9;
  CHECK(haustra_world_add_obstacle(w, &o, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(said("def.kind = 9"));
  o.kind = HAUSTRA_OBSTACLE_SPHERE;
  o.radius = -1.0;
  CHECK(haustra_world_add_obstacle(w, &o, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(said("environment.sphere[0].radius"));
  o.kind = HAUSTRA_OBSTACLE_PLANE;
  o.point[2] = 1e300;  // a floor no step can hold
  CHECK(haustra_world_add_obstacle(w, &o, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(said("environment.plane[1].point"));
  // A host's mesh is checked as a mesh file is: an open container, a degenerate triangle.
  const double corners[] = {0, 0, 0, 0.1, 0, 0, 0, 0.1, 0, 0, 0, 0.1};
  const uint32_t open[] = {0, 2, 1, 0, 1, 3, 0, 3, 2};
  o = haustra_obstacle_def{};
  REQUIRE(haustra_obstacle_def_default(&o) == HAUSTRA_OK);
  o.kind = HAUSTRA_OBSTACLE_MESH;
  o.vertices = corners;
  o.vertex_count = 4;
  o.triangles = open;
  o.triangle_count = 3;
  o.container = 1;
  CHECK(haustra_world_add_obstacle(w, &o, nullptr) == HAUSTRA_INVALID_GEOMETRY);
  CHECK(said("environment.mesh[0].container"));
  const uint32_t flat[] = {0, 1, 1};
  o.triangles = flat;
  o.triangle_count = 1;
  o.container = 0;
  CHECK(haustra_world_add_obstacle(w, &o, nullptr) == HAUSTRA_INVALID_GEOMETRY);
  CHECK(said("environment.mesh[0]"));
  haustra_attachment_def at;
  REQUIRE(haustra_attachment_def_default(&at) == HAUSTRA_OK);
  at.node = 21;
  CHECK(haustra_world_add_attachment(w, 0, &at, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(said("segment[0].attachment[0].node"));
  at.node = 0;  // a clamped base is held already
  CHECK(haustra_world_add_attachment(w, 0, &at, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(said("already held"));
  CHECK(haustra_world_add_attachment(w, 1, &at, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(said("segment index 1 out of range"));
  haustra_anchors_def an;
  REQUIRE(haustra_anchors_def_default(&an) == HAUSTRA_OK);
  an.from = 0.8;
  an.to = 0.2;
  CHECK(haustra_world_add_anchors(w, 0, &an, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(said("segment[0].anchors[0].to"));
  CHECK(haustra_world_remove_attachment(w, 0, 0) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(said("grasp slot of instrument 0"));
  CHECK(haustra_world_remove_instrument(w, 1) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(said("instrument index 1 out of range"));
  CHECK(haustra_world_remove_obstacle(w, HAUSTRA_OBSTACLE_CAPSULE, 0) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(said("capsule index 0 out of range"));
  CHECK(haustra_world_remove_obstacle(w, 4, 0) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_remove_anchors(w, 0, 0) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(haustra_world_add_instrument(w, nullptr, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  const haustra_counts c = counted(w);
  CHECK(c.instruments == 1);
  CHECK(c.obstacles[HAUSTRA_OBSTACLE_PLANE] == 1);
  CHECK(c.obstacles[HAUSTRA_OBSTACLE_SPHERE] + c.obstacles[HAUSTRA_OBSTACLE_MESH] == 0);
  CHECK(c.anchors == 0);
  CHECK(node_bits(w) == before);
  CHECK(haustra_world_destroy(w) == HAUSTRA_OK);
}

TEST_CASE(
    "C API: the nodes' velocities are their motion over the last frame, frames are unit quaternions, beads sit "
    "on their nodes") {
  const PartsScene scene;
  haustra_world* w = made(scene);
  const haustra_counts c = counted(w);
  std::vector<double> linear(3 * c.nodes, 1.0), angular(3 * c.nodes, 1.0);
  REQUIRE(haustra_world_node_velocities(w, linear.data(), angular.data(), linear.size()) == HAUSTRA_OK);
  for (double x : linear) CHECK(x == 0.0);  // before the first step
  step_frames(w, 4);
  const std::vector<double> before = node_bits(w);
  step_frames(w, 1);
  const std::vector<double> after = node_bits(w);
  REQUIRE(haustra_world_node_velocities(w, linear.data(), angular.data(), linear.size()) == HAUSTRA_OK);
  double fastest = 0.0;
  for (size_t k = 0; k < c.nodes; ++k)
    for (size_t i = 0; i < 3; ++i) {
      // The same arithmetic as the host's own difference of positions over dt: the same bits.
      CHECK(linear[3 * k + i] == (after[i * c.nodes + k] - before[i * c.nodes + k]) / 0.01);
      fastest = std::max(fastest, std::abs(linear[3 * k + i]));
    }
  CHECK(fastest > 0.01);  // the colon sags under gravity
  CHECK(haustra_world_node_velocities(w, linear.data(), nullptr, linear.size()) == HAUSTRA_OK);
  CHECK(haustra_world_node_velocities(w, linear.data(), angular.data(), 3) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(said("count = 3: expected 3 × 21 nodes = 63"));
  CHECK(haustra_world_node_velocities(w, nullptr, nullptr, linear.size()) == HAUSTRA_INVALID_ARGUMENT);

  haustra_quat_view q{};
  REQUIRE(haustra_world_node_rotations(w, &q) == HAUSTRA_OK);
  REQUIRE(q.count == c.nodes);
  for (size_t k = 0; k < q.count; ++k)
    CHECK(std::abs(q.w[k] * q.w[k] + q.x[k] * q.x[k] + q.y[k] * q.y[k] + q.z[k] * q.z[k] - 1.0) < 1e-12);
  const uint32_t* bead_nodes = nullptr;
  size_t beads = 0;
  REQUIRE(haustra_world_bead_nodes(w, &bead_nodes, &beads) == HAUSTRA_OK);
  REQUIRE(beads == 11);
  for (size_t b = 0; b < beads; ++b) CHECK(bead_nodes[b] == 2 * b);  // 11 beads spread over 21 nodes
  CHECK(haustra_world_bead_nodes(w, nullptr, &beads) == HAUSTRA_INVALID_ARGUMENT);
  // No room, no output: the count of what there is all the same.
  size_t listed = 9, total = 0;
  REQUIRE(haustra_world_contacts(w, nullptr, 0, &listed, &total) == HAUSTRA_OK);
  CHECK(listed == 0);
  CHECK(haustra_world_destroy(w) == HAUSTRA_OK);
}

TEST_CASE(
    "C API: structs carry their size: an older host's smaller def is read as far as it goes, a wrong size is "
    "refused and nothing written") {
  CHECK(haustra_abi_version() == HAUSTRA_ABI_VERSION);
  CHECK(haustra_check_abi(HAUSTRA_ABI_VERSION) == HAUSTRA_OK);
  CHECK(haustra_check_abi(HAUSTRA_ABI_OLDEST) == HAUSTRA_OK);
  CHECK(haustra_check_abi(14) == HAUSTRA_ABI_MISMATCH);
  CHECK(said("took the stage \"prefactor\""));
  CHECK(haustra_check_abi(13) == HAUSTRA_ABI_MISMATCH);
  CHECK(said("structs before ABI 14 carry no size"));
  CHECK(haustra_check_abi(HAUSTRA_ABI_VERSION + 1) == HAUSTRA_ABI_MISMATCH);
  CHECK(said("newer than the library"));

  const PartsScene scene;
  haustra_world* w = made(scene);
  // An output: with no size, or a newer header's, it is refused and left as it was.
  haustra_counts c{};
  c.segments = 77;
  CHECK(haustra_world_counts(w, &c) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(said("out.struct_size = 0"));
  CHECK(c.segments == 77);
  c.struct_size = sizeof c + 8;
  CHECK(haustra_world_counts(w, &c) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(said("a newer header's"));
  CHECK(c.segments == 77);
  haustra_event events[2];
  events[0].struct_size = 3;
  size_t n = 0;
  CHECK(haustra_world_take_events(w, events, 2, &n, nullptr) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(said("out[0].struct_size = 3"));
  CHECK(haustra_world_destroy(w) == HAUSTRA_OK);

  // A def of the size haustra_world_def had before ABI 13's frame limits: what lies past it in the
  // host's memory is not read, and the limits take their defaults.
  haustra_world_def def;
  REQUIRE(haustra_world_def_default(&def) == HAUSTRA_OK);
  def.struct_size = offsetof(haustra_world_def, max_substeps);
  def.threads = 1;
  def.max_substeps = -5;  // would be refused if read
  def.max_retries = 1000;
  haustra_segment_def seg;
  REQUIRE(haustra_segment_def_default(&seg) == HAUSTRA_OK);
  seg.nodes = 11;
  seg.length = 0.3;
  seg.anchor_stiffness = 500.0;  // past the size of haustra_segment_def before ABI 11: not read
  seg.struct_size = offsetof(haustra_segment_def, max_rings_per_vertex);
  REQUIRE(haustra_world_create(&def, &seg, 1, &w) == HAUSTRA_OK);
  haustra_frame_limits l = sized<haustra_frame_limits>();
  REQUIRE(haustra_world_frame_limits(w, &l) == HAUSTRA_OK);
  CHECK(l.max_substeps == 64);
  CHECK(l.max_retries == 16);
  CHECK(counted(w).anchors == 0);
  CHECK(counted(w).nodes == 11);
  CHECK(haustra_world_destroy(w) == HAUSTRA_OK);
  seg.struct_size = sizeof seg;  // the whole def: the anchors are read
  REQUIRE(haustra_world_create(&def, &seg, 1, &w) == HAUSTRA_OK);
  CHECK(counted(w).anchors == 11);
  CHECK(haustra_world_destroy(w) == HAUSTRA_OK);
  def.struct_size = offsetof(haustra_world_def, max_substeps) + 4;  // no size the struct ever had
  CHECK(haustra_world_create(&def, &seg, 1, &w) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(said("def.struct_size"));
}

TEST_CASE(
    "C API: the estimate of a scene and of the same world from definitions are one estimate, and a world of "
    "beads packed past what fits is refused up front saying so") {
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() / ("haustra-c-estimate-" + std::to_string(::getpid()) + ".toml");
  std::ofstream(file) << "[world]\ndt = 0.01\n[[segment]]\nname = \"colon\"\nnodes = 2001\n[segment.rest]\n"
                         "length = 0.4\n[segment.beads]\ncount = 400\n[segment.mesh]\nsource = \"procedural\"\n"
                         "[segment.mesh.procedural]\nvertices = 1500\n";
  haustra_estimate from_scene = sized<haustra_estimate>(), from_defs = sized<haustra_estimate>();
  REQUIRE(haustra_estimate_scene(file.c_str(), nullptr, &from_scene) == HAUSTRA_OK);
  std::filesystem::remove(file);
  haustra_world_def def;
  REQUIRE(haustra_world_def_default(&def) == HAUSTRA_OK);
  def.dt = 0.01;
  haustra_segment_def seg;
  REQUIRE(haustra_segment_def_default(&seg) == HAUSTRA_OK);
  seg.name = "colon";
  seg.nodes = 2001;
  seg.length = 0.4;
  seg.beads = 400;
  seg.mesh = 1;
  seg.mesh_vertices = 1500;
  REQUIRE(haustra_estimate_world(&def, &seg, 1, &from_defs) == HAUSTRA_OK);
  from_defs.available = from_scene.available;  // the machine's, read at each call
  CHECK(std::memcmp(&from_scene, &from_defs, sizeof from_defs) == 0);
  CHECK(from_scene.nodes == 2001);
  CHECK(from_scene.beads == 400);
  // 400 beads of 2 cm, 1.0025 mm apart: each within reach (2 r + the 1 cm margin) of its 49 next.
  CHECK(from_scene.bead_pairs == 400 * 49 - 49 * 50 / 2);
  CHECK(from_scene.build_seconds > 0.0);
  CHECK(from_scene.step_seconds > 0.0);

  // Issue 36's host: a million nodes, 300,000 beads of 2 cm on 1.66 m (each overlapping ten thousand
  // neighbours) passed the old estimate and ran out of memory after 100 s of building.
  seg.nodes = 1'000'000;
  seg.length = 1.66;
  seg.beads = 300'000;
  seg.mesh = 0;
  REQUIRE(haustra_estimate_world(&def, &seg, 1, &from_defs) == HAUSTRA_OK);
  CHECK(from_defs.bead_pairs > 2'000'000'000);
  CHECK(from_defs.total > 100'000'000'000);
  def.memory_limit = 8e9;
  haustra_world* w = nullptr;
  CHECK(haustra_world_create(&def, &seg, 1, &w) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(said("pairs of beads within reach"));
  CHECK(said("300000 beads overlap many neighbours each: fewer or smaller beads"));
  CHECK(w == nullptr);
  CHECK(haustra_estimate_world(&def, &seg, 1, nullptr) == HAUSTRA_INVALID_ARGUMENT);
}

TEST_CASE("C API: a frame stopped by a bead deep in an instrument's capsule names the capsule, not the environment") {
  // Issue 36: the instrument's own capsule was called "the environment" in an unstable stop. A
  // kinematic retractor commanded straight through the middle bead, the contact too soft to push
  // the bead out within the frame, and the robust mode off.
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() / ("haustra-c-capsule-" + std::to_string(::getpid()) + ".toml");
  std::ofstream(file) << "[world]\ndt = 0.01\ngravity = [0.0, 0.0, 0.0]\n[solver]\non_instability = \"stop\"\n"
                         "[contact]\ncoefficient = 1e-3\n[[segment]]\nname = \"colon\"\nnodes = 21\n[segment.rest]\n"
                         "length = 0.4\n[segment.beads]\ncount = 11\n[[instrument]]\nname = \"retractor\"\n"
                         "proxy = false\ntip = [0.2, 0.0, 0.3]\n";
  haustra_world* w = nullptr;
  REQUIRE(haustra_world_create_from_scene(file.c_str(), 1, &w) == HAUSTRA_OK);
  std::filesystem::remove(file);
  step_frames(w, 1);
  const double tip[3] = {0.2, 0.0, -0.1}, axis[3] = {0.0, 0.0, 1.0};
  REQUIRE(haustra_world_set_instrument_pose(w, 0, tip, axis) == HAUSTRA_OK);
  CHECK(haustra_world_step(w) == HAUSTRA_UNSTABLE);
  CHECK(said("node 10: bead's depth into an instrument's capsule (bead radii) 1.2 exceeds the limit 1"));
  CHECK(!said("environment"));
  CHECK(haustra_world_destroy(w) == HAUSTRA_OK);
}

TEST_CASE("C API: a NaN centreline point is named as not finite, a surface given as a scene is named a surface") {
  // Issue 36: a NaN point was reported as "points i and j are the same point", a surface answered
  // with a TOML syntax error.
  haustra_world_def def;
  REQUIRE(haustra_world_def_default(&def) == HAUSTRA_OK);
  haustra_segment_def seg;
  REQUIRE(haustra_segment_def_default(&seg) == HAUSTRA_OK);
  const double points[] = {0.0, 0.0, 0.0, 0.1, 0.0, 0.0, std::nan(""), 0.0, 0.0, 0.3, 0.0, 0.0};
  seg.centreline = points;
  seg.centreline_points = 4;
  haustra_world* w = nullptr;
  CHECK(haustra_world_create(&def, &seg, 1, &w) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(said("segments[0].centreline: point 2 is not finite"));
  CHECK(!said("same point"));
  const std::filesystem::path surface =
      std::filesystem::temp_directory_path() / ("haustra-c-surface-" + std::to_string(::getpid()) + ".obj");
  std::ofstream(surface) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  CHECK(haustra_world_create_from_scene(surface.c_str(), 1, &w) == HAUSTRA_PARSE);
  CHECK(said("a surface (.obj), not a scene file: `haustra import"));
  std::filesystem::remove(surface);
  CHECK(w == nullptr);
}
