// The C API (haustra/haustra.h) over the C++ World: handles checked against the live worlds,
// exceptions turned into status codes and a per-thread message, outputs written only on success.
#include "haustra/haustra.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <exception>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <unordered_set>

#include "haustra/centreline.hpp"
#include "haustra/error.hpp"
#include "haustra/frame_publisher.hpp"
#include "haustra/scene.hpp"
#include "haustra/world.hpp"

struct haustra_world {
  std::unique_ptr<haustra::World> world;
  std::unique_ptr<haustra::FramePublisher> frames;  // double-buffered worlds only
};

namespace {

using haustra::Error;
using haustra::ErrorCode;

static_assert(HAUSTRA_STAGE_COUNT == haustra::kStageCount, "haustra.h's stage count follows the engine's");
static_assert(static_cast<int>(ErrorCode::internal) == HAUSTRA_INTERNAL, "codes line up with haustra::ErrorCode");

thread_local std::string g_last_error;

// The live worlds: a handle is looked up here before it is used, so a stale or made-up one is
// refused instead of dereferenced.
std::mutex g_registry_mutex;
std::unordered_set<const haustra_world*>& registry() {
  static std::unordered_set<const haustra_world*> live;
  return live;
}

struct HandleError {
  std::string message;
};

haustra_world& live_handle(haustra_world* w) {
  std::lock_guard lock(g_registry_mutex);
  if (w == nullptr) throw HandleError{"the world handle is NULL"};
  if (registry().count(w) == 0)
    throw HandleError{fmt::format("{} is not a live world (never created, or already destroyed)", fmt::ptr(w))};
  return *w;
}

haustra::World& live(const haustra_world* w) { return *live_handle(const_cast<haustra_world*>(w)).world; }

template <class T>
T& required(T* p, const char* name) {
  if (p == nullptr) throw Error(ErrorCode::invalid_argument, fmt::format("{} is NULL", name));
  return *p;
}

Eigen::Vector3d finite_vec3(const double* v, const char* name) {
  if (v == nullptr) throw Error(ErrorCode::invalid_argument, fmt::format("{} is NULL", name));
  const Eigen::Vector3d out(v[0], v[1], v[2]);
  if (!out.allFinite())
    throw Error(ErrorCode::invalid_argument,
                fmt::format("{} = ({}, {}, {}): expected finite numbers", name, v[0], v[1], v[2]));
  return out;
}

template <class F>
haustra_status guarded(const char* function, F&& body) noexcept {
  try {
    body();
    g_last_error.clear();
    return HAUSTRA_OK;
  } catch (const HandleError& e) {
    g_last_error = fmt::format("{}: {}", function, e.message);
    return HAUSTRA_INVALID_HANDLE;
  } catch (const Error& e) {
    g_last_error = fmt::format("{}: {}", function, e.what());
    return static_cast<haustra_status>(e.code());
  } catch (const std::bad_alloc&) {
    g_last_error = fmt::format("{}: out of memory", function);
    return HAUSTRA_INTERNAL;
  } catch (const std::exception& e) {
    g_last_error = fmt::format("{}: {}", function, e.what());
    return HAUSTRA_INTERNAL;
  } catch (...) {
    g_last_error = fmt::format("{}: an unknown failure", function);
    return HAUSTRA_INTERNAL;
  }
}

haustra_world* make_handle(std::unique_ptr<haustra::World> world, bool double_buffered) {
  auto handle = std::make_unique<haustra_world>();
  handle->world = std::move(world);
  if (double_buffered) handle->frames = std::make_unique<haustra::FramePublisher>(*handle->world);
  std::lock_guard lock(g_registry_mutex);
  registry().insert(handle.get());
  return handle.release();
}

const haustra_world_def& checked_def(const haustra_world_def& d) {
  if (d.struct_size != sizeof(haustra_world_def))
    throw Error(ErrorCode::invalid_argument,
                fmt::format("def.struct_size = {}: expected {} (fill it with haustra_world_def_default first; a "
                            "different size means a header of another haustra version)",
                            d.struct_size, sizeof(haustra_world_def)));
  if (d.newton < 0 || d.newton > 2)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("def.newton = {}: expected 0 (lagged), 1 (Newton) or 2 (fast)", d.newton));
  return d;
}

// The run-time settings: threads, or the host's job system; the memory the world may take.
void apply_runtime(const haustra_world_def& d, haustra::WorldDesc& w) {
  if (d.threads < 0 || d.threads > 1024)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("def.threads = {}: expected 0 (all cores) to 1024", d.threads));
  w.threads = d.threads;
  if (d.memory_limit != 0.0) w.memory_limit = d.memory_limit;
  if (d.mesh_every_frame < 0 || d.mesh_every_frame > 1)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("def.mesh_every_frame = {}: expected 0 (when read) or 1 (every step)", d.mesh_every_frame));
  if (d.mesh_every_frame == 1) w.mesh_update = haustra::MeshUpdate::every_frame;
  if (d.frame_budget != 0.0) w.frame_budget = d.frame_budget;  // checked with the rest of the description
  if ((d.jobs.enqueue == nullptr) != (d.jobs.wait == nullptr))
    throw Error(ErrorCode::invalid_argument, "def.jobs: enqueue and wait are both needed (or neither, for oneTBB)");
  if (d.jobs.enqueue != nullptr) {
    if (d.jobs.workers < 1 || d.jobs.workers > 1024)
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("def.jobs.workers = {}: expected 1 to 1024", d.jobs.workers));
    w.jobs = {d.jobs.enqueue, d.jobs.wait, d.jobs.host, d.jobs.workers};
  }
}

haustra::SegmentDesc segment_desc(const haustra_segment_def& d, std::size_t i) {
  const std::string where = fmt::format("segments[{}]", i);
  if (d.struct_size != sizeof(haustra_segment_def))
    throw Error(ErrorCode::invalid_argument,
                fmt::format("{}.struct_size = {}: expected {} (fill it with haustra_segment_def_default first)", where,
                            d.struct_size, sizeof(haustra_segment_def)));
  haustra::SegmentDesc s;
  s.name = d.name != nullptr ? std::string(d.name) : fmt::format("segment{}", i);
  s.nodes = d.nodes;
  if (d.centreline != nullptr || d.centreline_points > 0) {
    if (d.centreline == nullptr) throw Error(ErrorCode::invalid_argument, where + ".centreline is NULL");
    if (d.centreline_points > 10'000'000)
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("{}.centreline_points = {}: too many", where, d.centreline_points));
    s.rest.kind = haustra::RestShapeKind::centreline;
    for (size_t k = 0; k < d.centreline_points; ++k)
      s.rest.centreline.emplace_back(d.centreline[3 * k], d.centreline[3 * k + 1], d.centreline[3 * k + 2]);
    s.rest.centreline_source = where + ".centreline";
    haustra::check_centreline_points(s.rest.centreline, where + ".centreline");
  } else {
    s.rest.length = d.length;
    s.base_position = finite_vec3(d.base_position, (where + ".base_position").c_str());
    s.base_tangent = finite_vec3(d.base_tangent, (where + ".base_tangent").c_str());
  }
  s.base = d.free_base != 0 ? haustra::BaseMode::free : haustra::BaseMode::clamped;
  if (d.drag >= 0.0) s.drag = d.drag;
  s.cross_section.radius = d.radius;
  s.cross_section.wall_thickness = d.wall_thickness;
  s.material.youngs_modulus = d.youngs_modulus;
  s.material.density = d.density;
  if (d.beads < 0)
    throw Error(ErrorCode::invalid_argument, fmt::format("{}.beads = {}: expected 0 or more", where, d.beads));
  if (d.beads > 0) {
    s.beads.enabled = true;
    s.beads.count = d.beads;
    s.beads.radius = d.bead_radius;
  }
  switch (d.mesh) {
    case 0: break;
    case 1:
      s.mesh.enabled = true;
      s.mesh.source = haustra::MeshSource::procedural;
      s.mesh.procedural.vertices = d.mesh_vertices;
      break;
    case 2:
      if (d.mesh_file == nullptr) throw Error(ErrorCode::invalid_argument, where + ".mesh = 2 needs mesh_file");
      s.mesh.enabled = true;
      s.mesh.source = haustra::MeshSource::file;
      s.mesh.file = d.mesh_file;
      s.mesh.scale = d.mesh_scale;
      break;
    default:
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("{}.mesh = {}: expected 0 (none), 1 (procedural) or 2 (mesh_file)", where, d.mesh));
  }
  s.mesh.rings_per_vertex = d.rings_per_vertex;
  s.mesh.max_rings_per_vertex = d.max_rings_per_vertex;
  s.mesh.mean_rings_per_vertex = d.mean_rings_per_vertex;
  s.mesh.weight_left_out = d.weight_left_out;
  s.mesh.skin_cost_limit = d.skin_cost_limit;
  s.chain_pieces = d.chain_pieces;
  switch (d.tissue) {
    case 0: s.material.response = haustra::TissueResponse::hooke; break;
    case 1: s.material.response = haustra::TissueResponse::exp2; break;
    default:
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("{}.tissue = {}: expected 0 (Hooke) or 1 (EXP2)", where, d.tissue));
  }
  s.material.exp2_alpha = d.exp2_alpha;
  s.material.exp2_beta = d.exp2_beta;
  s.material.exp2_gamma = d.exp2_gamma;
  if (d.anchor_stiffness != 0.0 || d.anchor_support != 0.0) {  // checked as the scene's fields
    haustra::AnchorsDesc a;
    a.stiffness = d.anchor_stiffness;
    a.support = d.anchor_support;
    a.damping = d.anchor_damping;
    a.slack = d.anchor_slack;
    a.strength = d.anchor_strength;
    s.anchors.push_back(a);
  }
  return s;
}

void copy3(const Eigen::Vector3d& v, double out[3]) {
  for (int i = 0; i < 3; ++i) out[i] = v[i];
}

}  // namespace

extern "C" {

const char* haustra_version(void) { return HAUSTRA_VERSION; }

haustra_status haustra_check_abi(int abi_version) {
  return guarded("haustra_check_abi",
                 [&] {
                   if (abi_version != HAUSTRA_ABI_VERSION)
                     throw Error(ErrorCode::invalid_argument,
                                 fmt::format("the host was built against ABI {}, this library is ABI {} (haustra {})",
                                             abi_version, HAUSTRA_ABI_VERSION, HAUSTRA_VERSION));
                 }) == HAUSTRA_OK
             ? HAUSTRA_OK
             : HAUSTRA_ABI_MISMATCH;
}

const char* haustra_last_error(void) { return g_last_error.c_str(); }

const char* haustra_stage_name(int stage) {
  if (stage < 0 || stage >= HAUSTRA_STAGE_COUNT) return nullptr;
  return haustra::stage_name(static_cast<haustra::Stage>(stage)).data();
}

haustra_status haustra_world_create_from_scene(const char* scene_path, int threads, haustra_world** out) {
  return guarded("haustra_world_create_from_scene", [&] {
    required(out, "out");
    if (scene_path == nullptr) throw Error(ErrorCode::invalid_argument, "scene_path is NULL");
    if (threads < 0 || threads > 1024)
      throw Error(ErrorCode::invalid_argument, fmt::format("threads = {}: expected 0 (all cores) to 1024", threads));
    haustra::SceneDesc scene = haustra::load_scene(scene_path);
    scene.world.threads = threads;
    *out = make_handle(haustra::create_world(scene), false);
  });
}

haustra_status haustra_world_create_from_scene_def(const char* scene_path, const haustra_world_def* def,
                                                   haustra_world** out) {
  return guarded("haustra_world_create_from_scene_def", [&] {
    required(out, "out");
    if (scene_path == nullptr) throw Error(ErrorCode::invalid_argument, "scene_path is NULL");
    haustra_world_def defaults;
    haustra_world_def_default(&defaults);
    const haustra_world_def& d = def != nullptr ? checked_def(*def) : defaults;
    haustra::SceneDesc scene = haustra::load_scene(scene_path);
    apply_runtime(d, scene.world);
    *out = make_handle(haustra::create_world(scene), d.double_buffered != 0);
  });
}

haustra_status haustra_world_def_default(haustra_world_def* def) {
  return guarded("haustra_world_def_default", [&] {
    haustra_world_def& d = required(def, "def");
    const haustra::WorldDesc w;
    d = haustra_world_def{};
    d.struct_size = sizeof(haustra_world_def);
    d.dt = w.dt;
    for (int i = 0; i < 3; ++i) d.gravity[i] = w.gravity[i];
    d.threads = 0;
    d.jobs.workers = 2;
    d.newton = w.solver.mode == haustra::SolverMode::lagged ? 0 : (w.solver.mode == haustra::SolverMode::fast ? 2 : 1);
    d.iterations = w.solver.iterations;
    d.substeps = w.solver.substeps;
    d.recover = w.solver.on_instability == haustra::InstabilityPolicy::recover ? 1 : 0;
    d.self_contact = w.contact.self ? 1 : 0;
  });
}

haustra_status haustra_segment_def_default(haustra_segment_def* def) {
  return guarded("haustra_segment_def_default", [&] {
    haustra_segment_def& d = required(def, "def");
    const haustra::SegmentDesc s;
    d = haustra_segment_def{};
    d.struct_size = sizeof(haustra_segment_def);
    d.nodes = s.nodes;
    d.length = s.rest.length;
    for (int i = 0; i < 3; ++i) {
      d.base_position[i] = s.base_position[i];
      d.base_tangent[i] = s.base_tangent[i];
    }
    d.drag = -1.0;
    d.radius = s.cross_section.radius;
    d.wall_thickness = s.cross_section.wall_thickness;
    d.youngs_modulus = s.material.youngs_modulus;
    d.density = s.material.density;
    d.mesh_vertices = s.mesh.procedural.vertices;
    d.mesh_scale = 1.0;
    d.rings_per_vertex = s.mesh.rings_per_vertex;
    d.max_rings_per_vertex = s.mesh.max_rings_per_vertex;
    d.mean_rings_per_vertex = s.mesh.mean_rings_per_vertex;
    d.weight_left_out = s.mesh.weight_left_out;
    d.skin_cost_limit = s.mesh.skin_cost_limit;
    d.chain_pieces = s.chain_pieces;
    d.exp2_alpha = s.material.exp2_alpha;
    d.exp2_beta = s.material.exp2_beta;
    d.exp2_gamma = s.material.exp2_gamma;
    const haustra::AnchorsDesc a;
    d.anchor_damping = a.damping;
    d.anchor_slack = a.slack;
    d.anchor_strength = a.strength;
  });
}

haustra_status haustra_world_create(const haustra_world_def* def, const haustra_segment_def* segments,
                                    size_t segment_count, haustra_world** out) {
  return guarded("haustra_world_create", [&] {
    required(out, "out");
    const haustra_world_def& d = checked_def(required(def, "def"));
    if (segments == nullptr && segment_count > 0) throw Error(ErrorCode::invalid_argument, "segments is NULL");
    if (segment_count > 100'000)
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("segment_count = {}: expected at most 100,000", segment_count));
    haustra::WorldDesc w;
    w.dt = d.dt;
    w.gravity = Eigen::Vector3d(d.gravity[0], d.gravity[1], d.gravity[2]);
    w.solver.mode = d.newton == 0   ? haustra::SolverMode::lagged
                    : d.newton == 2 ? haustra::SolverMode::fast
                                    : haustra::SolverMode::newton;
    w.solver.iterations = d.iterations;
    w.solver.substeps = d.substeps;
    w.solver.on_instability = d.recover != 0 ? haustra::InstabilityPolicy::recover : haustra::InstabilityPolicy::stop;
    w.contact.self = d.self_contact != 0;
    if (d.floor != 0) {
      haustra::PlaneDesc floor;
      floor.name = "floor";
      floor.point = Eigen::Vector3d(0.0, 0.0, d.floor_height);
      w.environment.planes.push_back(floor);
    }
    apply_runtime(d, w);
    for (size_t i = 0; i < segment_count; ++i) w.segments.push_back(segment_desc(segments[i], i));
    *out = make_handle(haustra::World::create(w), d.double_buffered != 0);
  });
}

haustra_status haustra_world_destroy(haustra_world* world) {
  return guarded("haustra_world_destroy", [&] {
    {
      std::lock_guard lock(g_registry_mutex);
      if (world == nullptr) throw HandleError{"the world handle is NULL"};
      if (registry().erase(world) == 0)
        throw HandleError{fmt::format("{} is not a live world (never created, or already destroyed)", fmt::ptr(world))};
    }
    delete world;
  });
}

haustra_status haustra_world_step(haustra_world* world) {
  return guarded("haustra_world_step", [&] {
    haustra_world& h = live_handle(world);
    h.world->step();
    if (h.frames) h.frames->publish(*h.world);
  });
}

haustra_status haustra_world_counts(const haustra_world* world, haustra_counts* out) {
  return guarded("haustra_world_counts", [&] {
    const haustra::World& w = live(world);
    haustra_counts& o = required(out, "out");
    o = haustra_counts{w.segment_count(),    w.node_count(),       w.bead_count(),
                       w.instrument_count(), w.mesh_buffer_size(), w.mesh_triangles().size()};
  });
}

haustra_status haustra_world_time(const haustra_world* world, double* seconds, uint64_t* frame) {
  return guarded("haustra_world_time", [&] {
    const haustra::World& w = live(world);
    if (seconds == nullptr && frame == nullptr)
      throw Error(ErrorCode::invalid_argument, "seconds and frame are both NULL");
    if (seconds != nullptr) *seconds = w.time();
    if (frame != nullptr) *frame = w.frame();
  });
}

haustra_status haustra_world_segment(const haustra_world* world, size_t segment, haustra_segment_info* out) {
  return guarded("haustra_world_segment", [&] {
    const haustra::World& w = live(world);
    haustra_segment_info& o = required(out, "out");
    const haustra::SegmentInfo& info = w.segment(segment);
    const haustra::Range beads = w.beads(segment);
    const haustra::MeshInfo& mesh = w.mesh(segment);
    o = haustra_segment_info{info.name.c_str(),
                             info.nodes.offset,
                             info.nodes.count,
                             beads.offset,
                             beads.count,
                             mesh.enabled ? mesh.vertices.offset : 0,
                             mesh.enabled ? mesh.vertices.count : 0,
                             w.chain_of(segment),
                             info.length};
  });
}

haustra_status haustra_world_add_segment(haustra_world* world, const haustra_segment_def* segment, size_t* index) {
  return guarded("haustra_world_add_segment", [&] {
    haustra_world& h = live_handle(world);
    const haustra::SegmentDesc desc = segment_desc(required(segment, "segment"), h.world->segment_count());
    std::size_t added = 0;
    auto change = [&]() -> const haustra::World& {
      added = h.world->add_segment(desc);
      return *h.world;
    };
    if (h.frames)
      h.frames->resize(change);
    else
      change();
    if (index != nullptr) *index = added;
  });
}

haustra_status haustra_world_remove_segment(haustra_world* world, size_t segment) {
  return guarded("haustra_world_remove_segment", [&] {
    haustra_world& h = live_handle(world);
    auto change = [&]() -> const haustra::World& {
      h.world->remove_segment(segment);
      return *h.world;
    };
    if (h.frames)
      h.frames->resize(change);
    else
      change();
  });
}

haustra_status haustra_world_node_positions(const haustra_world* world, haustra_vec3_view* out) {
  return guarded("haustra_world_node_positions", [&] {
    const haustra::World& w = live(world);
    const auto p = w.node_positions();
    required(out, "out") = haustra_vec3_view{p.x.data(), p.y.data(), p.z.data(), w.node_count()};
  });
}

haustra_status haustra_world_bead_radii(const haustra_world* world, const double** radii, size_t* count) {
  return guarded("haustra_world_bead_radii", [&] {
    const haustra::World& w = live(world);
    required(radii, "radii");
    required(count, "count");
    *radii = w.bead_radii().data();
    *count = w.bead_radii().size();
  });
}

haustra_status haustra_world_mesh_positions(const haustra_world* world, haustra_vec3f_view* out) {
  return guarded("haustra_world_mesh_positions", [&] {
    const haustra::World& w = live(world);
    const auto p = w.mesh_positions();
    required(out, "out") = haustra_vec3f_view{p.x.data(), p.y.data(), p.z.data(), w.mesh_buffer_size()};
  });
}

haustra_status haustra_world_mesh_normals(const haustra_world* world, haustra_vec3f_view* out) {
  return guarded("haustra_world_mesh_normals", [&] {
    const haustra::World& w = live(world);
    const auto n = w.mesh_normals();
    required(out, "out") = haustra_vec3f_view{n.x.data(), n.y.data(), n.z.data(), w.mesh_buffer_size()};
  });
}

haustra_status haustra_world_mesh_triangles(const haustra_world* world, haustra_triangles_view* out) {
  return guarded("haustra_world_mesh_triangles", [&] {
    const haustra::World& w = live(world);
    const auto t = w.mesh_triangles();
    required(out, "out") = haustra_triangles_view{t.empty() ? nullptr : t.front().data(), t.size()};
  });
}

haustra_status haustra_world_set_node_load(haustra_world* world, size_t node, const double force[3],
                                           const double moment[3]) {
  return guarded("haustra_world_set_node_load", [&] {
    haustra::World& w = live(world);
    const Eigen::Vector3d f = finite_vec3(force, "force");
    const Eigen::Vector3d m = finite_vec3(moment, "moment");
    w.set_external_load(node, f, m);  // checks the node
  });
}

haustra_status haustra_world_set_distributed_load(haustra_world* world, size_t segment, size_t count,
                                                  const double* force_per_length, const double* moment_per_length,
                                                  int add) {
  return guarded("haustra_world_set_distributed_load", [&] {
    haustra::World& w = live(world);
    const std::span<const double> forces(&required(force_per_length, "force_per_length"), 3 * count);
    const std::span<const double> moments =
        moment_per_length == nullptr ? std::span<const double>() : std::span<const double>(moment_per_length, 3 * count);
    w.set_distributed_load(segment, forces, moments, add != 0);  // checks the segment, the count and the values
  });
}

haustra_status haustra_world_set_instrument_pose(haustra_world* world, size_t instrument, const double tip[3],
                                                 const double axis[3]) {
  return guarded("haustra_world_set_instrument_pose", [&] {
    haustra::World& w = live(world);
    w.set_instrument_pose(instrument, finite_vec3(tip, "tip"), finite_vec3(axis, "axis"));
  });
}

haustra_status haustra_world_set_instrument_grasp(haustra_world* world, size_t instrument, int closed) {
  return guarded("haustra_world_set_instrument_grasp",
                 [&] { live(world).set_instrument_grasp(instrument, closed != 0); });
}

haustra_status haustra_world_instrument(const haustra_world* world, size_t instrument,
                                        haustra_instrument_reading* out) {
  return guarded("haustra_world_instrument", [&] {
    const haustra::InstrumentReading r = live(world).instrument(instrument);
    haustra_instrument_reading o{};
    copy3(r.tip, o.tip);
    copy3(r.force, o.force);
    copy3(r.torque, o.torque);
    copy3(r.filtered_force, o.filtered_force);
    o.closed = r.closed ? 1 : 0;
    o.grasping = r.grasping ? 1 : 0;
    o.slipped = r.slipped ? 1 : 0;
    o.grasped_segment = r.grasped_segment;
    o.grasped_node = r.grasped_node;
    copy3(r.commanded_tip, o.commanded_tip);
    o.cutting = r.cutting ? 1 : 0;
    required(out, "out") = o;
  });
}

haustra_status haustra_world_set_instrument_cutting(haustra_world* world, size_t instrument, int cutting) {
  return guarded("haustra_world_set_instrument_cutting",
                 [&] { live(world).set_instrument_cutting(instrument, cutting != 0); });
}

haustra_status haustra_world_anchors(const haustra_world* world, const uint32_t** nodes, const uint8_t** intact,
                                     size_t* count) {
  return guarded("haustra_world_anchors", [&] {
    const haustra::World& w = live(world);
    required(nodes, "nodes") = w.anchor_nodes().data();
    required(intact, "intact") = w.anchors_intact().data();
    required(count, "count") = w.anchor_count();
  });
}

haustra_status haustra_world_anchor_tensions(const haustra_world* world, double* out, size_t count) {
  return guarded("haustra_world_anchor_tensions", [&] {
    if (out == nullptr && count > 0) throw Error(ErrorCode::invalid_argument, "out is NULL");
    live(world).anchor_tensions(std::span<double>(out, count));
  });
}

haustra_status haustra_world_cut_tissue(haustra_world* world, const double centre[3], double radius, size_t* cut) {
  return guarded("haustra_world_cut_tissue", [&] {
    const std::size_t n = live(world).cut_tissue(finite_vec3(centre, "centre"), radius);
    if (cut != nullptr) *cut = n;
  });
}

haustra_status haustra_world_profile(const haustra_world* world, haustra_profile* out) {
  return guarded("haustra_world_profile", [&] {
    const haustra::FrameProfile& p = live(world).last_profile();
    haustra_profile o{};
    for (std::size_t s = 0; s < haustra::kStageCount; ++s) o.stage_seconds[s] = p.seconds[s];
    o.frame_seconds = p.frame_seconds;
    o.newton = p.newton ? 1 : 0;
#define HAUSTRA_COPY_FIELD(type, name, initial, meaning) o.name = p.name;
    HAUSTRA_PROFILE_COUNTERS(HAUSTRA_COPY_FIELD)
#undef HAUSTRA_COPY_FIELD
    required(out, "out") = o;
  });
}

haustra_status haustra_world_set_frame_budget(haustra_world* world, double seconds) {
  return guarded("haustra_world_set_frame_budget", [&] { live_handle(world).world->set_frame_budget(seconds); });
}

haustra_status haustra_world_late_frames(const haustra_world* world, uint64_t* count) {
  return guarded("haustra_world_late_frames", [&] { required(count, "count") = live(world).late_frames(); });
}

haustra_status haustra_world_set_gravity(haustra_world* world, const double gravity[3]) {
  return guarded("haustra_world_set_gravity",
                 [&] { live_handle(world).world->set_gravity(finite_vec3(gravity, "gravity")); });
}

haustra_status haustra_world_gravity(const haustra_world* world, double gravity[3]) {
  return guarded("haustra_world_gravity", [&] {
    double* out = &required(gravity, "gravity");
    const Eigen::Vector3d g = live(world).gravity();
    for (int i = 0; i < 3; ++i) out[i] = g[i];
  });
}

haustra_status haustra_world_set_dt(haustra_world* world, double dt) {
  return guarded("haustra_world_set_dt", [&] { live_handle(world).world->set_dt(dt); });
}

haustra_status haustra_world_dt(const haustra_world* world, double* dt) {
  return guarded("haustra_world_dt", [&] { required(dt, "dt") = live(world).dt(); });
}

haustra_status haustra_world_set_instrument_coupling(haustra_world* world, size_t instrument, double stiffness,
                                                     double damping, double force_limit) {
  return guarded("haustra_world_set_instrument_coupling", [&] {
    live_handle(world).world->set_instrument_coupling(instrument, stiffness, damping, force_limit);
  });
}

haustra_status haustra_world_material(const haustra_world* world, size_t segment, haustra_material* out) {
  return guarded("haustra_world_material", [&] {
    const haustra::SegmentDesc& d = live(world).segment_desc(segment);
    required(out, "out") =
        haustra_material{d.material.youngs_modulus, d.material.poisson_ratio, d.material.density, d.relaxation_time};
  });
}

haustra_status haustra_world_set_material(haustra_world* world, size_t segment, const haustra_material* material) {
  return guarded("haustra_world_set_material", [&] {
    haustra_world& h = live_handle(world);
    const haustra_material& m = required(material, "material");
    haustra::MaterialDesc next = h.world->segment_desc(segment).material;
    next.youngs_modulus = m.youngs_modulus;
    next.poisson_ratio = m.poisson_ratio;
    next.density = m.density;
    auto change = [&]() -> const haustra::World& {
      h.world->set_material(segment, next, m.relaxation_time);
      return *h.world;
    };
    if (h.frames)
      h.frames->resize(change);
    else
      change();
  });
}

haustra_status haustra_world_acquire_frame(haustra_world* world, haustra_frame* out) {
  return guarded("haustra_world_acquire_frame", [&] {
    haustra_world& h = live_handle(world);
    haustra_frame& o = required(out, "out");
    if (!h.frames)
      throw Error(ErrorCode::invalid_argument,
                  "this world was not created with double_buffered = 1 (haustra_world_def)");
    const haustra::FramePublisher::Slot& s = h.frames->acquire();
    o = haustra_frame{s.frame,
                      s.time,
                      {s.x.data(), s.y.data(), s.z.data(), s.x.size()},
                      {s.px.data(), s.py.data(), s.pz.data(), s.px.size()},
                      {s.nx.data(), s.ny.data(), s.nz.data(), s.nx.size()}};
  });
}

haustra_status haustra_world_release_frame(haustra_world* world) {
  return guarded("haustra_world_release_frame", [&] {
    haustra_world& h = live_handle(world);
    if (!h.frames)
      throw Error(ErrorCode::invalid_argument,
                  "this world was not created with double_buffered = 1 (haustra_world_def)");
    h.frames->release();
  });
}

haustra_status haustra_world_save_checkpoint(const haustra_world* world, const char* path) {
  return guarded("haustra_world_save_checkpoint", [&] {
    const haustra::World& w = live(world);
    if (path == nullptr) throw Error(ErrorCode::invalid_argument, "path is NULL");
    w.save_checkpoint_file(path);
  });
}

haustra_status haustra_world_restore_checkpoint(haustra_world* world, const char* path) {
  return guarded("haustra_world_restore_checkpoint", [&] {
    haustra_world& h = live_handle(world);
    if (path == nullptr) throw Error(ErrorCode::invalid_argument, "path is NULL");
    h.world->restore_checkpoint_file(path);
    if (h.frames) h.frames->publish(*h.world);
  });
}

}  // extern "C"
