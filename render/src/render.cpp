// The software renderer: the world as triangle soups by kind, traced with Embree, shaded in layers.
#include "haustra/render/render.hpp"

#include <oneapi/tbb/parallel_for.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>

#include "haustra/embree_scene.hpp"
#include "haustra/mesh_io.hpp"
#include "haustra/render/shapes.hpp"

namespace haustra::render {
namespace {

struct Material {
  Shows shows = Shows::organ;
  Rgb colour;
  float opacity = 1.0f;
  float shine = 0.1f;
  bool checker = false;  // floor tiles (10 cm)
  // A container (the body around the organs) seen from outside: only its far wall shows, from
  // inside, as in a cut-away, and it casts no shadow (everything in it would be dark).
  bool cut_away = false;
};

// One triangle soup per material, with optional per-vertex colours.
struct Geometry : Soup {
  Material material;
  std::vector<Rgb> colours;

  std::uint32_t vertex(const Eigen::Vector3d& p) {
    vertices.push_back(p);
    return static_cast<std::uint32_t>(vertices.size() - 1);
  }
};

Rgb scale(Rgb a, float s) { return {a.r * s, a.g * s, a.b * s}; }
Rgb add(Rgb a, Rgb b) { return {a.r + b.r, a.g + b.g, a.b + b.b}; }

struct Bounds {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = Eigen::Vector3d::Constant(-1e300);
  void add(const Eigen::Vector3d& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  [[nodiscard]] bool empty() const { return lo.x() > hi.x(); }
};

Bounds subject_bounds(const World& world) {
  Bounds b;
  const auto nodes = world.node_positions();
  for (std::size_t i = 0; i < nodes.size(); ++i) b.add(nodes.get(i));
  const auto mesh = world.mesh_positions();
  for (std::size_t s = 0; s < world.segment_count(); ++s) {
    const MeshInfo& m = world.mesh(s);
    for (std::size_t v = m.vertices.offset; v < m.vertices.offset + m.vertices.count; ++v)
      b.add(Eigen::Vector3d(mesh.x[v], mesh.y[v], mesh.z[v]));
  }
  for (std::size_t i = 0; i < world.instrument_count(); ++i) b.add(world.instrument(i).tip);
  if (b.empty()) b.add(Eigen::Vector3d::Zero());
  return b;
}

}  // namespace

void grow_bounds(const World& world, Eigen::Vector3d& lo, Eigen::Vector3d& hi) {
  const Bounds b = subject_bounds(world);
  lo = lo.cwiseMin(b.lo);
  hi = hi.cwiseMax(b.hi);
}

Camera fit_camera(const World& world, const Eigen::Vector3d& from, double fov_degrees, double aspect) {
  const Bounds b = subject_bounds(world);
  return fit_camera(b.lo, b.hi, from, fov_degrees, aspect);
}

Camera fit_camera(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const Eigen::Vector3d& from, double fov_degrees,
                  double aspect) {
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  const double radius = std::max(0.5 * (hi - lo).norm(), 0.02);
  const double half = 0.5 * fov_degrees * std::numbers::pi / 180.0;
  const double fit = std::min(half, std::atan(std::tan(half) * aspect));
  Camera c;
  c.target = centre;
  c.eye = centre + from.normalized() * (1.1 * radius / std::sin(fit));
  c.fov_degrees = fov_degrees;
  return c;
}

std::vector<std::uint32_t> nearest_nodes(const World& w) {
  std::vector<std::uint32_t> out(w.mesh_buffer_size(), 0);
  const auto p = w.mesh_positions();
  const auto n = w.node_positions();
  for (std::size_t s = 0; s < w.segment_count(); ++s) {
    const MeshInfo& m = w.mesh(s);
    if (!m.enabled) continue;
    const Range r = w.segment(s).nodes;
    for (std::size_t v = m.vertices.offset; v < m.vertices.offset + m.vertices.count; ++v) {
      const Eigen::Vector3d x(p.x[v], p.y[v], p.z[v]);
      double best = 1e300;
      for (std::size_t k = r.offset; k < r.offset + r.count; ++k)
        if ((n.get(k) - x).squaredNorm() < best) {
          best = (n.get(k) - x).squaredNorm();
          out[v] = static_cast<std::uint32_t>(k);
        }
    }
  }
  return out;
}

namespace {

// What the picture shows, one Geometry per kind: built from the world and its description.
struct SceneParts {
  const World& world;
  const WorldDesc& desc;
  const RenderOptions& o;
  double size;   // of the subject, m: overlays are drawn in proportion
  bool overlay;  // something drawn inside the organ: the organ is see-through
  Picture& pic;  // its colour scale
  std::vector<Geometry> geoms;

  void keep(Geometry&& g) {
    if (!g.triangles.empty()) geoms.push_back(std::move(g));
  }
  [[nodiscard]] std::vector<Eigen::Vector3d> rod_points(std::size_t s) const {
    const auto nodes = world.node_positions();
    const Range r = world.segment(s).nodes;
    std::vector<Eigen::Vector3d> pts;
    for (std::size_t k = r.offset; k < r.offset + r.count; ++k) pts.push_back(nodes.get(k));
    return pts;
  }
  static constexpr Rgb kTissue{0.80f, 0.42f, 0.40f};

  // Organ meshes (see-through when an overlay must show inside them), coloured by strain if asked.
  void organs() {
    Geometry g;
    g.material = {Shows::organ, kTissue, overlay ? 0.35f : 1.0f, 0.25f, false};
    const auto p = world.mesh_positions();
    const auto n = world.mesh_normals();
    std::vector<double> value;
    const bool strain = o.overlays.colour == Colouring::strain;
    const std::vector<std::uint32_t> nearest = strain ? nearest_nodes(world) : std::vector<std::uint32_t>{};
    for (std::size_t s = 0; s < world.segment_count(); ++s) {
      const MeshInfo& m = world.mesh(s);
      if (!m.enabled) continue;
      const auto base = static_cast<std::uint32_t>(g.vertices.size());
      for (std::size_t v = m.vertices.offset; v < m.vertices.offset + m.vertices.count; ++v) {
        g.vertices.emplace_back(p.x[v], p.y[v], p.z[v]);
        g.normals.emplace_back(n.x[v], n.y[v], n.z[v]);
        if (strain) {
          const std::size_t best = nearest[v];
          const Eigen::Vector4d q = world.strains().get(best) - world.rest_strains().get(best);
          value.push_back(q.head<2>().norm());
        }
      }
      for (std::size_t t = m.triangles.offset; t < m.triangles.offset + m.triangles.count; ++t) {
        auto tri = world.mesh_triangles()[t];
        for (auto& v : tri) v = static_cast<std::uint32_t>(v - m.vertices.offset + base);
        g.triangles.push_back(tri);
      }
    }
    if (!value.empty()) {
      pic.colour_min = *std::min_element(value.begin(), value.end());
      pic.colour_max = *std::max_element(value.begin(), value.end());
      for (double v : value)
        g.colours.push_back(colormap((v - pic.colour_min) / std::max(pic.colour_max - pic.colour_min, 1e-12)));
    }
    bool any_normal = false;
    for (const auto& nn : g.normals) any_normal = any_normal || nn.squaredNorm() > 0.5;
    if (!any_normal) g.normals.clear();  // the world computes no normals: use face normals
    keep(std::move(g));
  }

  // The rod as a tube where a segment has no mesh.
  void rods() {
    Geometry g;
    g.material = {Shows::rod, kTissue, overlay ? 0.35f : 1.0f, 0.25f, false};
    for (std::size_t s = 0; s < world.segment_count(); ++s)
      if (!world.mesh(s).enabled) add_tube(g, rod_points(s), desc.segments[s].cross_section.radius, 16);
    keep(std::move(g));
  }

  void centrelines() {
    Geometry g;
    g.material = {Shows::centreline, {0.95f, 0.80f, 0.10f}, 1.0f, 0.2f, false};
    for (std::size_t s = 0; s < world.segment_count(); ++s) add_tube(g, rod_points(s), 0.0025 * size / 0.5, 8);
    geoms.push_back(std::move(g));
  }

  // The beads, coloured by how deep their deepest contact goes if asked.
  void beads() {
    Geometry g;
    g.material = {Shows::bead, {0.55f, 0.62f, 0.85f}, 1.0f, 0.3f, false};
    const bool penetration = o.overlays.colour == Colouring::penetration;
    std::vector<double> depth(world.bead_count(), 0.0);
    for (const Contact& c : world.contact_list())
      if (c.depth > 0.0) {
        depth[c.bead] = std::max(depth[c.bead], c.depth / world.bead_radii()[c.bead]);
        if (c.kind == ContactKind::bead)
          depth[c.other] = std::max(depth[c.other], c.depth / world.bead_radii()[c.other]);
      }
    const auto nodes = world.node_positions();
    for (std::size_t i = 0; i < world.bead_count(); ++i) {
      add_sphere(g, nodes.get(world.bead_nodes()[i]), world.bead_radii()[i], 10);
      if (penetration) g.colours.resize(g.vertices.size(), colormap(depth[i] / 0.05));  // 0 … 5 % of the radius
    }
    if (penetration && !depth.empty()) {
      pic.colour_min = *std::min_element(depth.begin(), depth.end());
      pic.colour_max = *std::max_element(depth.begin(), depth.end());
    }
    keep(std::move(g));
  }

  // Each cage's edges as thin tubes.
  void cages() {
    Geometry g;
    g.material = {Shows::cage, {0.15f, 0.35f, 0.95f}, 1.0f, 0.2f, false};
    for (std::size_t s = 0; s < world.segment_count(); ++s) {
      if (!world.mesh(s).enabled) continue;
      const std::vector<Eigen::Vector3d> cv = world.cage_vertices(s);
      std::vector<std::pair<std::uint32_t, std::uint32_t>> edges;
      for (const auto& t : world.cage_triangles(s))
        for (int i = 0; i < 3; ++i) {
          const std::uint32_t a = t[static_cast<std::size_t>(i)], c = t[static_cast<std::size_t>((i + 1) % 3)];
          edges.emplace_back(std::min(a, c), std::max(a, c));
        }
      std::sort(edges.begin(), edges.end());
      edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
      for (const auto& [a, c] : edges) add_tube(g, {cv[a], cv[c]}, 0.0012 * size / 0.5, 6);
    }
    keep(std::move(g));
  }

  void wires() {
    Geometry g;
    g.material = {Shows::cage, {0.15f, 0.35f, 0.95f}, 1.0f, 0.2f, false};
    for (const auto& w : o.wires)
      for (std::size_t i = 0; i + 1 < w.size(); ++i) add_tube(g, {w[i], w[i + 1]}, 0.0012 * size / 0.5, 6);
    keep(std::move(g));
  }

  void contacts() {
    Geometry g;
    g.material = {Shows::contact, {0.95f, 0.10f, 0.08f}, 1.0f, 0.3f, false};
    for (const Contact& c : world.contact_list())
      if (c.depth > 0.0) add_sphere(g, c.point, 0.004 * size / 0.5, 5);
    keep(std::move(g));
  }

  void instruments() {
    Geometry g;
    g.material = {Shows::instrument, {0.55f, 0.57f, 0.60f}, 1.0f, 0.8f, false};
    for (std::size_t i = 0; i < world.instrument_count(); ++i) {
      const InstrumentReading r = world.instrument(i);
      add_capsule(g, r.tip, r.tip + desc.instruments[i].length * r.axis, desc.instruments[i].radius);
    }
    keep(std::move(g));
  }

  void obstacles() {
    Geometry g;
    g.material = {Shows::obstacle, {0.60f, 0.63f, 0.55f}, 1.0f, 0.15f, false};
    for (const auto& s : desc.environment.spheres) add_sphere(g, s.center, s.radius, 24);
    for (const auto& c : desc.environment.capsules) add_capsule(g, c.a, c.b, c.radius);
    for (const auto& m : desc.environment.meshes) {
      if (m.container) continue;
      const auto base = static_cast<std::uint32_t>(g.vertices.size());
      g.vertices.insert(g.vertices.end(), m.vertices.begin(), m.vertices.end());
      for (auto t : m.triangles) g.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
    }
    if (!g.normals.empty() && g.normals.size() != g.vertices.size()) g.normals.clear();
    keep(std::move(g));
  }

  // Each container wound outward (its volume positive), so that its front faces are the ones a
  // ray from outside meets first: those are passed through.
  void containers() {
    for (const auto& m : desc.environment.meshes) {
      if (!m.container) continue;
      Geometry g;
      g.material = {Shows::obstacle, {0.80f, 0.70f, 0.62f}, 1.0f, 0.05f, false, true};
      g.vertices = m.vertices;
      const bool inward = mesh_volume(m.vertices, m.triangles) < 0.0;
      for (auto t : m.triangles) g.triangles.push_back(inward ? std::array{t[0], t[2], t[1]} : t);
      geoms.push_back(std::move(g));
    }
  }

  // Each plane as a tiled square under the subject, four subject sizes wide; a plane seen from
  // behind (the camera outside a box's wall) would hide the subject: left out, as in a cut-away.
  void floors(const Bounds& b) {
    for (const auto& plane : desc.environment.planes) {
      if ((pic.camera.eye - plane.point).dot(plane.normal) < 0.0) continue;
      Geometry g;
      g.material = {Shows::floor, {0.82f, 0.82f, 0.80f}, 1.0f, 0.0f, true};
      const Eigen::Vector3d n = plane.normal.normalized();
      const Eigen::Vector3d centre = 0.5 * (b.lo + b.hi);
      const Eigen::Vector3d foot = centre - (centre - plane.point).dot(n) * n;
      const auto [u, v] = across(n);
      const double half = 2.0 * size;
      const std::uint32_t a = g.vertex(foot - half * u - half * v), c = g.vertex(foot + half * u - half * v),
                          d = g.vertex(foot + half * u + half * v), e = g.vertex(foot - half * u + half * v);
      g.triangles = {{a, c, d}, {a, d, e}};
      geoms.push_back(std::move(g));
    }
  }
};

// A ray's colour: up to six layers of see-through surfaces, each lit by a sun (with its shadow), a
// fill light and a highlight, over a sky gradient; `shows` (if given) takes the first opaque kind.
struct Shader {
  const EmbreeScene& scene;
  const std::vector<Geometry>& geoms;
  const Camera& cam;
  bool shadows;
  double size;

  // Something that casts a shadow lies between p and the sun (a container does not).
  [[nodiscard]] bool shadowed(const Eigen::Vector3d& p, const Eigen::Vector3d& sun, double eps) const {
    double t = 0.0;
    for (int crossing = 0; crossing < 16; ++crossing) {
      const EmbreeScene::Hit h = scene.first_hit(p, sun, t, 10.0 * size);
      if (!h.found) return false;
      if (!geoms[h.geometry].material.cut_away) return true;
      t = h.distance + eps;
    }
    return false;
  }

  [[nodiscard]] Rgb operator()(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, Shows* shows) const {
    const Eigen::Vector3d sun = Eigen::Vector3d(-0.35, -0.5, 1.0).normalized();
    const double eps = 1e-5 * size;
    Rgb accumulated{0, 0, 0};
    float remaining = 1.0f;
    double t0 = 0.0;
    int passed = 0;  // a container's near walls passed through (a body's arms and trunk: a few)
    for (int layer = 0; layer < 6 && remaining > 0.02f; ++layer) {
      const EmbreeScene::Hit h = scene.first_hit(origin, dir, t0, std::numeric_limits<double>::infinity());
      if (!h.found) break;
      const Geometry& g = geoms[h.geometry];
      const auto& tri = g.triangles[h.triangle];
      const Eigen::Vector3d p = origin + h.distance * dir;
      if (g.material.cut_away &&
          (g.vertices[tri[1]] - g.vertices[tri[0]]).cross(g.vertices[tri[2]] - g.vertices[tri[0]]).dot(dir) < 0.0 &&
          ++passed < 16) {  // its near wall, from outside: not a layer
        t0 = h.distance + eps;
        --layer;
        continue;
      }
      Eigen::Vector3d n;
      if (!g.normals.empty())
        n = (1.0 - h.u - h.v) * g.normals[tri[0]] + h.u * g.normals[tri[1]] + h.v * g.normals[tri[2]];
      else
        n = (g.vertices[tri[1]] - g.vertices[tri[0]]).cross(g.vertices[tri[2]] - g.vertices[tri[0]]);
      n.normalize();
      if (n.dot(dir) > 0.0) n = -n;
      Rgb base = g.material.colour;
      if (!g.colours.empty()) {
        const auto w0 = static_cast<float>(1.0 - h.u - h.v), w1 = static_cast<float>(h.u), w2 = static_cast<float>(h.v);
        base = add(add(scale(g.colours[tri[0]], w0), scale(g.colours[tri[1]], w1)), scale(g.colours[tri[2]], w2));
      }
      if (g.material.checker) {
        const long ix = std::lround(std::floor(p.x() / 0.1)), iy = std::lround(std::floor(p.y() / 0.1));
        if (((ix + iy) & 1L) != 0) base = scale(base, 0.86f);
      }
      double light = std::max(0.0, n.dot(sun));
      if (shadows && light > 0.0 && shadowed(p + eps * n, sun, eps)) light *= 0.25;
      const double fill = 0.35 * std::max(0.0, n.dot(-dir));
      const Eigen::Vector3d half = (sun - dir).normalized();
      const double spec = g.material.shine * std::pow(std::max(0.0, n.dot(half)), 40.0) * (light > 0.0 ? 1.0 : 0.0);
      Rgb c = scale(base, static_cast<float>(0.18 + 0.72 * light + fill));
      c = add(c, Rgb{static_cast<float>(spec), static_cast<float>(spec), static_cast<float>(spec)});
      const float a = g.material.opacity;
      accumulated = add(accumulated, scale(c, remaining * a));
      if (shows != nullptr && (*shows == Shows::background || a >= 0.99f)) *shows = g.material.shows;
      remaining *= 1.0f - a;
      t0 = h.distance + eps;
    }
    // Sky: a soft vertical gradient.
    const Rgb sky =
        mix(Rgb{0.93f, 0.94f, 0.96f}, Rgb{0.70f, 0.76f, 0.86f}, static_cast<float>(0.5 + 0.5 * dir.dot(cam.up)));
    return add(accumulated, scale(sky, remaining));
  }
};

// Every pixel: s × s rays through it, averaged; the middle ray says what the pixel shows.
void trace(const Shader& shade, const RenderOptions& o, Picture& pic) {
  const Camera& cam = pic.camera;
  const double aspect = static_cast<double>(o.width) / o.height;
  const Eigen::Vector3d forward = (cam.target - cam.eye).normalized();
  const Eigen::Vector3d right = forward.cross(cam.up).normalized();
  const Eigen::Vector3d up = right.cross(forward);
  const double tan_half = std::tan(0.5 * cam.fov_degrees * std::numbers::pi / 180.0);
  pic.image = Image(o.width, o.height);
  pic.shows.assign(static_cast<std::size_t>(o.width * o.height), Shows::background);
  const int s = std::max(1, o.samples);
  tbb::parallel_for(0, o.height, [&](int y) {
    for (int x = 0; x < o.width; ++x) {
      Rgb sum{0, 0, 0};
      for (int j = 0; j < s; ++j)
        for (int i = 0; i < s; ++i) {
          const double px = (2.0 * (x + (i + 0.5) / s) / o.width - 1.0) * tan_half * aspect;
          const double py = (1.0 - 2.0 * (y + (j + 0.5) / s) / o.height) * tan_half;
          const Eigen::Vector3d dir = (forward + px * right + py * up).normalized();
          Shows* shows = (i == s / 2 && j == s / 2) ? &pic.shows[static_cast<std::size_t>(y * o.width + x)] : nullptr;
          sum = add(sum, shade(cam.eye, dir, shows));
        }
      pic.image.set(x, y, scale(sum, 1.0f / static_cast<float>(s * s)));
    }
  });
}

}  // namespace

Picture render(const World& world, const WorldDesc& desc, const RenderOptions& o) {
  Picture pic;
  const double aspect = static_cast<double>(o.width) / o.height;
  pic.camera = o.camera ? *o.camera : fit_camera(world, o.view_from, 35.0, aspect);
  const Bounds b = subject_bounds(world);
  const bool overlay = o.overlays.beads || o.overlays.cage || o.overlays.centreline || !o.wires.empty();
  SceneParts parts{world, desc, o, std::max((b.hi - b.lo).norm(), 0.05), overlay, pic, {}};
  parts.organs();
  parts.rods();
  if (o.overlays.centreline) parts.centrelines();
  if (o.overlays.beads || o.overlays.colour == Colouring::penetration) parts.beads();
  if (o.overlays.cage) parts.cages();
  if (!o.wires.empty()) parts.wires();
  if (o.overlays.contacts) parts.contacts();
  parts.instruments();
  parts.obstacles();
  parts.containers();
  parts.floors(b);

  EmbreeScene scene;
  for (const Geometry& g : parts.geoms) scene.add_triangles(g.vertices, g.triangles);
  scene.commit();
  trace(Shader{scene, parts.geoms, pic.camera, o.shadows, parts.size}, o, pic);
  return pic;
}

}  // namespace haustra::render
