// Scene files: TOML read into a world description, every value checked with file, line and field.
#include "haustra/scene.hpp"

#include <fmt/format.h>

#include <toml++/toml.h>
#include <fstream>
#include <sstream>

#include "haustra/centreline.hpp"
#include "haustra/error.hpp"
#include "haustra/mesh_io.hpp"

namespace haustra {

struct SceneSource {
  std::string file;
  toml::table root;
};

namespace {

// Where something came from, for messages: "file:line:col", or "file (from --set)".
std::string where(const std::string& file, const toml::source_region& source) {
  if (source.begin.line > 0) return fmt::format("{}:{}:{}", file, source.begin.line, source.begin.column);
  return file + " (from --set)";
}

std::string where(const std::string& file, const toml::node* node) {
  return node != nullptr ? where(file, node->source()) : file + " (from --set)";
}

std::string describe_value(const toml::node& n) {
  std::ostringstream s;
  if (n.is_string()) return fmt::format("the string \"{}\"", *n.value<std::string>());
  if (n.is_table()) return "a table";
  if (n.is_array()) return "an array";
  n.visit([&](const auto& v) { s << v; });
  std::ostringstream type;
  type << n.type();
  return fmt::format("{} ({})", s.str(), type.str());
}

// Reads one scene document into a SceneDesc, checking every field.
class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  // code: parse for what the scene file itself gets wrong; a file it names keeps its own error's code.
  [[noreturn]] void fail(const toml::node* node, const std::string& path, const std::string& detail,
                         ErrorCode code = ErrorCode::parse) const {
    throw FieldError(code, path, detail, fmt::format("{}: {}: {}", where(file_, node), path, detail));
  }

  [[noreturn]] void fail_at(const toml::source_region& source, const std::string& path,
                            const std::string& detail) const {
    throw FieldError(ErrorCode::parse, path, detail, fmt::format("{}: {}: {}", where(file_, source), path, detail));
  }

  // Rejects keys a table does not know, naming the ones it does.
  void check_keys(const toml::table& t, const std::string& path, std::initializer_list<std::string_view> known) const {
    for (const auto& [key, node] : t) {
      if (std::find(known.begin(), known.end(), key.str()) != known.end()) continue;
      std::string list;
      for (auto k : known) list += fmt::format("{}{}", list.empty() ? "" : ", ", k);
      const std::string full = path.empty() ? std::string(key.str()) : path + "." + std::string(key.str());
      fail_at(key.source().begin.line > 0 ? key.source() : node.source(), full,
              fmt::format("unknown key; expected one of: {}", list));
    }
  }

  const toml::table* table(const toml::table& parent, std::string_view key, const std::string& path) const {
    const toml::node* n = parent.get(key);
    if (n == nullptr) return nullptr;
    if (!n->is_table()) fail(n, path, fmt::format("expected a table, got {}", describe_value(*n)));
    return n->as_table();
  }

  double number(const toml::table& t, std::string_view key, const std::string& path, double fallback) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    if (auto v = n->value<double>(); v && (n->is_floating_point() || n->is_integer())) {
      if (!std::isfinite(*v)) fail(n, path, "expected a finite number");
      return *v;
    }
    fail(n, path, fmt::format("expected a number, got {}", describe_value(*n)));
  }

  std::optional<double> optional_number(const toml::table& t, std::string_view key, const std::string& path) const {
    if (t.get(key) == nullptr) return std::nullopt;
    return number(t, key, path, 0.0);
  }

  int integer(const toml::table& t, std::string_view key, const std::string& path, int fallback) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    if (!n->is_integer()) fail(n, path, fmt::format("expected an integer, got {}", describe_value(*n)));
    const std::int64_t v = *n->value<std::int64_t>();
    if (v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max())
      fail(n, path, fmt::format("{} is out of range", v));
    return static_cast<int>(v);
  }

  bool boolean(const toml::table& t, std::string_view key, const std::string& path, bool fallback) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    if (!n->is_boolean()) fail(n, path, fmt::format("expected true or false, got {}", describe_value(*n)));
    return *n->value<bool>();
  }

  std::string string(const toml::table& t, std::string_view key, const std::string& path,
                     const std::string& fallback) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    if (!n->is_string()) fail(n, path, fmt::format("expected a string, got {}", describe_value(*n)));
    return *n->value<std::string>();
  }

  template <class Enum>
  Enum choice(const toml::table& t, std::string_view key, const std::string& path, Enum fallback,
              std::initializer_list<std::pair<std::string_view, Enum>> options) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    const std::string v = string(t, key, path, "");
    std::string list;
    for (const auto& [name, value] : options) {
      if (name == v) return value;
      list += fmt::format("{}\"{}\"", list.empty() ? "" : ", ", name);
    }
    fail(n, path, fmt::format("expected one of {}, got \"{}\"", list, v));
  }

  // A fixed-length array of finite numbers: [x, y, z] or [a, b].
  template <int N>
  Eigen::Matrix<double, N, 1> numbers(const toml::table& t, std::string_view key, const std::string& path,
                                      const Eigen::Matrix<double, N, 1>& fallback) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    const char* shape = N == 3 ? "[x, y, z]" : "[a, b]";
    const toml::array* a = n->as_array();
    if (a == nullptr || a->size() != static_cast<std::size_t>(N))
      fail(n, path, fmt::format("expected {}, got {}", shape, describe_value(*n)));
    Eigen::Matrix<double, N, 1> v;
    for (int i = 0; i < N; ++i) {
      const toml::node& e = *a->get(static_cast<std::size_t>(i));
      if (!(e.is_floating_point() || e.is_integer())) fail(n, path, fmt::format("expected {} numbers", N));
      v[i] = *e.value<double>();
    }
    if (!v.allFinite()) fail(n, path, fmt::format("expected {} finite numbers", N));
    return v;
  }

  Eigen::Vector3d vec3(const toml::table& t, std::string_view key, const std::string& path,
                       const Eigen::Vector3d& fallback) const {
    return numbers<3>(t, key, path, fallback);
  }

  Eigen::Vector2d vec2(const toml::table& t, std::string_view key, const std::string& path,
                       const Eigen::Vector2d& fallback) const {
    return numbers<2>(t, key, path, fallback);
  }

  std::vector<int> integers(const toml::table& t, std::string_view key, const std::string& path) const {
    std::vector<int> out;
    const toml::node* n = t.get(key);
    if (n == nullptr) return out;
    const toml::array* a = n->as_array();
    if (a == nullptr) fail(n, path, fmt::format("expected an array of integers, got {}", describe_value(*n)));
    for (std::size_t i = 0; i < a->size(); ++i) {
      const toml::node& e = *a->get(i);
      if (!e.is_integer())
        fail(n, fmt::format("{}[{}]", path, i), fmt::format("expected an integer, got {}", describe_value(e)));
      out.push_back(static_cast<int>(*e.value<std::int64_t>()));
    }
    return out;
  }

  // [[a, b], ...]: pairs of numbers.
  std::vector<std::pair<double, double>> pairs(const toml::table& t, std::string_view key,
                                               const std::string& path) const {
    std::vector<std::pair<double, double>> out;
    const toml::node* n = t.get(key);
    if (n == nullptr) return out;
    const toml::array* a = n->as_array();
    if (a == nullptr) fail(n, path, fmt::format("expected [[a, b], ...], got {}", describe_value(*n)));
    for (std::size_t i = 0; i < a->size(); ++i) {
      const toml::array* p = a->get(i)->as_array();
      if (p == nullptr || p->size() != 2 || !(p->get(0)->is_number()) || !(p->get(1)->is_number()))
        fail(a->get(i), fmt::format("{}[{}]", path, i), "expected [a, b] of two numbers");
      out.emplace_back(*p->get(0)->value<double>(), *p->get(1)->value<double>());
    }
    return out;
  }

  // An array of tables (TOML [[name]]); absent is empty.
  std::vector<const toml::table*> tables(const toml::table& t, std::string_view key, const std::string& path) const {
    std::vector<const toml::table*> out;
    const toml::node* n = t.get(key);
    if (n == nullptr) return out;
    const toml::array* a = n->as_array();
    if (a == nullptr) fail(n, path, fmt::format("expected [[{}]] tables, got {}", key, describe_value(*n)));
    for (std::size_t i = 0; i < a->size(); ++i) {
      const toml::node* e = a->get(i);
      if (!e->is_table()) fail(e, fmt::format("{}[{}]", path, i), "expected a table");
      out.push_back(e->as_table());
    }
    return out;
  }

  const std::string& file() const { return file_; }

 private:
  std::string file_;
};

StrainLaw read_law(const Reader& r, const toml::table& t, std::string_view key, const std::string& path,
                   StrainLaw fallback) {
  return r.choice<StrainLaw>(
      t, key, path, fallback,
      {{"elastic", StrainLaw::elastic}, {"viscous", StrainLaw::viscous}, {"kelvin-voigt", StrainLaw::kelvin_voigt}});
}

OrganMeshDesc read_organ_mesh(const Reader& r, const toml::table& t, const std::string& path,
                              const std::filesystem::path& scene_dir) {
  r.check_keys(t, path,
               {"source", "file", "scale", "translate", "procedural", "cage", "skinning", "rings_per_vertex",
                "weight_left_out", "normals"});
  OrganMeshDesc d;
  d.enabled = true;
  const toml::node* file_node = t.get("file");
  d.source = r.choice<MeshSource>(t, "source", path + ".source",
                                  file_node != nullptr ? MeshSource::file : MeshSource::procedural,
                                  {{"procedural", MeshSource::procedural}, {"file", MeshSource::file}});
  if (d.source == MeshSource::file) {
    if (file_node == nullptr) r.fail(&t, path + ".file", "a mesh with source = \"file\" needs file = \"path\"");
    d.file = (scene_dir / r.string(t, "file", path + ".file", "")).string();
    if (!std::filesystem::exists(d.file))
      r.fail(file_node, path + ".file", fmt::format("{}: no such mesh file", d.file), ErrorCode::io);
  } else if (file_node != nullptr) {
    r.fail(file_node, path + ".file", "only a mesh with source = \"file\" reads a file");
  }
  d.scale = r.number(t, "scale", path + ".scale", d.scale);
  d.translate = r.vec3(t, "translate", path + ".translate", d.translate);
  d.skinning =
      r.choice<SkinningMethod>(t, "skinning", path + ".skinning", d.skinning,
                               {{"mvc", SkinningMethod::mean_value}, {"linear-blend", SkinningMethod::linear_blend}});
  d.rings_per_vertex = r.integer(t, "rings_per_vertex", path + ".rings_per_vertex", d.rings_per_vertex);
  d.weight_left_out = r.number(t, "weight_left_out", path + ".weight_left_out", d.weight_left_out);
  d.normals = r.boolean(t, "normals", path + ".normals", d.normals);
  if (const toml::table* p = r.table(t, "procedural", path + ".procedural")) {
    const std::string pp = path + ".procedural";
    r.check_keys(*p, pp, {"vertices", "radius", "haustra_spacing", "haustra_depth", "taenia_depth", "end_taper"});
    ProceduralOrganDesc& o = d.procedural;
    o.vertices = r.integer(*p, "vertices", pp + ".vertices", o.vertices);
    o.radius = r.number(*p, "radius", pp + ".radius", o.radius);
    o.haustra_spacing = r.number(*p, "haustra_spacing", pp + ".haustra_spacing", o.haustra_spacing);
    o.haustra_depth = r.number(*p, "haustra_depth", pp + ".haustra_depth", o.haustra_depth);
    o.taenia_depth = r.number(*p, "taenia_depth", pp + ".taenia_depth", o.taenia_depth);
    o.end_taper = r.number(*p, "end_taper", pp + ".end_taper", o.end_taper);
  }
  if (const toml::table* c = r.table(t, "cage", path + ".cage")) {
    const std::string cp = path + ".cage";
    r.check_keys(*c, cp, {"ring_vertices", "middle_rings", "clearance", "max_iterations", "binding"});
    d.cage.binding = r.choice<CageBinding>(
        *c, "binding", cp + ".binding", d.cage.binding,
        {{"auto", CageBinding::automatic}, {"closest", CageBinding::closest}, {"harmonic", CageBinding::harmonic}});
    d.cage.ring_vertices = r.integer(*c, "ring_vertices", cp + ".ring_vertices", d.cage.ring_vertices);
    d.cage.middle_rings = r.boolean(*c, "middle_rings", cp + ".middle_rings", d.cage.middle_rings);
    d.cage.clearance = r.number(*c, "clearance", cp + ".clearance", d.cage.clearance);
    d.cage.max_iterations = r.integer(*c, "max_iterations", cp + ".max_iterations", d.cage.max_iterations);
  }
  return d;
}

SegmentDesc read_segment(const Reader& r, const toml::table& t, const std::string& path,
                         const std::filesystem::path& scene_dir) {
  r.check_keys(t, path, {"name",          "nodes",         "rest",           "law",
                         "base",          "base_position", "base_tangent",   "base_normal",
                         "drag",          "radius",        "wall_thickness", "youngs_modulus",
                         "poisson_ratio", "density",       "linear_density", "relaxation_time",
                         "attachment",    "load",          "beads",          "mesh",
                         "chain",         "tissue"});
  SegmentDesc s;
  s.name = r.string(t, "name", path + ".name", path);
  s.nodes = r.integer(t, "nodes", path + ".nodes", s.nodes);
  s.base =
      r.choice<BaseMode>(t, "base", path + ".base", s.base, {{"clamped", BaseMode::clamped}, {"free", BaseMode::free}});
  s.base_position = r.vec3(t, "base_position", path + ".base_position", s.base_position);
  s.base_tangent = r.vec3(t, "base_tangent", path + ".base_tangent", s.base_tangent);
  s.base_normal = r.vec3(t, "base_normal", path + ".base_normal", s.base_normal);
  s.drag = r.optional_number(t, "drag", path + ".drag");
  s.cross_section.radius = r.number(t, "radius", path + ".radius", s.cross_section.radius);
  s.cross_section.wall_thickness =
      r.number(t, "wall_thickness", path + ".wall_thickness", s.cross_section.wall_thickness);
  s.material.youngs_modulus = r.number(t, "youngs_modulus", path + ".youngs_modulus", s.material.youngs_modulus);
  s.material.poisson_ratio = r.number(t, "poisson_ratio", path + ".poisson_ratio", s.material.poisson_ratio);
  s.material.density = r.number(t, "density", path + ".density", s.material.density);
  s.linear_density = r.optional_number(t, "linear_density", path + ".linear_density");
  s.relaxation_time = r.number(t, "relaxation_time", path + ".relaxation_time", s.relaxation_time);

  if (const toml::table* rest = r.table(t, "rest", path + ".rest")) {
    const std::string rp = path + ".rest";
    r.check_keys(*rest, rp, {"shape", "length", "curvature", "torsion", "file"});
    s.rest.kind = r.choice<RestShapeKind>(*rest, "shape", rp + ".shape", s.rest.kind,
                                          {{"straight", RestShapeKind::straight},
                                           {"arc", RestShapeKind::constant_strain},
                                           {"centreline", RestShapeKind::centreline}});
    s.rest.length = r.number(*rest, "length", rp + ".length", s.rest.length);
    const Eigen::Vector2d k = r.vec2(*rest, "curvature", rp + ".curvature", Eigen::Vector2d::Zero());
    s.rest.curvature_torsion = {k.x(), k.y(), r.number(*rest, "torsion", rp + ".torsion", 0.0)};
    const toml::node* file_node = rest->get("file");
    if (s.rest.kind == RestShapeKind::centreline) {
      if (file_node == nullptr) r.fail(rest, rp + ".file", "a centreline rest shape needs file = \"path.json\"");
      const std::filesystem::path f = scene_dir / r.string(*rest, "file", rp + ".file", "");
      try {
        Centreline c = read_centreline(f);
        s.rest.centreline = std::move(c.points);
        s.rest.centreline_source = f.string();
      } catch (const Error& e) {
        r.fail(file_node, rp + ".file", e.what(), e.code());
      }
    } else if (file_node != nullptr) {
      r.fail(file_node, rp + ".file", "only a rest shape with shape = \"centreline\" reads a file");
    }
  }
  if (const toml::table* tissue = r.table(t, "tissue", path + ".tissue")) {
    const std::string tp = path + ".tissue";
    r.check_keys(*tissue, tp, {"response", "alpha", "beta", "gamma"});
    s.material.response = r.choice<TissueResponse>(*tissue, "response", tp + ".response", s.material.response,
                                                   {{"hooke", TissueResponse::hooke}, {"exp2", TissueResponse::exp2}});
    s.material.exp2_alpha = r.number(*tissue, "alpha", tp + ".alpha", s.material.exp2_alpha);
    s.material.exp2_beta = r.number(*tissue, "beta", tp + ".beta", s.material.exp2_beta);
    s.material.exp2_gamma = r.number(*tissue, "gamma", tp + ".gamma", s.material.exp2_gamma);
  }
  if (const toml::table* law = r.table(t, "law", path + ".law")) {
    const std::string lp = path + ".law";
    r.check_keys(*law, lp, {"bending", "torsion", "axial"});
    const StrainLaw bending = read_law(r, *law, "bending", lp + ".bending", s.law[kappa1]);
    s.law[kappa1] = bending;
    s.law[kappa2] = bending;
    s.law[torsion] = read_law(r, *law, "torsion", lp + ".torsion", s.law[torsion]);
    s.law[axial] = read_law(r, *law, "axial", lp + ".axial", s.law[axial]);
  }
  if (const toml::table* beads = r.table(t, "beads", path + ".beads")) {
    const std::string bp = path + ".beads";
    r.check_keys(*beads, bp, {"count", "spacing", "nodes", "radius", "radius_profile"});
    s.beads.enabled = true;
    s.beads.count = r.integer(*beads, "count", bp + ".count", 0);
    s.beads.spacing = r.number(*beads, "spacing", bp + ".spacing", 0.0);
    s.beads.nodes = r.integers(*beads, "nodes", bp + ".nodes");
    if (const toml::node* radius = beads->get("radius"); radius != nullptr && radius->is_string()) {
      if (*radius->value<std::string>() != "mesh")
        r.fail(radius, bp + ".radius",
               fmt::format("expected a radius in m or \"mesh\" (from the organ mesh's cross-sections), got \"{}\"",
                           *radius->value<std::string>()));
      s.beads.radius_from_mesh = true;
    } else {
      s.beads.radius = r.number(*beads, "radius", bp + ".radius", 0.0);
    }
    s.beads.radius_profile = r.pairs(*beads, "radius_profile", bp + ".radius_profile");
  }
  if (const toml::table* mesh = r.table(t, "mesh", path + ".mesh"))
    s.mesh = read_organ_mesh(r, *mesh, path + ".mesh", scene_dir);
  if (const toml::table* chain = r.table(t, "chain", path + ".chain")) {
    r.check_keys(*chain, path + ".chain", {"pieces"});
    s.chain_pieces = r.integer(*chain, "pieces", path + ".chain.pieces", s.chain_pieces);
  }
  const auto attachments = r.tables(t, "attachment", path + ".attachment");
  for (std::size_t i = 0; i < attachments.size(); ++i) {
    const toml::table& a = *attachments[i];
    const std::string ap = fmt::format("{}.attachment[{}]", path, i);
    r.check_keys(a, ap, {"node", "hold_frame", "target", "active"});
    if (a.get("node") == nullptr) r.fail(&a, ap + ".node", "an attachment needs node = <index> (−1 is the tip)");
    AttachmentDesc d;
    d.node = r.integer(a, "node", ap + ".node", -1);
    d.hold_frame = r.boolean(a, "hold_frame", ap + ".hold_frame", false);
    if (a.get("target") != nullptr) d.target = r.vec3(a, "target", ap + ".target", Eigen::Vector3d::Zero());
    d.active = r.boolean(a, "active", ap + ".active", true);
    s.attachments.push_back(d);
  }
  const auto loads = r.tables(t, "load", path + ".load");
  for (std::size_t i = 0; i < loads.size(); ++i) {
    const toml::table& l = *loads[i];
    const std::string lp = fmt::format("{}.load[{}]", path, i);
    r.check_keys(l, lp, {"node", "force", "moment"});
    if (l.get("node") == nullptr) r.fail(&l, lp + ".node", "a load needs node = <index> (−1 is the tip)");
    PointLoadDesc d;
    d.node = r.integer(l, "node", lp + ".node", -1);
    d.force = r.vec3(l, "force", lp + ".force", Eigen::Vector3d::Zero());
    d.moment = r.vec3(l, "moment", lp + ".moment", Eigen::Vector3d::Zero());
    s.loads.push_back(d);
  }
  return s;
}

// Each [[environment.<key>]] table through `read`, into `out`.
template <class Desc, class Read>
void read_obstacles(const Reader& r, const toml::table& t, const char* key, std::vector<Desc>& out, Read read) {
  const auto tables = r.tables(t, key, fmt::format("environment.{}", key));
  for (std::size_t i = 0; i < tables.size(); ++i)
    out.push_back(read(*tables[i], fmt::format("environment.{}[{}]", key, i)));
}

void read_environment(const Reader& r, const toml::table& t, const std::filesystem::path& scene_dir,
                      EnvironmentDesc& env) {
  r.check_keys(t, "environment", {"plane", "sphere", "capsule", "mesh"});
  read_obstacles(r, t, "plane", env.planes, [&](const toml::table& o, const std::string& p) {
    r.check_keys(o, p, {"name", "point", "normal"});
    PlaneDesc d;
    d.name = r.string(o, "name", p + ".name", p);
    d.point = r.vec3(o, "point", p + ".point", d.point);
    d.normal = r.vec3(o, "normal", p + ".normal", d.normal);
    return d;
  });
  read_obstacles(r, t, "sphere", env.spheres, [&](const toml::table& o, const std::string& p) {
    r.check_keys(o, p, {"name", "center", "radius"});
    SphereObstacleDesc d;
    d.name = r.string(o, "name", p + ".name", p);
    d.center = r.vec3(o, "center", p + ".center", d.center);
    d.radius = r.number(o, "radius", p + ".radius", d.radius);
    return d;
  });
  read_obstacles(r, t, "capsule", env.capsules, [&](const toml::table& o, const std::string& p) {
    r.check_keys(o, p, {"name", "a", "b", "radius"});
    CapsuleObstacleDesc d;
    d.name = r.string(o, "name", p + ".name", p);
    d.a = r.vec3(o, "a", p + ".a", d.a);
    d.b = r.vec3(o, "b", p + ".b", d.b);
    d.radius = r.number(o, "radius", p + ".radius", d.radius);
    return d;
  });
  read_obstacles(r, t, "mesh", env.meshes, [&](const toml::table& o, const std::string& p) {
    r.check_keys(o, p, {"name", "file", "scale", "translate"});
    const toml::node* file_node = o.get("file");
    if (file_node == nullptr) r.fail(&o, p + ".file", "a mesh obstacle needs file = \"path\"");
    MeshObstacleDesc d;
    d.name = r.string(o, "name", p + ".name", p);
    const std::filesystem::path f = scene_dir / r.string(o, "file", p + ".file", "");
    const double scale = r.number(o, "scale", p + ".scale", 1.0);
    if (!(scale > 0.0)) r.fail(o.get("scale"), p + ".scale", "expected a positive scale (e.g. 0.001 for millimetres)");
    const Eigen::Vector3d translate = r.vec3(o, "translate", p + ".translate", Eigen::Vector3d::Zero());
    try {
      TriangleMesh mesh = load_mesh(f);
      for (auto& v : mesh.vertices) v = scale * v + translate;
      d.vertices = std::move(mesh.vertices);
      d.triangles = std::move(mesh.triangles);
      d.source = f.string();
    } catch (const Error& e) {
      r.fail(file_node, p + ".file", e.what(), e.code());
    }
    return d;
  });
}

InstrumentDesc read_instrument(const Reader& r, const toml::table& t, const std::string& path) {
  r.check_keys(t, path,
               {"name", "radius", "length", "grasp_reach", "hold_frame", "force_filter", "tip", "axis", "keyframe"});
  InstrumentDesc d;
  d.name = r.string(t, "name", path + ".name", path);
  d.radius = r.number(t, "radius", path + ".radius", d.radius);
  d.length = r.number(t, "length", path + ".length", d.length);
  d.grasp_reach = r.number(t, "grasp_reach", path + ".grasp_reach", d.grasp_reach);
  d.hold_frame = r.boolean(t, "hold_frame", path + ".hold_frame", d.hold_frame);
  d.force_filter = r.number(t, "force_filter", path + ".force_filter", d.force_filter);
  d.tip = r.vec3(t, "tip", path + ".tip", d.tip);
  d.axis = r.vec3(t, "axis", path + ".axis", d.axis);
  const auto keyframes = r.tables(t, "keyframe", path + ".keyframe");
  for (std::size_t i = 0; i < keyframes.size(); ++i) {
    const std::string kp = fmt::format("{}.keyframe[{}]", path, i);
    r.check_keys(*keyframes[i], kp, {"time", "tip", "axis", "grasp"});
    if (keyframes[i]->get("time") == nullptr) r.fail(keyframes[i], kp + ".time", "a keyframe needs time = <s>");
    InstrumentKeyframe k;
    k.time = r.number(*keyframes[i], "time", kp + ".time", 0.0);
    k.tip = r.vec3(*keyframes[i], "tip", kp + ".tip", i > 0 ? d.keyframes.back().tip : d.tip);
    k.axis = r.vec3(*keyframes[i], "axis", kp + ".axis", i > 0 ? d.keyframes.back().axis : d.axis);
    k.grasp = r.boolean(*keyframes[i], "grasp", kp + ".grasp", i > 0 && d.keyframes.back().grasp);
    d.keyframes.push_back(k);
  }
  return d;
}

SceneDesc read_scene(const Reader& r, const toml::table& root, const std::filesystem::path& file) {
  r.check_keys(root, "", {"scene", "world", "solver", "filter", "segment", "contact", "environment", "instrument"});
  SceneDesc scene;
  scene.file = file;
  if (const toml::table* t = r.table(root, "scene", "scene")) {
    r.check_keys(*t, "scene", {"name", "description", "frames"});
    scene.name = r.string(*t, "name", "scene.name", "");
    scene.description = r.string(*t, "description", "scene.description", "");
    scene.frames = r.integer(*t, "frames", "scene.frames", scene.frames);
    if (scene.frames < 0) r.fail(t->get("frames"), "scene.frames", "expected a non-negative frame count");
  }
  if (scene.name.empty()) scene.name = file.stem().string();
  WorldDesc& w = scene.world;
  if (const toml::table* t = r.table(root, "world", "world")) {
    r.check_keys(*t, "world", {"dt", "gravity", "threads", "memory_limit"});
    w.dt = r.number(*t, "dt", "world.dt", w.dt);
    w.gravity = r.vec3(*t, "gravity", "world.gravity", w.gravity);
    w.threads = r.integer(*t, "threads", "world.threads", w.threads);
    w.memory_limit = r.number(*t, "memory_limit", "world.memory_limit", w.memory_limit);
  }
  if (const toml::table* t = r.table(root, "solver", "solver")) {
    r.check_keys(*t, "solver",
                 {"mode", "iterations", "substeps", "relaxation", "tolerance", "max_iterations", "attachment_tolerance",
                  "refactor_frames", "on_instability", "max_substeps", "max_axial_strain", "max_section_angle",
                  "max_displacement", "max_attachment_error"});
    SolverDesc& s = w.solver;
    s.mode = r.choice<SolverMode>(
        *t, "mode", "solver.mode", s.mode,
        {{"newton", SolverMode::newton}, {"lagged", SolverMode::lagged}, {"fast", SolverMode::fast}});
    s.iterations = r.integer(*t, "iterations", "solver.iterations", s.iterations);
    s.substeps = r.integer(*t, "substeps", "solver.substeps", s.substeps);
    s.relaxation = r.number(*t, "relaxation", "solver.relaxation", s.relaxation);
    s.tolerance = r.number(*t, "tolerance", "solver.tolerance", s.tolerance);
    s.max_iterations = r.integer(*t, "max_iterations", "solver.max_iterations", s.max_iterations);
    s.refactor_frames = r.integer(*t, "refactor_frames", "solver.refactor_frames", s.refactor_frames);
    s.attachment_tolerance =
        r.number(*t, "attachment_tolerance", "solver.attachment_tolerance", s.attachment_tolerance);
    s.on_instability =
        r.choice<InstabilityPolicy>(*t, "on_instability", "solver.on_instability", s.on_instability,
                                    {{"recover", InstabilityPolicy::recover}, {"stop", InstabilityPolicy::stop}});
    s.max_substeps = r.integer(*t, "max_substeps", "solver.max_substeps", s.max_substeps);
    s.max_axial_strain = r.number(*t, "max_axial_strain", "solver.max_axial_strain", s.max_axial_strain);
    s.max_section_angle = r.number(*t, "max_section_angle", "solver.max_section_angle", s.max_section_angle);
    s.max_displacement = r.number(*t, "max_displacement", "solver.max_displacement", s.max_displacement);
    s.max_attachment_error =
        r.number(*t, "max_attachment_error", "solver.max_attachment_error", s.max_attachment_error);
  }
  if (const toml::table* t = r.table(root, "filter", "filter")) {
    r.check_keys(*t, "filter", {"enabled", "zeta_scale"});
    w.filter.enabled = r.boolean(*t, "enabled", "filter.enabled", w.filter.enabled);
    w.filter.zeta_scale = r.number(*t, "zeta_scale", "filter.zeta_scale", w.filter.zeta_scale);
  }
  const auto segments = r.tables(root, "segment", "segment");
  for (std::size_t i = 0; i < segments.size(); ++i)
    w.segments.push_back(read_segment(r, *segments[i], fmt::format("segment[{}]", i), file.parent_path()));
  if (const toml::table* t = r.table(root, "contact", "contact")) {
    r.check_keys(*t, "contact", {"coefficient", "exponent", "margin", "broad_phase", "self"});
    ContactDesc& c = w.contact;
    c.coefficient = r.number(*t, "coefficient", "contact.coefficient", c.coefficient);
    c.exponent = r.number(*t, "exponent", "contact.exponent", c.exponent);
    c.margin = r.number(*t, "margin", "contact.margin", c.margin);
    c.broad_phase = r.choice<BroadPhase>(*t, "broad_phase", "contact.broad_phase", c.broad_phase,
                                         {{"auto", BroadPhase::automatic},
                                          {"grid", BroadPhase::grid},
                                          {"sweep", BroadPhase::sweep},
                                          {"brute", BroadPhase::brute}});
    c.self = r.boolean(*t, "self", "contact.self", c.self);
  }
  if (const toml::table* t = r.table(root, "environment", "environment"))
    read_environment(r, *t, file.parent_path(), w.environment);
  const auto instruments = r.tables(root, "instrument", "instrument");
  for (std::size_t i = 0; i < instruments.size(); ++i)
    w.instruments.push_back(read_instrument(r, *instruments[i], fmt::format("instrument[{}]", i)));
  return scene;
}

// "segment[1].nodes" → {"segment", 1}, {"nodes", none}
struct PathPart {
  std::string key;
  std::optional<std::size_t> index;
};

std::vector<PathPart> split_path(const std::string& path, const std::string& file) {
  std::vector<PathPart> parts;
  std::size_t start = 0;
  while (start <= path.size()) {
    const std::size_t dot = path.find('.', start);
    std::string piece = path.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    PathPart part;
    if (const std::size_t lb = piece.find('['); lb != std::string::npos) {
      const std::size_t rb = piece.find(']', lb);
      if (rb == std::string::npos || rb + 1 != piece.size())
        throw Error(ErrorCode::invalid_argument, fmt::format("{}: --set {}: expected key[index]", file, path));
      try {
        part.index = static_cast<std::size_t>(std::stoul(piece.substr(lb + 1, rb - lb - 1)));
      } catch (const std::exception&) {
        throw Error(ErrorCode::invalid_argument, fmt::format("{}: --set {}: the index must be a number", file, path));
      }
      piece = piece.substr(0, lb);
    }
    if (piece.empty()) throw Error(ErrorCode::invalid_argument, fmt::format("{}: --set {}: empty key", file, path));
    part.key = piece;
    parts.push_back(part);
    if (dot == std::string::npos) break;
    start = dot + 1;
  }
  return parts;
}

void set_path(toml::table& table, std::span<const PathPart> parts, const toml::node& value, const std::string& what) {
  const PathPart& p = parts.front();
  if (parts.size() == 1) {
    if (p.index) throw Error(ErrorCode::invalid_argument, what + ": cannot index the last key");
    const toml::node* existing = table.get(p.key);
    if (existing != nullptr && (existing->is_table() || existing->is_array_of_tables()))
      throw Error(ErrorCode::invalid_argument, what + ": that key is a table, not a value");
    table.insert_or_assign(p.key, value);
    return;
  }
  toml::node* n = table.get(p.key);
  if (n == nullptr) {
    if (p.index) throw Error(ErrorCode::invalid_argument, fmt::format("{}: there is no {}[{}]", what, p.key, *p.index));
    table.insert(p.key, toml::table{});
    n = table.get(p.key);
  }
  if (toml::array* a = n->as_array(); a != nullptr && a->is_array_of_tables()) {
    if (p.index) {
      if (*p.index >= a->size())
        throw Error(ErrorCode::invalid_argument,
                    fmt::format("{}: {}[{}] does not exist (there are {})", what, p.key, *p.index, a->size()));
      set_path(*a->get(*p.index)->as_table(), parts.subspan(1), value, what);
    } else {
      for (auto& e : *a) set_path(*e.as_table(), parts.subspan(1), value, what);
    }
    return;
  }
  if (!n->is_table() || p.index)
    throw Error(ErrorCode::invalid_argument, fmt::format("{}: {} is not a table", what, p.key));
  set_path(*n->as_table(), parts.subspan(1), value, what);
}

void apply_override(toml::table& root, const std::string& assignment, const std::string& file) {
  const std::size_t eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw Error(ErrorCode::invalid_argument, fmt::format("{}: --set {}: expected key=value", file, assignment));
  const std::string key = assignment.substr(0, eq);
  const std::string text = assignment.substr(eq + 1);
  toml::table parsed;
  try {
    parsed = toml::parse("v = " + text);
  } catch (const toml::parse_error&) {
    parsed = toml::table{{"v", text}};  // a bare word is a string
  }
  set_path(root, split_path(key, file), *parsed.get("v"), fmt::format("{}: --set {}", file, assignment));
}

}  // namespace

SceneDesc parse_scene(const std::string& text, const std::filesystem::path& file,
                      std::span<const std::string> overrides) {
  auto source = std::make_shared<SceneSource>();
  source->file = file.string();
  try {
    source->root = toml::parse(text, file.string());
  } catch (const toml::parse_error& e) {
    throw Error(ErrorCode::parse, fmt::format("{}:{}:{}: not valid TOML: {}", file.string(), e.source().begin.line,
                                              e.source().begin.column, e.description()));
  }
  for (const std::string& o : overrides) apply_override(source->root, o, file.string());
  const Reader reader(file.string());
  SceneDesc scene = read_scene(reader, source->root, file);
  scene.source = source;
  return scene;
}

SceneDesc load_scene(const std::filesystem::path& file, std::span<const std::string> overrides) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw Error(ErrorCode::io, fmt::format("{}: cannot open the scene file", file.string()));
  std::ostringstream text;
  text << in.rdbuf();
  return parse_scene(text.str(), file, overrides);
}

std::unique_ptr<World> create_world(const SceneDesc& scene) {
  try {
    return World::create(scene.world);
  } catch (const FieldError& e) {
    if (!scene.source) throw;
    // Find the node the field path names: "segment[0].rest.length".
    const toml::node* node = nullptr;
    const toml::node* nearest = &scene.source->root;
    toml::node_view<const toml::node> view{scene.source->root};
    std::string path = e.field();
    std::size_t start = 0;
    bool found = true;
    while (start < path.size()) {
      const std::size_t dot = path.find('.', start);
      std::string piece = path.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
      std::optional<std::size_t> index;
      if (const std::size_t lb = piece.find('['); lb != std::string::npos) {
        index = static_cast<std::size_t>(std::stoul(piece.substr(lb + 1)));
        piece = piece.substr(0, lb);
      }
      view = view[piece];
      if (index) view = view[*index];
      if (!view) {
        found = false;
        break;
      }
      nearest = view.node();
      if (dot == std::string::npos) break;
      start = dot + 1;
    }
    node = found ? view.node() : nearest;
    const std::string loc = where(scene.source->file, node);
    const std::string note = found ? "" : " (not set in the file: the default does not suit the rest of the scene)";
    throw FieldError(e.code(), e.field(), e.detail(), fmt::format("{}: {}: {}{}", loc, e.field(), e.detail(), note));
  }
}

}  // namespace haustra
