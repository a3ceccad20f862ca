// Scene files: TOML read into a world description, every value checked with file, line and field.
#include "haustra/scene.hpp"

#include <fmt/format.h>

#include <toml++/toml.h>
#include <algorithm>
#include <cctype>

#include "haustra/centreline.hpp"
#include "haustra/error.hpp"
#include "haustra/mesh_io.hpp"
#include "io/bounded_input.hpp"
#include "io/scene_overrides.hpp"
#include "io/scene_reader.hpp"

namespace haustra {

struct SceneSource {
  std::string file;
  toml::table root;
};

namespace {

using scene_io::Reader;
using scene_io::where;

StrainLaw read_law(const Reader& r, const toml::table& t, std::string_view key, const std::string& path,
                   StrainLaw fallback) {
  return r.choice<StrainLaw>(
      t, key, path, fallback,
      {{"elastic", StrainLaw::elastic}, {"viscous", StrainLaw::viscous}, {"kelvin-voigt", StrainLaw::kelvin_voigt}});
}

OrganMeshDesc read_organ_mesh(const Reader& r, const toml::table& t, const std::string& path,
                              const std::filesystem::path& scene_dir) {
  r.refuse_removed(
      t, path,
      {"rings_per_vertex", "weight_left_out", "max_rings_per_vertex", "mean_rings_per_vertex", "skin_cost_limit"},
      "removed (decision 0120): choose mesh.skinning = \"along-rod\" | \"cage\" | \"cage-full\" | "
      "\"linear-blend\"");
  r.check_keys(t, path, {"source", "file", "scale", "translate", "procedural", "cage", "skinning", "normals"});
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
  if (const toml::node* n = t.get("skinning"); n != nullptr && n->value<std::string>() == "mvc")
    r.fail(n, path + ".skinning", "\"mvc\" was renamed (decision 0120): skinning = \"cage\"");
  d.skinning = r.choice<SkinningMethod>(t, "skinning", path + ".skinning", d.skinning,
                                        {{"along-rod", SkinningMethod::along_rod},
                                         {"cage", SkinningMethod::cage},
                                         {"cage-full", SkinningMethod::cage_full},
                                         {"linear-blend", SkinningMethod::linear_blend}});
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

// [segment.rest]: straight, an arc, or a centreline read from a file beside the scene.
void read_rest(const Reader& r, const toml::table& t, const std::string& path, const std::filesystem::path& scene_dir,
               SegmentDesc& s) {
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
}

// [segment.tissue] (Hooke or EXP2) and [segment.law] (elastic, viscous or viscoelastic per strain).
void read_tissue_and_law(const Reader& r, const toml::table& t, const std::string& path, SegmentDesc& s) {
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
}

// [segment.beads]: a count, a spacing or nodes; a radius, "mesh" or a profile along the rod.
void read_beads(const Reader& r, const toml::table& t, const std::string& path, SegmentDesc& s) {
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
}

// [[segment.attachment]] and [[segment.load]].
void read_attachments_and_loads(const Reader& r, const toml::table& t, const std::string& path, SegmentDesc& s) {
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
  const auto distributed = r.tables(t, "distributed_load", path + ".distributed_load");
  for (std::size_t i = 0; i < distributed.size(); ++i) {
    const toml::table& l = *distributed[i];
    const std::string lp = fmt::format("{}.distributed_load[{}]", path, i);
    r.check_keys(l, lp, {"from", "to", "force", "moment"});
    DistributedLoadDesc d;
    d.from = r.integer(l, "from", lp + ".from", 0);
    d.to = r.integer(l, "to", lp + ".to", -1);
    d.force = r.vec3(l, "force", lp + ".force", Eigen::Vector3d::Zero());
    d.moment = r.vec3(l, "moment", lp + ".moment", Eigen::Vector3d::Zero());
    s.distributed_loads.push_back(d);
  }
}

// [[segment.anchors]]: connective tissue over a range of the organ (decision 0095).
void read_anchors(const Reader& r, const toml::table& t, const std::string& path, SegmentDesc& s) {
  const auto ranges = r.tables(t, "anchors", path + ".anchors");
  for (std::size_t i = 0; i < ranges.size(); ++i) {
    const toml::table& a = *ranges[i];
    const std::string ap = fmt::format("{}.anchors[{}]", path, i);
    r.check_keys(a, ap,
                 {"name", "from", "to", "target", "root", "stiffness", "damping", "slack", "strength", "support"});
    AnchorsDesc d;
    d.name = r.string(a, "name", ap + ".name", d.name);
    d.from = r.number(a, "from", ap + ".from", d.from);
    d.to = r.number(a, "to", ap + ".to", d.to);
    d.target = r.choice<AnchorTarget>(a, "target", ap + ".target", d.target,
                                      {{"rest", AnchorTarget::rest}, {"root", AnchorTarget::root}});
    d.root = r.points(a, "root", ap + ".root");
    if (!d.root.empty() && a.get("target") == nullptr) d.target = AnchorTarget::root;
    d.stiffness = r.number(a, "stiffness", ap + ".stiffness", d.stiffness);
    d.damping = r.number(a, "damping", ap + ".damping", d.damping);
    d.slack = r.number(a, "slack", ap + ".slack", d.slack);
    d.strength = r.number(a, "strength", ap + ".strength", d.strength);
    d.support = r.number(a, "support", ap + ".support", d.support);
    s.anchors.push_back(std::move(d));
  }
}

SegmentDesc read_segment(const Reader& r, const toml::table& t, const std::string& path,
                         const std::filesystem::path& scene_dir) {
  r.check_keys(t, path,
               {"name",
                "nodes",
                "rest",
                "law",
                "base",
                "base_position",
                "base_tangent",
                "base_normal",
                "drag",
                "radius",
                "wall_thickness",
                "youngs_modulus",
                "poisson_ratio",
                "density",
                "linear_density",
                "relaxation_time",
                "attachment",
                "load",
                "distributed_load",
                "beads",
                "mesh",
                "chain",
                "tissue",
                "anchors",
                "failure_strain"});
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
  s.material.failure_strain = r.number(t, "failure_strain", path + ".failure_strain", s.material.failure_strain);

  read_rest(r, t, path, scene_dir, s);
  read_tissue_and_law(r, t, path, s);
  read_beads(r, t, path, s);
  if (const toml::table* mesh = r.table(t, "mesh", path + ".mesh"))
    s.mesh = read_organ_mesh(r, *mesh, path + ".mesh", scene_dir);
  if (const toml::table* chain = r.table(t, "chain", path + ".chain")) {
    r.check_keys(*chain, path + ".chain", {"pieces"});
    s.chain_pieces = r.integer(*chain, "pieces", path + ".chain.pieces", s.chain_pieces);
  }
  read_attachments_and_loads(r, t, path, s);
  read_anchors(r, t, path, s);
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
    r.check_keys(o, p, {"name", "file", "scale", "translate", "container"});
    const toml::node* file_node = o.get("file");
    if (file_node == nullptr) r.fail(&o, p + ".file", "a mesh obstacle needs file = \"path\"");
    MeshObstacleDesc d;
    d.name = r.string(o, "name", p + ".name", p);
    const std::filesystem::path f = scene_dir / r.string(o, "file", p + ".file", "");
    const double scale = r.number(o, "scale", p + ".scale", 1.0);
    if (!(scale > 0.0) || !(scale <= 1e5))
      r.fail(o.get("scale"), p + ".scale", "expected a positive scale up to 1e5 (e.g. 0.001 for millimetres)");
    const Eigen::Vector3d translate = r.vec3(o, "translate", p + ".translate", Eigen::Vector3d::Zero());
    if (!(translate.cwiseAbs().maxCoeff() <= 1e5))
      r.fail(o.get("translate"), p + ".translate", "expected three numbers within ±1e5 m");
    d.container = r.boolean(o, "container", p + ".container", d.container);
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
               {"name", "radius", "length", "grasp_reach", "hold_frame", "force_filter", "tip", "axis", "keyframe",
                "coupling_stiffness", "coupling_damping", "force_limit", "holding_force", "cut_radius", "proxy"});
  InstrumentDesc d;
  d.name = r.string(t, "name", path + ".name", path);
  d.radius = r.number(t, "radius", path + ".radius", d.radius);
  d.length = r.number(t, "length", path + ".length", d.length);
  d.grasp_reach = r.number(t, "grasp_reach", path + ".grasp_reach", d.grasp_reach);
  d.hold_frame = r.boolean(t, "hold_frame", path + ".hold_frame", d.hold_frame);
  d.force_filter = r.number(t, "force_filter", path + ".force_filter", d.force_filter);
  d.coupling_stiffness = r.number(t, "coupling_stiffness", path + ".coupling_stiffness", d.coupling_stiffness);
  d.coupling_damping = r.number(t, "coupling_damping", path + ".coupling_damping", d.coupling_damping);
  d.force_limit = r.number(t, "force_limit", path + ".force_limit", d.force_limit);
  d.holding_force = r.number(t, "holding_force", path + ".holding_force", d.holding_force);
  d.cut_radius = r.number(t, "cut_radius", path + ".cut_radius", d.cut_radius);
  d.proxy = r.boolean(t, "proxy", path + ".proxy", d.proxy);
  d.tip = r.vec3(t, "tip", path + ".tip", d.tip);
  d.axis = r.vec3(t, "axis", path + ".axis", d.axis);
  const auto keyframes = r.tables(t, "keyframe", path + ".keyframe");
  for (std::size_t i = 0; i < keyframes.size(); ++i) {
    const std::string kp = fmt::format("{}.keyframe[{}]", path, i);
    r.check_keys(*keyframes[i], kp, {"time", "tip", "axis", "grasp", "cut"});
    if (keyframes[i]->get("time") == nullptr) r.fail(keyframes[i], kp + ".time", "a keyframe needs time = <s>");
    InstrumentKeyframe k;
    k.time = r.number(*keyframes[i], "time", kp + ".time", 0.0);
    k.tip = r.vec3(*keyframes[i], "tip", kp + ".tip", i > 0 ? d.keyframes.back().tip : d.tip);
    k.axis = r.vec3(*keyframes[i], "axis", kp + ".axis", i > 0 ? d.keyframes.back().axis : d.axis);
    k.grasp = r.boolean(*keyframes[i], "grasp", kp + ".grasp", i > 0 && d.keyframes.back().grasp);
    k.cut = r.boolean(*keyframes[i], "cut", kp + ".cut", i > 0 && d.keyframes.back().cut);
    d.keyframes.push_back(k);
  }
  return d;
}

SceneDesc read_scene(const Reader& r, const toml::table& root, const std::filesystem::path& file) {
  r.check_keys(root, "",
               {"scene", "world", "solver", "filter", "sleep", "segment", "contact", "environment", "instrument"});
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
    r.check_keys(*t, "world", {"dt", "gravity", "threads", "memory_limit", "mesh_update", "frame_budget"});
    w.dt = r.number(*t, "dt", "world.dt", w.dt);
    w.gravity = r.vec3(*t, "gravity", "world.gravity", w.gravity);
    w.threads = r.integer(*t, "threads", "world.threads", w.threads);
    w.memory_limit = r.number(*t, "memory_limit", "world.memory_limit", w.memory_limit);
    w.mesh_update = r.choice<MeshUpdate>(*t, "mesh_update", "world.mesh_update", w.mesh_update,
                                         {{"on_read", MeshUpdate::on_read}, {"every_frame", MeshUpdate::every_frame}});
    w.frame_budget = r.number(*t, "frame_budget", "world.frame_budget", w.frame_budget);
  }
  if (const toml::table* t = r.table(root, "sleep", "sleep")) {
    r.check_keys(*t, "sleep", {"enabled", "speed", "time", "ranges"});
    w.sleep.enabled = r.boolean(*t, "enabled", "sleep.enabled", w.sleep.enabled);
    w.sleep.speed = r.number(*t, "speed", "sleep.speed", w.sleep.speed);
    w.sleep.time = r.number(*t, "time", "sleep.time", w.sleep.time);
    w.sleep.ranges = r.boolean(*t, "ranges", "sleep.ranges", w.sleep.ranges);
  }
  if (const toml::table* t = r.table(root, "solver", "solver")) {
    r.refuse_removed(*t, "solver",
                     {"prefactor", "attachment_tolerance", "refactor_frames", "max_axial_strain", "max_section_angle",
                      "max_attachment_error"},
                     "removed in decision 0108 (the model's constants now; fast mode's prefactor is gone)");
    r.check_keys(*t, "solver",
                 {"mode", "iterations", "substeps", "relaxation", "tolerance", "max_iterations", "on_instability",
                  "max_substeps", "max_retries", "calm_frames", "max_displacement"});
    SolverDesc& s = w.solver;
    s.mode = r.choice<SolverMode>(
        *t, "mode", "solver.mode", s.mode,
        {{"newton", SolverMode::newton}, {"lagged", SolverMode::lagged}, {"fast", SolverMode::fast}});
    s.iterations = r.integer(*t, "iterations", "solver.iterations", s.iterations);
    s.substeps = r.integer(*t, "substeps", "solver.substeps", s.substeps);
    s.relaxation = r.number(*t, "relaxation", "solver.relaxation", s.relaxation);
    s.tolerance = r.number(*t, "tolerance", "solver.tolerance", s.tolerance);
    s.max_iterations = r.integer(*t, "max_iterations", "solver.max_iterations", s.max_iterations);
    s.on_instability =
        r.choice<InstabilityPolicy>(*t, "on_instability", "solver.on_instability", s.on_instability,
                                    {{"recover", InstabilityPolicy::recover}, {"stop", InstabilityPolicy::stop}});
    s.max_substeps = r.integer(*t, "max_substeps", "solver.max_substeps", s.max_substeps);
    s.max_retries = r.integer(*t, "max_retries", "solver.max_retries", s.max_retries);
    s.calm_frames = r.integer(*t, "calm_frames", "solver.calm_frames", s.calm_frames);
    s.max_displacement = r.number(*t, "max_displacement", "solver.max_displacement", s.max_displacement);
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
    r.check_keys(*t, "contact", {"coefficient", "exponent", "margin", "broad_phase", "self", "rest_exclusions"});
    ContactDesc& c = w.contact;
    c.coefficient = r.number(*t, "coefficient", "contact.coefficient", c.coefficient);
    c.exponent = r.number(*t, "exponent", "contact.exponent", c.exponent);
    c.margin = r.number(*t, "margin", "contact.margin", c.margin);
    c.broad_phase = r.choice<BroadPhase>(
        *t, "broad_phase", "contact.broad_phase", c.broad_phase,
        {{"auto", BroadPhase::automatic}, {"grid", BroadPhase::grid}, {"brute", BroadPhase::brute}});
    c.self = r.boolean(*t, "self", "contact.self", c.self);
    c.rest_exclusions =
        r.choice<RestExclusions>(*t, "rest_exclusions", "contact.rest_exclusions", c.rest_exclusions,
                                 {{"segment", RestExclusions::segment}, {"world", RestExclusions::world}});
  }
  if (const toml::table* t = r.table(root, "environment", "environment"))
    read_environment(r, *t, file.parent_path(), w.environment);
  const auto instruments = r.tables(root, "instrument", "instrument");
  for (std::size_t i = 0; i < instruments.size(); ++i)
    w.instruments.push_back(read_instrument(r, *instruments[i], fmt::format("instrument[{}]", i)));
  return scene;
}

}  // namespace

SceneDesc parse_scene(const std::string& text, const std::filesystem::path& file,
                      std::span<const std::string> overrides) {
  // Bounded before toml++ sees it: its parser and its tables' destructors recurse once per level.
  if (text.size() > io::kMaxSceneBytes)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("{}: {} bytes of scene text, more than the {} MiB a scene file may have", file.string(),
                            text.size(), io::kMaxSceneBytes >> 20));
  io::check_toml_nesting(text, file.string());
  auto source = std::make_shared<SceneSource>();
  source->file = file.string();
  try {
    source->root = toml::parse(text, file.string());
  } catch (const toml::parse_error& e) {
    throw Error(ErrorCode::parse, fmt::format("{}:{}:{}: not valid TOML: {}", file.string(), e.source().begin.line,
                                              e.source().begin.column, e.description()));
  }
  for (const std::string& o : overrides) scene_io::apply_override(source->root, o, file.string());
  const Reader reader(file.string());
  SceneDesc scene = read_scene(reader, source->root, file);
  scene.source = source;
  return scene;
}

SceneDesc load_scene(const std::filesystem::path& file, std::span<const std::string> overrides) {
  // A surface given where a scene belongs would otherwise be answered with a TOML syntax error.
  std::string ext = file.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (std::find(kMeshFormats.begin(), kMeshFormats.end(), ext) != kMeshFormats.end())
    throw Error(ErrorCode::parse, fmt::format("{}: a surface ({}), not a scene file: `haustra import {}` makes a scene "
                                              "of it (`haustra run` and `view` import one on the fly)",
                                              file.string(), ext, file.string()));
  const std::string text = io::read_bounded_file(file, "scene file", io::kMaxSceneBytes);
  // An empty file would read as a scene of no segments that steps: most likely a wrong path or a
  // write that did not finish, so it is refused as a file problem.
  if (text.find_first_not_of(" \t\r\n") == std::string::npos)
    throw Error(ErrorCode::io,
                fmt::format("{}: the scene file is empty (expected TOML with a [[segment]])", file.string()));
  return parse_scene(text, file, overrides);
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
