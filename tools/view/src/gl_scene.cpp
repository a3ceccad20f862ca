// OpenGL 3.3 core drawing of a published frame: one lit shader over three batches (opaque
// triangles, the organ, lines); the organ see-through when an overlay must show inside it.
#include "gl_scene.hpp"

#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>
#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>

#include "haustra/error.hpp"
#include "haustra/mesh_io.hpp"
#include "haustra/render/shapes.hpp"

namespace haustra::view {
namespace {

using render::Rgb;

constexpr const char* kVertexShader = R"(#version 330 core
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
layout(location = 2) in vec4 colour;
uniform mat4 view_projection;
out vec3 world_position;
out vec3 world_normal;
out vec4 vertex_colour;
void main() {
  gl_Position = view_projection * vec4(position, 1.0);
  world_position = position;
  world_normal = normal;
  vertex_colour = colour;
}
)";

constexpr const char* kFragmentShader = R"(#version 330 core
in vec3 world_position;
in vec3 world_normal;
in vec4 vertex_colour;
uniform vec3 eye;
uniform int lit;
out vec4 fragment;
void main() {
  if (lit == 0) { fragment = vec4(pow(vertex_colour.rgb, vec3(1.0 / 2.2)), vertex_colour.a); return; }
  vec3 n = normalize(world_normal);
  vec3 v = normalize(eye - world_position);
  if (dot(n, v) < 0.0) n = -n;  // open meshes and inner walls: light the side we see
  vec3 sun = normalize(vec3(0.4, -0.3, 0.85));
  vec3 fill = normalize(vec3(-0.6, 0.5, 0.3));
  float diffuse = 0.75 * max(dot(n, sun), 0.0) + 0.25 * max(dot(n, fill), 0.0);
  float specular = 0.25 * pow(max(dot(n, normalize(sun + v)), 0.0), 32.0);
  vec3 c = vertex_colour.rgb * (0.28 + diffuse) + vec3(specular);
  fragment = vec4(pow(c, vec3(1.0 / 2.2)), vertex_colour.a);  // linear colours to the screen's sRGB
}
)";

unsigned compile(unsigned kind, const char* source) {
  const unsigned shader = glCreateShader(kind);
  glShaderSource(shader, 1, &source, nullptr);
  glCompileShader(shader);
  int ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (ok == 0) {
    std::string log(4096, '\0');
    glGetShaderInfoLog(shader, static_cast<int>(log.size()), nullptr, log.data());
    throw Error(ErrorCode::internal, fmt::format("the viewer's shader does not compile: {}", log.c_str()));
  }
  return shader;
}

Vertex vertex(const Eigen::Vector3d& p, const Eigen::Vector3d& n, Rgb c, float alpha = 1.0f) {
  return {{static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())},
          {static_cast<float>(n.x()), static_cast<float>(n.y()), static_cast<float>(n.z())},
          {c.r, c.g, c.b, alpha}};
}

void append(Batch& b, const render::Soup& s, Rgb colour) {
  const auto base = static_cast<std::uint32_t>(b.vertices.size());
  for (std::size_t i = 0; i < s.vertices.size(); ++i)
    b.vertices.push_back(vertex(s.vertices[i], i < s.normals.size() ? s.normals[i] : Eigen::Vector3d::UnitZ(), colour));
  for (const auto& t : s.triangles)
    for (std::uint32_t v : t) b.indices.push_back(base + v);
}

void line(Batch& b, const Eigen::Vector3d& a, const Eigen::Vector3d& c, Rgb colour, float alpha = 1.0f) {
  const auto base = static_cast<std::uint32_t>(b.vertices.size());
  b.vertices.push_back(vertex(a, Eigen::Vector3d::UnitZ(), colour, alpha));
  b.vertices.push_back(vertex(c, Eigen::Vector3d::UnitZ(), colour, alpha));
  b.indices.push_back(base);
  b.indices.push_back(base + 1);
}

Eigen::Vector3d node(const FramePublisher::Slot& f, std::size_t k) { return {f.x[k], f.y[k], f.z[k]}; }

// A cone from `base` to `apex` (the force arrow's head).
void add_cone(render::Soup& s, const Eigen::Vector3d& base, const Eigen::Vector3d& apex, double radius) {
  const Eigen::Vector3d axis = (apex - base).normalized();
  const auto [u, v] = render::across(axis);
  const auto first = static_cast<std::uint32_t>(s.vertices.size());
  constexpr int kSides = 16;
  for (int k = 0; k < kSides; ++k) {
    const double a = 2.0 * std::numbers::pi * k / kSides;
    const Eigen::Vector3d r = std::cos(a) * u + std::sin(a) * v;
    s.vertices.push_back(base + radius * r);
    s.normals.push_back((r + axis * radius / (apex - base).norm()).normalized());
  }
  s.vertices.push_back(apex);
  s.normals.push_back(axis);
  for (int k = 0; k < kSides; ++k)
    s.triangles.push_back(
        {first + static_cast<std::uint32_t>(k), first + static_cast<std::uint32_t>((k + 1) % kSides), first + kSides});
}

const Rgb kTissue{0.80f, 0.42f, 0.40f};
const Rgb kBead{0.55f, 0.62f, 0.85f};
const Rgb kCage{0.15f, 0.35f, 0.95f};
const Rgb kCentreline{0.95f, 0.80f, 0.10f};
const Rgb kContact{0.95f, 0.10f, 0.08f};
const Rgb kAnchor{0.25f, 0.70f, 0.30f};  // connective tissue that holds
const Rgb kTorn{0.85f, 0.05f, 0.55f};    // where it tore or was cut
const Rgb kInstrument{0.55f, 0.57f, 0.60f};
const Rgb kObstacle{0.60f, 0.63f, 0.55f};
const Rgb kBody{0.80f, 0.70f, 0.62f};  // a container, seen from inside
const Rgb kFloor{0.78f, 0.78f, 0.76f};
const Rgb kGrid{0.45f, 0.45f, 0.47f};
const Rgb kForce{0.95f, 0.55f, 0.05f};

}  // namespace

GlScene::GlScene() {
  const unsigned vs = compile(GL_VERTEX_SHADER, kVertexShader), fs = compile(GL_FRAGMENT_SHADER, kFragmentShader);
  program_ = glCreateProgram();
  glAttachShader(program_, vs);
  glAttachShader(program_, fs);
  glLinkProgram(program_);
  glDeleteShader(vs);
  glDeleteShader(fs);
  int ok = 0;
  glGetProgramiv(program_, GL_LINK_STATUS, &ok);
  if (ok == 0) throw Error(ErrorCode::internal, "the viewer's shaders do not link");
  vp_location_ = glGetUniformLocation(program_, "view_projection");
  eye_location_ = glGetUniformLocation(program_, "eye");
  lit_location_ = glGetUniformLocation(program_, "lit");
  for (Batch* b : {&opaque_, &organ_, &lines_, &planes_}) {
    glGenVertexArrays(1, &b->vao);
    glGenBuffers(1, &b->vbo);
    glGenBuffers(1, &b->ebo);
    glBindVertexArray(b->vao);
    glBindBuffer(GL_ARRAY_BUFFER, b->vbo);
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, b->ebo);
    glEnableVertexAttribArray(0);
    glEnableVertexAttribArray(1);
    glEnableVertexAttribArray(2);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(Vertex), reinterpret_cast<void*>(offsetof(Vertex, p)));
    glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, sizeof(Vertex), reinterpret_cast<void*>(offsetof(Vertex, n)));
    glVertexAttribPointer(2, 4, GL_FLOAT, GL_FALSE, sizeof(Vertex), reinterpret_cast<void*>(offsetof(Vertex, c)));
  }
  glBindVertexArray(0);
}

GlScene::~GlScene() {
  for (Batch* b : {&opaque_, &organ_, &lines_, &planes_}) {
    glDeleteBuffers(1, &b->vbo);
    glDeleteBuffers(1, &b->ebo);
    glDeleteVertexArrays(1, &b->vao);
  }
  glDeleteProgram(program_);
}

void GlScene::build(const FramePublisher::Slot& f, const ModelInfo& m, const DrawOptions& o) {
  opaque_.clear();
  organ_.clear();
  lines_.clear();
  planes_.clear();
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (std::size_t k = 0; k < f.x.size(); ++k) {
    lo = lo.cwiseMin(node(f, k));
    hi = hi.cwiseMax(node(f, k));
  }
  if (f.x.empty()) lo = hi = Eigen::Vector3d::Zero();
  subject_centre_ = 0.5 * (lo + hi);
  subject_size_ = std::max((hi - lo).norm(), 0.05);
  build_organ(f, m, o);
  build_overlays(f, m, o);
  build_surroundings(f, m, o);
  for (Batch* b : {&opaque_, &organ_, &lines_, &planes_}) upload(*b);
}

void GlScene::build_organ(const FramePublisher::Slot& f, const ModelInfo& m, const DrawOptions& o) {
  organ_transparent_ = o.beads || o.cage || o.centreline;
  const float alpha = organ_transparent_ ? 0.35f : 1.0f;
  organ_.vertices.resize(f.px.size());
  for (std::size_t v = 0; v < f.px.size(); ++v) {
    Rgb c = kTissue;
    if (o.colour == Colouring::strain && v < m.vertex_node.size()) {
      const std::size_t k = m.vertex_node[v];
      const double d1 = f.details.strain[4 * k] - f.details.rest_strain[4 * k];
      const double d2 = f.details.strain[4 * k + 1] - f.details.rest_strain[4 * k + 1];
      c = render::colormap(std::hypot(d1, d2) / std::max(o.strain_range, 1e-9));
    }
    organ_.vertices[v] = {{f.px[v], f.py[v], f.pz[v]}, {f.nx[v], f.ny[v], f.nz[v]}, {c.r, c.g, c.b, alpha}};
  }
  organ_.indices.reserve(3 * m.triangles.size());
  for (const auto& t : m.triangles) organ_.indices.insert(organ_.indices.end(), t.begin(), t.end());
  // A segment without a mesh is drawn as a tube along its nodes.
  render::Soup tubes;
  for (std::size_t s = 0; s < m.segment_nodes.size(); ++s) {
    if (m.meshes[s].enabled) continue;
    std::vector<Eigen::Vector3d> pts;
    for (std::size_t k = 0; k < m.segment_nodes[s].count; ++k) pts.push_back(node(f, m.segment_nodes[s].offset + k));
    add_tube(tubes, pts, m.desc.segments[std::min(s, m.desc.segments.size() - 1)].cross_section.radius, 16);
  }
  const auto base = static_cast<std::uint32_t>(organ_.vertices.size());
  for (std::size_t i = 0; i < tubes.vertices.size(); ++i) {
    Vertex vx = vertex(tubes.vertices[i], tubes.normals[i], kTissue, alpha);
    organ_.vertices.push_back(vx);
  }
  for (const auto& t : tubes.triangles)
    for (std::uint32_t v : t) organ_.indices.push_back(base + v);
}

void GlScene::build_overlays(const FramePublisher::Slot& f, const ModelInfo& m, const DrawOptions& o) {
  const FrameDetails& d = f.details;
  if (o.beads || o.colour == Colouring::penetration) {
    std::vector<double> depth(m.bead_nodes.size(), 0.0);
    for (const Contact& c : d.contacts) {
      if (c.depth <= 0.0) continue;
      if (c.bead < depth.size()) depth[c.bead] = std::max(depth[c.bead], c.depth / m.bead_radii[c.bead]);
      if (c.kind == ContactKind::bead && c.other < depth.size())
        depth[c.other] = std::max(depth[c.other], c.depth / m.bead_radii[c.other]);
    }
    for (std::size_t i = 0; i < m.bead_nodes.size(); ++i) {
      render::Soup s;
      render::add_sphere(s, node(f, m.bead_nodes[i]), m.bead_radii[i], 8);
      append(opaque_, s, o.colour == Colouring::penetration ? render::colormap(depth[i] / 0.05) : kBead);
    }
  }
  if (o.centreline)
    for (const Range& r : m.segment_nodes)
      for (std::size_t k = r.offset; k + 1 < r.offset + r.count; ++k)
        line(lines_, node(f, k), node(f, k + 1), kCentreline);
  if (o.cage)
    for (std::size_t s = 0; s < d.cages.size() && s < m.cage_triangles.size(); ++s) {
      const auto& cv = d.cages[s];
      if (cv.empty()) continue;
      for (const auto& t : m.cage_triangles[s])
        for (int i = 0; i < 3; ++i) {
          const std::uint32_t a = t[static_cast<std::size_t>(i)], b = t[static_cast<std::size_t>((i + 1) % 3)];
          if (a < b && a < cv.size() && b < cv.size()) line(lines_, cv[a], cv[b], kCage);
        }
    }
  if (o.anchors) {
    // Intact anchors as lines from their node to where they hold it (long ones are pulled hard);
    // torn or cut ones as a dot where the tissue was, so a surgeon sees what let go.
    const double dot = 0.006 * subject_size_;
    render::Soup torn;
    for (std::size_t a = 0; a < m.anchor_nodes.size() && a < d.anchors_intact.size(); ++a) {
      if (d.anchors_intact[a] != 0)
        line(lines_, node(f, m.anchor_nodes[a]), m.anchor_targets[a], kAnchor);
      else
        render::add_sphere(torn, m.anchor_targets[a], dot, 4);
    }
    append(opaque_, torn, kTorn);
  }
  if (o.contacts) {
    const double r = 0.01 * subject_size_;
    for (const Contact& c : d.contacts)
      if (c.depth > 0.0) {
        render::Soup s;
        render::add_sphere(s, c.point, r, 4);
        append(opaque_, s, kContact);
      }
  }
}

void GlScene::build_surroundings(const FramePublisher::Slot& f, const ModelInfo& m, const DrawOptions& o) {
  const FrameDetails& d = f.details;
  // Instruments (the mouse's only while it holds or presses), and the force the tissue puts on
  // the mouse's grasper as an arrow from its tip.
  for (std::size_t i = 0; i < d.instruments.size() && i < m.desc.instruments.size(); ++i) {
    if (i == m.mouse && !o.show_mouse) continue;
    const InstrumentReading& r = d.instruments[i];
    render::Soup s;
    render::add_capsule(s, r.tip, r.tip + m.desc.instruments[i].length * r.axis, m.desc.instruments[i].radius);
    append(opaque_, s, kInstrument);
    // A grasp holds through a spring (decision 0057): drawn from the grasp point to the node, so a
    // hard pull shows as a long spring rather than a tissue that stops following.
    if (r.grasping && r.grasped_segment < m.segment_nodes.size())
      line(lines_, r.grasp_target, node(f, m.segment_nodes[r.grasped_segment].offset + r.grasped_node), kForce);
    if (i == m.mouse && r.grasping) {
      const Eigen::Vector3d force = r.filtered_force;
      const double length = std::min(force.norm() * o.force_scale, 0.5 * subject_size_);
      if (length > 1e-4) {
        const Eigen::Vector3d dir = force.normalized(), end = r.tip + length * dir;
        const double w = 0.004 * subject_size_;
        render::Soup arrow;
        render::add_tube(arrow, {r.tip, end - 3.0 * w * dir}, w, 12);
        add_cone(arrow, end - 3.0 * w * dir, end, 2.0 * w);
        append(opaque_, arrow, kForce);
      }
    }
  }
  const EnvironmentDesc& env = m.desc.environment;
  render::Soup obstacles;
  for (const auto& s : env.spheres) render::add_sphere(obstacles, s.center, s.radius, 24);
  for (const auto& c : env.capsules) render::add_capsule(obstacles, c.a, c.b, c.radius);
  append(opaque_, obstacles, kObstacle);
  for (const auto& mesh : env.meshes) {
    // A container (the body around the organs) is wound inward and drawn with the planes, back
    // faces culled: only its far wall shows, from inside, as in a cut-away.
    const bool turn = mesh.container && mesh_volume(mesh.vertices, mesh.triangles) > 0.0;
    render::Soup s;
    for (const auto& t : mesh.triangles) {  // flat shaded: face normals
      const Eigen::Vector3d a = mesh.vertices[t[0]], b = turn ? mesh.vertices[t[2]] : mesh.vertices[t[1]],
                            c = turn ? mesh.vertices[t[1]] : mesh.vertices[t[2]];
      const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
      const auto first = static_cast<std::uint32_t>(s.vertices.size());
      for (const auto& p : {a, b, c}) {
        s.vertices.push_back(p);
        s.normals.push_back(n);
      }
      s.triangles.push_back({first, first + 1, first + 2});
    }
    append(mesh.container ? planes_ : opaque_, s, mesh.container ? kBody : kObstacle);
  }
  // Each plane as a square under the subject, four subject sizes wide, with a 10 cm grid.
  for (const auto& plane : env.planes) {
    const Eigen::Vector3d n = plane.normal.normalized();
    const Eigen::Vector3d foot = subject_centre_ - (subject_centre_ - plane.point).dot(n) * n;
    const auto [u, v] = render::across(n);
    const double half = std::ceil(2.0 * subject_size_ / 0.1) * 0.1;
    render::Soup quad;
    for (const auto& [a, b] : {std::pair{-1.0, -1.0}, {1.0, -1.0}, {1.0, 1.0}, {-1.0, 1.0}}) {
      quad.vertices.push_back(foot + half * (a * u + b * v) - 1e-4 * n);
      quad.normals.push_back(n);
    }
    // Wound to face the plane's free side: drawn with back faces culled, a wall between the eye and
    // the organ (the eye outside the box) shows only its grid and never hides the organ.
    if (u.cross(v).dot(n) > 0.0)
      quad.triangles = {{0, 1, 2}, {0, 2, 3}};
    else
      quad.triangles = {{0, 2, 1}, {0, 3, 2}};
    append(planes_, quad, kFloor);
    for (double t = -half; t <= half + 1e-9; t += 0.1) {
      line(lines_, foot + t * u - half * v, foot + t * u + half * v, kGrid, 0.6f);
      line(lines_, foot - half * u + t * v, foot + half * u + t * v, kGrid, 0.6f);
    }
  }
}

void GlScene::upload(Batch& b) {
  glBindBuffer(GL_ARRAY_BUFFER, b.vbo);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(b.vertices.size() * sizeof(Vertex)), b.vertices.data(),
               GL_STREAM_DRAW);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, b.ebo);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(b.indices.size() * sizeof(std::uint32_t)),
               b.indices.data(), GL_STREAM_DRAW);
}

void GlScene::draw_batch(const Batch& b, unsigned mode) {
  if (b.indices.empty()) return;
  glBindVertexArray(b.vao);
  glDrawElements(mode, static_cast<GLsizei>(b.indices.size()), GL_UNSIGNED_INT, nullptr);
}

void GlScene::draw(const OrbitCamera& camera, const DrawOptions&, int width, int height) {
  glViewport(0, 0, width, height);
  glClearColor(0.86f, 0.88f, 0.92f, 1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  glUseProgram(program_);
  const Eigen::Matrix4f vp = camera.view_projection();
  glUniformMatrix4fv(vp_location_, 1, GL_FALSE, vp.data());  // Eigen is column-major, as GL wants
  const Eigen::Vector3f eye = camera.eye().cast<float>();
  glUniform3f(eye_location_, eye.x(), eye.y(), eye.z());
  glUniform1i(lit_location_, 1);
  glDisable(GL_BLEND);
  draw_batch(opaque_, GL_TRIANGLES);
  glEnable(GL_CULL_FACE);  // planes from their free side only
  glCullFace(GL_BACK);
  glFrontFace(GL_CCW);
  draw_batch(planes_, GL_TRIANGLES);
  glDisable(GL_CULL_FACE);
  if (!organ_transparent_) draw_batch(organ_, GL_TRIANGLES);
  glEnable(GL_BLEND);
  glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
  glUniform1i(lit_location_, 0);
  draw_batch(lines_, GL_LINES);
  if (organ_transparent_) {  // see-through: after everything inside it, without hiding it
    glUniform1i(lit_location_, 1);
    glDepthMask(GL_FALSE);
    draw_batch(organ_, GL_TRIANGLES);
    glDepthMask(GL_TRUE);
  }
  glBindVertexArray(0);
  glUseProgram(0);
}

}  // namespace haustra::view
