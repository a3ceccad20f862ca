// Skinning on the host's GPU (decisions 0110, 0122): render/shaders/haustra_skin.glsl run by Mesa (under
// Xvfb) with transform feedback over every mesh vertex of a deformed organ, against the engine's CPU
// skinning of the same frame (the cage's rigid groups and the along-rod screws): positions to
// 1e-6 m, normals to a stated angle; and a perturbed weight must fail the same comparison.
#include <doctest/doctest.h>

#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "gpu_skin_gl.hpp"
#include "scene_fixtures.hpp"

namespace haustra {
namespace {

// One hidden GL 3.3 core context for the whole process (made once: initializing GLFW again after
// a terminate fails now and then under Xvfb), current on the calling thread.
std::string g_glfw_error;

GLFWwindow* make_window() {
  glfwSetErrorCallback([](int, const char* text) { g_glfw_error = text; });
  if (glfwInit() != GLFW_TRUE) return nullptr;
  glfwWindowHint(GLFW_VISIBLE, GLFW_FALSE);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  return glfwCreateWindow(16, 16, "gpu skin test", nullptr, nullptr);
}

struct Context {
  Context() {
    static GLFWwindow* const window = make_window();
    INFO("GLFW: " << g_glfw_error);
    REQUIRE(window != nullptr);
    glfwMakeContextCurrent(window);
    MESSAGE("GL " << std::string(reinterpret_cast<const char*>(glGetString(GL_VERSION))) << " on "
                  << std::string(reinterpret_cast<const char*>(glGetString(GL_RENDERER))));
  }
};

constexpr const char* kMain = R"(
layout(location = 0) in vec3 rest_position;
layout(location = 1) in vec3 rest_normal;
layout(location = 3) in uvec2 slots;
out vec3 skinned_position;
out vec3 skinned_normal;
void main() {
  haustra_skin(rest_position, rest_normal, slots, skinned_position, skinned_normal);
  gl_Position = vec4(skinned_position, 1.0);
}
)";

unsigned feedback_program() {
  const std::string source = view::skin_vertex_shader(kMain);
  const char* text = source.c_str();
  const unsigned vs = glCreateShader(GL_VERTEX_SHADER);
  glShaderSource(vs, 1, &text, nullptr);
  glCompileShader(vs);
  int ok = 0;
  glGetShaderiv(vs, GL_COMPILE_STATUS, &ok);
  std::string log(4096, '\0');
  glGetShaderInfoLog(vs, static_cast<int>(log.size()), nullptr, log.data());
  INFO(log.c_str());
  REQUIRE(ok != 0);
  const unsigned program = glCreateProgram();
  glAttachShader(program, vs);
  const char* varyings[] = {"skinned_position", "skinned_normal"};
  glTransformFeedbackVaryings(program, 2, varyings, GL_INTERLEAVED_ATTRIBS);
  glLinkProgram(program);
  glDeleteShader(vs);
  glGetProgramiv(program, GL_LINK_STATUS, &ok);
  REQUIRE(ok != 0);
  return program;
}

struct Skinned {
  std::vector<float> out;  // 6 a vertex: position, normal
  [[nodiscard]] Eigen::Vector3d position(std::size_t v) const { return {out[6 * v], out[6 * v + 1], out[6 * v + 2]}; }
  [[nodiscard]] Eigen::Vector3d normal(std::size_t v) const { return {out[6 * v + 3], out[6 * v + 4], out[6 * v + 5]}; }
};

// Every mesh vertex through the shader, its outputs read back from the transform feedback buffer.
Skinned run_shader(const GpuSkinBinding& b, std::span<const float> rings) {
  std::vector<std::uint32_t> all(b.vertices);
  for (std::uint32_t v = 0; v < all.size(); ++v) all[v] = v;
  const std::vector<view::SkinVertex> vertices = view::skin_vertices(b, all);
  const unsigned program = feedback_program();
  view::GpuSkinBuffers buffers;
  buffers.upload_binding(b);
  buffers.upload_rings(rings);
  unsigned vao = 0, vbo = 0, tfo = 0;
  glGenVertexArrays(1, &vao);
  glBindVertexArray(vao);
  glGenBuffers(1, &vbo);
  glBindBuffer(GL_ARRAY_BUFFER, vbo);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(vertices.size() * sizeof(view::SkinVertex)), vertices.data(),
               GL_STATIC_DRAW);
  view::GpuSkinBuffers::vertex_attributes(3);
  Skinned s;
  s.out.assign(6 * b.vertices, 0.0f);
  glGenBuffers(1, &tfo);
  glBindBuffer(GL_TRANSFORM_FEEDBACK_BUFFER, tfo);
  glBufferData(GL_TRANSFORM_FEEDBACK_BUFFER, static_cast<GLsizeiptr>(s.out.size() * sizeof(float)), nullptr,
               GL_STREAM_READ);
  glBindBufferBase(GL_TRANSFORM_FEEDBACK_BUFFER, 0, tfo);
  glUseProgram(program);
  buffers.bind(program, 0);
  glEnable(GL_RASTERIZER_DISCARD);
  glBeginTransformFeedback(GL_POINTS);
  glDrawArrays(GL_POINTS, 0, static_cast<GLsizei>(b.vertices));
  glEndTransformFeedback();
  glDisable(GL_RASTERIZER_DISCARD);
  glGetBufferSubData(GL_TRANSFORM_FEEDBACK_BUFFER, 0, static_cast<GLsizeiptr>(s.out.size() * sizeof(float)),
                     s.out.data());
  REQUIRE(glGetError() == GL_NO_ERROR);
  glDeleteBuffers(1, &tfo);
  glDeleteBuffers(1, &vbo);
  glDeleteVertexArrays(1, &vao);
  glDeleteProgram(program);
  return s;
}

struct Errors {
  double position = 0.0, moved = 0.0;         // m: the worst vertex against the CPU; the most a vertex moved from rest
  double normal_max = 0.0, normal_p99 = 0.0;  // degrees against the CPU's normals
};

Errors compare(const World& w, const GpuSkinBinding& b, const Skinned& gpu) {
  const auto p = w.mesh_positions();
  const auto n = w.mesh_normals();
  Errors e;
  std::vector<double> angles;
  for (std::size_t v = 0; v < b.vertices; ++v) {
    const Eigen::Vector3d cpu(p.x[v], p.y[v], p.z[v]);
    e.position = std::max(e.position, (gpu.position(v) - cpu).norm());
    const Eigen::Vector3d rest(b.rest_position[3 * v], b.rest_position[3 * v + 1], b.rest_position[3 * v + 2]);
    e.moved = std::max(e.moved, (cpu - rest).norm());
    const Eigen::Vector3d cn(n.x[v], n.y[v], n.z[v]);
    if (cn.norm() < 0.5) continue;  // a vertex of no triangle
    angles.push_back(std::acos(std::clamp(gpu.normal(v).normalized().dot(cn.normalized()), -1.0, 1.0)) * 180.0 / M_PI);
  }
  std::sort(angles.begin(), angles.end());
  if (!angles.empty()) {
    e.normal_max = angles.back();
    e.normal_p99 = angles[angles.size() * 99 / 100];
  }
  return e;
}

// The shader against the CPU on this frame, and the host's CPU reference (gpu_skin_vertex) too.
Errors check_frame(const World& w, const std::string& what, double moved_at_least = 0.05) {
  const GpuSkinBinding& b = w.gpu_skin_binding();
  std::vector<float> rings(kGpuRingDataFloats * w.ring_count());
  w.gpu_ring_frame(rings);
  const Skinned gpu = run_shader(b, rings);
  const Errors e = compare(w, b, gpu);
  MESSAGE(what << ": " << b.vertices << " vertices, " << b.slots() << " slots (at most " << b.max_slots
               << " a vertex); moved up to " << e.moved << " m; shader vs CPU " << e.position << " m, normals "
               << e.normal_max << " deg at most, " << e.normal_p99 << " deg 99th pct");
  CHECK(e.moved > moved_at_least);  // a deformed organ, not the rest pose
  CHECK(e.position <= 1e-6);        // the issue's bound
  const auto p = w.mesh_positions();
  double reference = 0.0;
  for (std::size_t v = 0; v < b.vertices; ++v)
    reference =
        std::max(reference, (gpu_skin_vertex(b, rings, v).position - Eigen::Vector3d(p.x[v], p.y[v], p.z[v])).norm());
  CHECK(reference <= 1e-6);
  return e;
}

// The demo organ (4,000 vertices) with `skin`, checked twice: lifted by the scene's grasper (100
// frames, 1.7 s), then bent through 90° and twisted through 90° over the middle fifth of its 1 m rod.
std::pair<Errors, Errors> lifted_then_bent(const std::string& skin, const std::string& label) {
  auto w = test::scene_world("demo", 1, {"segment.mesh.procedural.vertices=4000", "segment.mesh.skinning=" + skin});
  for (int f = 0; f < 100; ++f) w->step();
  const Errors lifted = check_frame(*w, label + "lifted");
  const auto rest = w->rest_strains();
  std::vector<double> strains(rest.data.begin(), rest.data.end());
  const std::size_t n = w->node_count();
  const double span = 0.2;  // m of a 1 m rod
  for (std::size_t k = 2 * n / 5; k < 3 * n / 5; ++k) {
    strains[4 * k] += (M_PI / 2) / span;
    strains[4 * k + 2] += (M_PI / 2) / span;
  }
  w->pose_rod(0, w->base_pose(0), strains);
  return {lifted, check_frame(*w, label + "bent and twisted")};
}

// The CT colon (a mesh file) cut into a chain of three pieces with `skin`, grasped and pulled for
// 40 frames so the pieces bend apart at their cuts: the vertices on a cut are copies in two pieces,
// each skinned on its own and welded to their mean (decision 0060's weld); the shader sums the
// copies' slots, each at 1/n.
Errors colon_in_three_pieces(const std::string& skin, const std::string& label) {
  SceneDesc scene = test::scene_desc("anatomy-grasp", {"segment.mesh.skinning=" + skin});
  SegmentDesc& seg = scene.world.segments[0];
  seg.nodes = 55;
  seg.chain_pieces = 3;
  seg.beads.count = 18;
  seg.beads.radius_from_mesh = false;
  seg.beads.radius = 0.018;
  auto w = create_world(scene);
  for (int f = 0; f < 40; ++f) w->step();
  return check_frame(*w, label + "CT colon, 3 pieces", 0.03);
}

}  // namespace

TEST_CASE("the skinning shader gives the CPU's mesh to 1e-6 m on a lifted, bent and twisted organ") {
  const Context gl;
  const auto [lifted, bent] = lifted_then_bent("cage", "");
  // Normals: the shader turns the rest normal by the rings' blended rotation; the CPU's come from
  // the skinned neighbours. Measured 2.4° (99th percentile) and 4.8° at most (docs/skinning.md).
  CHECK(std::max(lifted.normal_p99, bent.normal_p99) <= 5.0);
  CHECK(std::max(lifted.normal_max, bent.normal_max) <= 10.0);
}

TEST_CASE("the skinning shader closes a chain's cut as the CPU's weld does (the CT colon in three pieces)") {
  const Context gl;
  const Errors e = colon_in_three_pieces("cage", "");
  // Its normals are further from the CPU's than the procedural organ's: rings 7 mm apart on a
  // 15–20 mm colon, so a vertex's weights change fast along the rod and the pull stretches the wall,
  // which the rings' blended rotation does not see. Measured 10.5° (99th percentile), 24.6° at most.
  CHECK(e.normal_p99 <= 20.0);
  CHECK(e.normal_max <= 45.0);
}

// Decision 0122: along the rod each vertex is a screw in the shader too; its normal is the rest
// normal turned by the screw's rotation (exact for a rigid cross-section).
TEST_CASE("the skinning shader follows the along-rod screws: an organ lifted, bent and twisted; a chain's cut") {
  const Context gl;
  const auto [lifted, bent] = lifted_then_bent("along-rod", "along the rod, ");
  // The screw turns the rest normal with the cross-section; the CPU's come from the skinned
  // neighbours, which also see the wall stretched by the grasp. Measured 4.0° (99th percentile)
  // and 10.7° at most, lifted.
  CHECK(std::max(lifted.normal_p99, bent.normal_p99) <= 5.0);
  CHECK(std::max(lifted.normal_max, bent.normal_max) <= 20.0);
  const Errors cut = colon_in_three_pieces("along-rod", "along the rod, ");
  CHECK(cut.normal_p99 <= 20.0);
  CHECK(cut.normal_max <= 45.0);
}

TEST_CASE("the comparison fails for a binding off by one weight in a hundred") {
  const Context gl;
  auto w = test::scene_world("demo", 1, {"segment.mesh.procedural.vertices=4000"});
  for (int f = 0; f < 100; ++f) w->step();
  GpuSkinBinding b = w->gpu_skin_binding();
  std::vector<float> rings(kGpuRingDataFloats * w->ring_count());
  w->gpu_ring_frame(rings);
  // The vertex that moved most: its first slot's b and A scaled by 1.01.
  const auto p = w->mesh_positions();
  std::size_t worst = 0;
  double moved = 0.0;
  for (std::size_t v = 0; v < b.vertices; ++v) {
    const double d = (Eigen::Vector3d(p.x[v], p.y[v], p.z[v]) -
                      Eigen::Vector3d(b.rest_position[3 * v], b.rest_position[3 * v + 1], b.rest_position[3 * v + 2]))
                         .norm();
    if (d > moved) moved = d, worst = v;
  }
  for (int c = 0; c < 4; ++c) b.slot_coefficient[4 * b.slot_range[2 * worst] + c] *= 1.01f;
  const Errors e = compare(*w, b, run_shader(b, rings));
  MESSAGE("perturbed: shader vs CPU " << e.position << " m");
  CHECK(e.position > 1e-5);
}

}  // namespace haustra
