// OpenGL 3.3 core drawing of a published frame: one lit shader over three batches (opaque
// triangles, the organ, lines); the organ see-through when an overlay must show inside it.
#include "gl_scene.hpp"

#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>
#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
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

// Cheap per fragment (a software renderer shades every pixel on the CPU): the specular power by
// squaring, and the screen's gamma as a square root (2.0 for 2.2: no visible difference).
constexpr const char* kFragmentShader = R"(#version 330 core
in vec3 world_position;
in vec3 world_normal;
in vec4 vertex_colour;
uniform vec3 eye;
uniform int lit;
out vec4 fragment;
void main() {
  if (lit == 0) { fragment = vec4(sqrt(vertex_colour.rgb), vertex_colour.a); return; }
  vec3 n = normalize(world_normal);
  vec3 v = normalize(eye - world_position);
  if (dot(n, v) < 0.0) n = -n;  // open meshes and inner walls: light the side we see
  const vec3 sun = vec3(0.4056, -0.3042, 0.8619);
  const vec3 fill = vec3(-0.7171, 0.5976, 0.3586);
  float diffuse = 0.75 * max(dot(n, sun), 0.0) + 0.25 * max(dot(n, fill), 0.0);
  float s = max(dot(n, normalize(sun + v)), 0.0);
  s *= s; s *= s; s *= s; s *= s; s *= s;  // s^32
  vec3 c = vertex_colour.rgb * (0.28 + diffuse) + vec3(0.25 * s);
  fragment = vec4(sqrt(c), vertex_colour.a);  // linear colours to the screen's (near) sRGB
}
)";

// The organ skinned on the GPU (decision 0110): the lit shader's outputs from the skinning shader.
constexpr const char* kSkinMain = R"(
layout(location = 0) in vec3 rest_position;
layout(location = 1) in vec3 rest_normal;
layout(location = 2) in vec4 colour;
layout(location = 3) in uvec2 slots;
uniform mat4 view_projection;
out vec3 world_position;
out vec3 world_normal;
out vec4 vertex_colour;
void main() {
  vec3 p, n;
  haustra_skin(rest_position, rest_normal, slots, p, n);
  gl_Position = view_projection * vec4(p, 1.0);
  world_position = p;
  world_normal = n;
  vertex_colour = colour;
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
const Rgb kSpring{0.05f, 0.75f, 0.85f};    // the grasp's spring, drawn over everything
const Rgb kSelected{0.62f, 0.45f, 0.98f};  // what the inspector has selected

bool is(const Highlight& h, Highlight::Kind kind, std::size_t index) { return h.kind == kind && h.index == index; }

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
  try {  // a driver that cannot run the skinning shader draws the CPU's mesh
    const std::string skin_source = skin_vertex_shader(kSkinMain);
    const unsigned svs = compile(GL_VERTEX_SHADER, skin_source.c_str()),
                   sfs = compile(GL_FRAGMENT_SHADER, kFragmentShader);
    skin_program_ = glCreateProgram();
    glAttachShader(skin_program_, svs);
    glAttachShader(skin_program_, sfs);
    glLinkProgram(skin_program_);
    glDeleteShader(svs);
    glDeleteShader(sfs);
    glGetProgramiv(skin_program_, GL_LINK_STATUS, &ok);
    skin_supported_ = ok != 0;
  } catch (const Error&) {
    skin_supported_ = false;
  }
  skin_vp_location_ = glGetUniformLocation(skin_program_, "view_projection");
  skin_eye_location_ = glGetUniformLocation(skin_program_, "eye");
  skin_lit_location_ = glGetUniformLocation(skin_program_, "lit");
  glGenVertexArrays(1, &skin_vao_);
  glGenBuffers(1, &skin_vbo_);
  glGenBuffers(1, &skin_colour_vbo_);
  glBindVertexArray(skin_vao_);
  glBindBuffer(GL_ARRAY_BUFFER, skin_vbo_);
  GpuSkinBuffers::vertex_attributes(3);
  glBindBuffer(GL_ARRAY_BUFFER, skin_colour_vbo_);
  glVertexAttribPointer(2, 4, GL_FLOAT, GL_FALSE, 4 * sizeof(float), nullptr);
  glBindVertexArray(0);
  for (Batch* b : {&opaque_, &organ_, &lines_, &planes_, &grid_, &overlay_, &tubes_}) {
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
  for (Batch* b : {&opaque_, &organ_, &lines_, &planes_, &grid_, &overlay_, &tubes_}) {
    glDeleteBuffers(1, &b->vbo);
    glDeleteBuffers(1, &b->ebo);
    glDeleteVertexArrays(1, &b->vao);
  }
  glDeleteProgram(program_);
  glDeleteBuffers(1, &skin_vbo_);
  glDeleteBuffers(1, &skin_colour_vbo_);
  glDeleteVertexArrays(1, &skin_vao_);
  if (skin_program_ != 0) glDeleteProgram(skin_program_);
}

std::array<Eigen::Vector3d, 2> drawn_bounds(const FramePublisher::Slot& f, const ModelInfo& m) {
  if (f.x.empty()) return {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (std::size_t k = 0; k < f.x.size(); ++k) {
    lo = lo.cwiseMin(node(f, k));
    hi = hi.cwiseMax(node(f, k));
  }
  if (!f.mesh_made) return {lo - Eigen::Vector3d::Constant(m.skin_reach), hi + Eigen::Vector3d::Constant(m.skin_reach)};
  for (std::size_t i = 0; i < f.px.size(); ++i) {  // the skin reaches a radius beyond the nodes
    const Eigen::Vector3d p(f.px[i], f.py[i], f.pz[i]);
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  return {lo, hi};
}

void GlScene::build(const FramePublisher::Slot& f, const ModelInfo& m, const DrawOptions& o,
                    const OrbitCamera& camera) {
  for (Batch* b : {&opaque_, &organ_, &lines_, &planes_, &grid_, &overlay_, &tubes_}) b->clear();
  grid_ranges_.clear();
  const auto [lo, hi] = drawn_bounds(f, m);
  subject_lo_ = lo;
  subject_hi_ = hi;
  subject_centre_ = 0.5 * (lo + hi);
  subject_size_ = std::max((hi - lo).norm(), 0.05);
  build_organ(f, m, o, camera);
  build_overlays(f, m, o);
  build_surroundings(f, m, o);
  for (Batch* b : {&opaque_, &lines_, &planes_, &grid_, &overlay_, &tubes_}) upload(*b);
  // The organ: only the vertices of this frame's blocks; its indices stay in their buffer.
  glBindBuffer(GL_ARRAY_BUFFER, organ_.vbo);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(organ_.vertices.size() * sizeof(Vertex)),
               organ_.vertices.data(), GL_STREAM_DRAW);
}

void GlScene::prepare_lod(const FramePublisher::Slot& f, const ModelInfo& m) {
  if (m.triangles == lod_triangles_ && !lod_.chunks.empty()) return;
  // The frame's mesh: the CPU's, or (rings for the GPU) the same sum on the CPU, once per model.
  const bool rings = !f.mesh_made && m.gpu_skin && !f.gpu_pending;
  if (!f.mesh_made && !rings) return;
  const std::size_t n = f.mesh_made ? f.px.size() : m.gpu_skin->vertices;
  std::vector<Eigen::Vector3d> positions(n), normals(n), nodes(f.x.size());
  for (std::size_t v = 0; v < n; ++v) {
    if (rings) {
      const GpuSkinned s = gpu_skin_vertex(*m.gpu_skin, f.gpu_rings, v);
      positions[v] = s.position;
      normals[v] = s.normal;
      continue;
    }
    positions[v] = {f.px[v], f.py[v], f.pz[v]};
    normals[v] = {f.nx[v], f.ny[v], f.nz[v]};
  }
  for (std::size_t k = 0; k < f.x.size(); ++k) nodes[k] = node(f, k);
  lod_ =
      m.vertex_node.size() == n ? build_organ_lod(positions, normals, m.triangles, m.vertex_node, nodes) : OrganLod{};
  lod_triangles_ = m.triangles;
  ++lod_build_;
  glBindVertexArray(organ_.vao);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, organ_.ebo);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(lod_.indices.size() * sizeof(std::uint32_t)),
               lod_.indices.data(), GL_STATIC_DRAW);
  glBindVertexArray(0);
}

// The binding's buffers when the model changed, the LOD's vertices' attributes when the LOD did.
void GlScene::prepare_gpu_skin(const ModelInfo& m) {
  if (skin_binding_ != m.gpu_skin) {
    skin_binding_ = m.gpu_skin;
    skin_.upload_binding(*skin_binding_);
    skin_lod_build_ = 0;
  }
  if (skin_lod_build_ == lod_build_) return;
  const std::vector<SkinVertex> vertices = skin_vertices(*skin_binding_, lod_.source);
  glBindBuffer(GL_ARRAY_BUFFER, skin_vbo_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(vertices.size() * sizeof(SkinVertex)), vertices.data(),
               GL_STATIC_DRAW);
  skin_colours_.assign(4 * lod_.source.size(), 0.0f);
  glBindBuffer(GL_ARRAY_BUFFER, skin_colour_vbo_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(skin_colours_.size() * sizeof(float)), nullptr, GL_STREAM_DRAW);
  skin_lod_build_ = lod_build_;
  glBindVertexArray(skin_vao_);  // the LOD's indices, as the CPU path's VAO has them
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, organ_.ebo);
  glBindVertexArray(0);
}

void GlScene::build_organ(const FramePublisher::Slot& f, const ModelInfo& m, const DrawOptions& o,
                          const OrbitCamera& camera) {
  organ_transparent_ = o.beads || o.cage || o.centreline;
  const float alpha = organ_transparent_ ? 0.35f : 1.0f;
  prepare_lod(f, m);
  if (m.gpu_skin && m.gpu_skin != skin_checked_) {
    skin_checked_ = m.gpu_skin;
    skin_fits_ = gpu_skinning_supported(*m.gpu_skin);
  }
  organ_on_gpu_ = wants_gpu_skinning(o) && !f.mesh_made && m.gpu_skin && !f.gpu_pending &&
                  f.gpu_rings.size() == kGpuRingDataFloats * m.gpu_skin->rings && !lod_.chunks.empty();
  if (organ_on_gpu_) {
    prepare_gpu_skin(m);
    skin_.upload_rings(f.gpu_rings);
    skin_rings_.assign(f.gpu_rings.begin(), f.gpu_rings.end());
  }
  organ_plain_ = true;
  organ_colour_ = {kTissue.r, kTissue.g, kTissue.b, alpha};
  lod_nodes_.resize(f.x.size());
  for (std::size_t k = 0; k < f.x.size(); ++k) lod_nodes_[k] = node(f, k);
  const LodView view{camera.view_projection().cast<double>(), camera.eye(),
                     camera.height / (camera.fov_degrees * std::numbers::pi / 180.0)};
  lod_levels_.assign(lod_.chunks.size(), -1);
  choose_lod_levels(lod_, lod_nodes_, view, o.triangle_budget, lod_levels_);
  lod_draws_.clear();
  organ_triangles_drawn_ = 0;
  // The selected organ's vertices (its pieces' meshes), tinted.
  std::vector<bool> selected;
  if (o.highlight.kind == Highlight::Kind::organ && o.highlight.index < m.organs.size()) {
    selected.assign(f.px.size(), false);
    for (std::size_t piece : m.organs[o.highlight.index].pieces)
      for (std::size_t v = 0; v < m.meshes[piece].vertices.count; ++v)
        if (const std::size_t g = m.meshes[piece].vertices.offset + v; g < selected.size()) selected[g] = true;
  }
  for (std::size_t chunk = 0; chunk < lod_.chunks.size() && (organ_on_gpu_ || f.mesh_made); ++chunk) {
    if (lod_levels_[chunk] < 0) continue;
    const LodBlock& block = lod_.chunks[chunk].levels[static_cast<std::size_t>(lod_levels_[chunk])];
    const LodChunk& part = lod_.chunks[chunk];
    const double distance =
        (lod_nodes_[std::min<std::size_t>(part.first_node + part.node_count / 2, lod_nodes_.size() - 1)] - view.eye)
            .norm();
    lod_draws_.push_back({organ_on_gpu_ ? block.first_vertex : static_cast<std::uint32_t>(organ_.vertices.size()),
                          block.first_index, block.index_count, distance, block.vertex_count});
    organ_triangles_drawn_ += block.index_count / 3;
    for (std::uint32_t i = 0; i < block.vertex_count; ++i) {
      const std::uint32_t v = lod_.source[block.first_vertex + i];
      Rgb c = kTissue;
      if (o.colour == Colouring::strain) {
        const std::size_t k = m.vertex_node[v];
        const double d1 = f.details.strain[4 * k] - f.details.rest_strain[4 * k];
        const double d2 = f.details.strain[4 * k + 1] - f.details.rest_strain[4 * k + 1];
        c = render::colormap(std::hypot(d1, d2) / std::max(o.strain_range, 1e-9));
      }
      if (!selected.empty() && selected[v]) c = kSelected;
      if (organ_on_gpu_) {  // the skin is the GPU's: only a colour that is not the tissue's is sent
        organ_plain_ = organ_plain_ && o.colour != Colouring::strain && selected.empty();
        float* to = skin_colours_.data() + 4 * (std::size_t{block.first_vertex} + i);
        to[0] = c.r, to[1] = c.g, to[2] = c.b, to[3] = alpha;
        continue;
      }
      organ_.vertices.push_back({{f.px[v], f.py[v], f.pz[v]}, {f.nx[v], f.ny[v], f.nz[v]}, {c.r, c.g, c.b, alpha}});
    }
  }
  if (organ_on_gpu_ && !organ_plain_) {
    glBindBuffer(GL_ARRAY_BUFFER, skin_colour_vbo_);
    glBufferSubData(GL_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(skin_colours_.size() * sizeof(float)),
                    skin_colours_.data());
  }
  // Near chunks first: the depth test then spares the shading of what they hide.
  std::stable_sort(lod_draws_.begin(), lod_draws_.end(),
                   [](const LodDraw& a, const LodDraw& b) { return a.distance < b.distance; });
  // A segment without a mesh is drawn as a tube along its nodes.
  for (std::size_t s = 0; s < m.segment_nodes.size(); ++s) {
    if (m.meshes[s].enabled) continue;
    render::Soup tube;
    std::vector<Eigen::Vector3d> pts;
    for (std::size_t k = 0; k < m.segment_nodes[s].count; ++k) pts.push_back(node(f, m.segment_nodes[s].offset + k));
    const std::size_t organ = s < m.organ_of_segment.size() ? m.organ_of_segment[s] : 0;
    add_tube(tube, pts, organ < m.organs.size() ? m.organs[organ].desc.cross_section.radius : 0.01, 16);
    const Rgb colour = is(o.highlight, Highlight::Kind::organ, organ) ? kSelected : kTissue;
    const auto base = static_cast<std::uint32_t>(tubes_.vertices.size());
    for (std::size_t i = 0; i < tube.vertices.size(); ++i)
      tubes_.vertices.push_back(vertex(tube.vertices[i], tube.normals[i], colour, alpha));
    for (const auto& t : tube.triangles)
      for (std::uint32_t v : t) tubes_.indices.push_back(base + v);
  }
}

namespace {

// Möller and Trumbore's ray and triangle: the distance along the ray, or nothing.
std::optional<double> ray_triangle(const Ray& ray, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                   const Eigen::Vector3d& c) {
  const Eigen::Vector3d e1 = b - a, e2 = c - a, p = ray.direction.cross(e2);
  const double det = e1.dot(p);
  if (std::abs(det) < 1e-18) return std::nullopt;
  const Eigen::Vector3d s = ray.origin - a;
  const double u = s.dot(p) / det;
  if (u < 0.0 || u > 1.0) return std::nullopt;
  const Eigen::Vector3d q = s.cross(e1);
  const double w = ray.direction.dot(q) / det;
  if (w < 0.0 || u + w > 1.0) return std::nullopt;
  const double t = e2.dot(q) / det;
  return t > 0.0 ? std::optional<double>(t) : std::nullopt;
}

Eigen::Vector3d position(const Vertex& v) { return {v.p[0], v.p[1], v.p[2]}; }

void pick_in(const Ray& ray, const std::vector<Vertex>& vertices, const std::uint32_t* indices, std::size_t count,
             std::uint32_t base, std::optional<OrganHit>& best) {
  for (std::size_t i = 0; i + 2 < count; i += 3) {
    const Eigen::Vector3d a = position(vertices[base + indices[i]]), b = position(vertices[base + indices[i + 1]]),
                          c = position(vertices[base + indices[i + 2]]);
    const auto t = ray_triangle(ray, a, b, c);
    if (!t || (best && *t >= best->distance)) continue;
    Eigen::Vector3d n = (b - a).cross(c - a).normalized();
    if (n.dot(ray.direction) > 0.0) n = -n;  // towards the eye
    best = OrganHit{*t, ray.origin + *t * ray.direction, n};
  }
}

}  // namespace

std::optional<OrganHit> GlScene::pick_organ(const Ray& ray) const {
  std::optional<OrganHit> best;
  if (organ_on_gpu_) {  // the drawn vertices where the shader put them: its sum on the CPU (gpu_skin.hpp)
    std::vector<Vertex> drawn(lod_.source.size());
    for (const LodDraw& d : lod_draws_)
      for (std::uint32_t i = d.base_vertex; i < d.base_vertex + d.vertex_count; ++i) {
        const Eigen::Vector3d p = gpu_skin_vertex(*skin_binding_, skin_rings_, lod_.source[i]).position;
        drawn[i] = {{float(p.x()), float(p.y()), float(p.z())}, {0, 0, 1}, {0, 0, 0, 1}};
      }
    for (const LodDraw& d : lod_draws_)
      pick_in(ray, drawn, lod_.indices.data() + d.first_index, d.index_count, d.base_vertex, best);
    pick_in(ray, tubes_.vertices, tubes_.indices.data(), tubes_.indices.size(), 0, best);
    return best;
  }
  for (const LodDraw& d : lod_draws_)
    pick_in(ray, organ_.vertices, lod_.indices.data() + d.first_index, d.index_count, d.base_vertex, best);
  pick_in(ray, tubes_.vertices, tubes_.indices.data(), tubes_.indices.size(), 0, best);
  return best;
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
    const bool some = o.highlight.kind == Highlight::Kind::anchors && o.highlight.index < m.organs.size();
    std::vector<bool> of_selected(some ? m.node_count : 0, false);
    if (some)
      for (std::size_t piece : m.organs[o.highlight.index].pieces)
        for (std::size_t k = 0; k < m.segment_nodes[piece].count; ++k)
          of_selected[m.segment_nodes[piece].offset + k] = true;
    for (std::size_t a = 0; a < m.anchor_nodes.size() && a < d.anchors_intact.size(); ++a) {
      if (d.anchors_intact[a] != 0)
        line(lines_, node(f, m.anchor_nodes[a]), m.anchor_targets[a],
             some && of_selected[m.anchor_nodes[a]] ? kSelected : kAnchor);
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
    append(opaque_, s, is(o.highlight, Highlight::Kind::instrument, i) ? kSelected : kInstrument);
    // A grasp holds through a spring (decision 0057): drawn from the grasp point to the node, so a
    // hard pull shows as a long spring rather than a tissue that stops following.
    if (r.grasping && r.grasped_segment < m.segment_nodes.size())
      line(overlay_, r.grasp_target, node(f, m.segment_nodes[r.grasped_segment].offset + r.grasped_node), kSpring);
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
  for (std::size_t i = 0; i < env.spheres.size(); ++i) {
    render::Soup s;
    render::add_sphere(s, env.spheres[i].center, env.spheres[i].radius, 24);
    append(opaque_, s, is(o.highlight, Highlight::Kind::sphere, i) ? kSelected : kObstacle);
  }
  for (std::size_t i = 0; i < env.capsules.size(); ++i) {
    render::Soup s;
    render::add_capsule(s, env.capsules[i].a, env.capsules[i].b, env.capsules[i].radius);
    append(opaque_, s, is(o.highlight, Highlight::Kind::capsule, i) ? kSelected : kObstacle);
  }
  for (std::size_t mesh_index = 0; mesh_index < env.meshes.size(); ++mesh_index) {
    const auto& mesh = env.meshes[mesh_index];
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
    const bool chosen = is(o.highlight, Highlight::Kind::mesh, mesh_index);
    append(mesh.container ? planes_ : opaque_, s, chosen ? kSelected : mesh.container ? kBody : kObstacle);
  }
  // Each plane as a square under the subject, four subject sizes wide, with a 10 cm grid.
  for (std::size_t plane_index = 0; plane_index < env.planes.size(); ++plane_index) {
    const PlaneDesc& plane = env.planes[plane_index];
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
    append(planes_, quad, is(o.highlight, Highlight::Kind::plane, plane_index) ? kSelected : kFloor);
    PlaneRange range{plane.point, n, static_cast<std::uint32_t>(grid_.indices.size()), 0};
    for (double t = -half; t <= half + 1e-9; t += 0.1) {
      line(grid_, foot + t * u - half * v, foot + t * u + half * v, kGrid, 0.6f);
      line(grid_, foot - half * u + t * v, foot + half * u + t * v, kGrid, 0.6f);
    }
    range.index_count = static_cast<std::uint32_t>(grid_.indices.size()) - range.first_index;
    grid_ranges_.push_back(range);
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

void GlScene::draw_organ() {
  if (organ_on_gpu_) {  // its own program, then back to the lit one for the tubes
    glUseProgram(skin_program_);
    glUniformMatrix4fv(skin_vp_location_, 1, GL_FALSE, draw_vp_.data());
    glUniform3f(skin_eye_location_, draw_eye_.x(), draw_eye_.y(), draw_eye_.z());
    glUniform1i(skin_lit_location_, 1);
    skin_.bind(skin_program_, 0);
    glBindVertexArray(skin_vao_);
    if (organ_plain_) {  // one colour: a constant attribute, nothing sent per vertex
      glDisableVertexAttribArray(2);
      glVertexAttrib4f(2, organ_colour_[0], organ_colour_[1], organ_colour_[2], organ_colour_[3]);
    } else {
      glEnableVertexAttribArray(2);
    }
    for (const LodDraw& d : lod_draws_)
      glDrawElementsBaseVertex(
          GL_TRIANGLES, static_cast<GLsizei>(d.index_count), GL_UNSIGNED_INT,
          reinterpret_cast<void*>(static_cast<std::uintptr_t>(d.first_index) * sizeof(std::uint32_t)),
          static_cast<GLint>(d.base_vertex));
    glUseProgram(program_);
    glUniform1i(lit_location_, 1);
    draw_batch(tubes_, GL_TRIANGLES);
    return;
  }
  glBindVertexArray(organ_.vao);
  for (const LodDraw& d : lod_draws_)
    glDrawElementsBaseVertex(
        GL_TRIANGLES, static_cast<GLsizei>(d.index_count), GL_UNSIGNED_INT,
        reinterpret_cast<void*>(static_cast<std::uintptr_t>(d.first_index) * sizeof(std::uint32_t)),
        static_cast<GLint>(d.base_vertex));
  draw_batch(tubes_, GL_TRIANGLES);
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
  const Eigen::Vector3d eye_d = camera.eye();
  const Eigen::Vector3f eye = eye_d.cast<float>();
  draw_vp_ = vp;
  draw_eye_ = eye;
  glUniform3f(eye_location_, eye.x(), eye.y(), eye.z());
  glUniform1i(lit_location_, 1);
  glDisable(GL_BLEND);
  draw_batch(opaque_, GL_TRIANGLES);
  glEnable(GL_CULL_FACE);  // planes from their free side only
  glCullFace(GL_BACK);
  glFrontFace(GL_CCW);
  draw_batch(planes_, GL_TRIANGLES);
  glDisable(GL_CULL_FACE);
  if (!organ_transparent_) draw_organ();
  glEnable(GL_BLEND);
  glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
  glUniform1i(lit_location_, 0);
  draw_batch(lines_, GL_LINES);
  // A plane's grid only where the plane is drawn (seen from its free side): a wall between the eye
  // and the organ shows neither its face nor its lines.
  glBindVertexArray(grid_.vao);
  for (const PlaneRange& r : grid_ranges_)
    if ((eye_d - r.point).dot(r.normal) > 0.0 && r.index_count > 0)
      glDrawElements(GL_LINES, static_cast<GLsizei>(r.index_count), GL_UNSIGNED_INT,
                     reinterpret_cast<void*>(static_cast<std::uintptr_t>(r.first_index) * sizeof(std::uint32_t)));
  if (organ_transparent_) {  // see-through: after everything inside it, without hiding it
    glUniform1i(lit_location_, 1);
    glDepthMask(GL_FALSE);
    draw_organ();
    glDepthMask(GL_TRUE);
  }
  glUniform1i(lit_location_, 0);
  glDisable(GL_DEPTH_TEST);  // the grasp's spring, wherever the organ or the floor is
  draw_batch(overlay_, GL_LINES);
  glEnable(GL_DEPTH_TEST);
  glBindVertexArray(0);
  glUseProgram(0);
}

}  // namespace haustra::view
