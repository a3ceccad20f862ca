// The C API (haustra/haustra.h) over the C++ World: handles checked against the live worlds,
// exceptions turned into status codes and a per-thread message, outputs written only on success.
#include "haustra/haustra.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <exception>
#include <memory>
#include <mutex>
#include <new>
#include <span>
#include <string>
#include <type_traits>
#include <unordered_set>

#include "haustra/centreline.hpp"
#include "haustra/error.hpp"
#include "haustra/frame_publisher.hpp"
#include "haustra/mesh_io.hpp"
#include "haustra/scene.hpp"
#include "haustra/world.hpp"

struct haustra_world {
  std::unique_ptr<haustra::World> world;
  std::unique_ptr<haustra::FramePublisher> frames;  // double-buffered worlds only
  // haustra_world_gpu_skin last handed out the along-rod screws (ABI 17's form): a ring data count of
  // the rings' rows alone would leave the host's shader reading past its buffer, so it is refused.
  mutable std::atomic<bool> gave_screws{false};
};

namespace {

using haustra::Error;
using haustra::ErrorCode;

static_assert(HAUSTRA_STAGE_COUNT == haustra::kStageCount, "haustra.h's stage count follows the engine's");
static_assert(static_cast<int>(ErrorCode::internal) == HAUSTRA_INTERNAL, "codes line up with haustra::ErrorCode");
static_assert(static_cast<int>(ErrorCode::busy) == HAUSTRA_BUSY, "codes line up with haustra::ErrorCode");
static_assert(sizeof(haustra_event::message) == sizeof(haustra::Event::text), "an event's text fits whole");
static_assert(static_cast<int>(haustra::Event::Kind::cut) == HAUSTRA_EVENT_CUT, "event kinds line up");
static_assert(static_cast<int>(haustra::ContactKind::instrument) == HAUSTRA_CONTACT_INSTRUMENT,
              "contact kinds line up");
static_assert(static_cast<int>(haustra::ObstacleKind::mesh) == HAUSTRA_OBSTACLE_MESH, "obstacle kinds line up");

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

// A handle in the registry (the caller holds the registry's lock), or HandleError.
haustra_world& registered(const haustra_world* w) {
  if (w == nullptr) throw HandleError{"the world handle is NULL"};
  if (registry().count(w) == 0)
    throw HandleError{fmt::format("{} is not a live world (never created, or already destroyed)", fmt::ptr(w))};
  return *const_cast<haustra_world*>(w);
}

// A live world held by this thread for one call (decision 0100): looked up and taken under the
// registry's lock, so that destroy cannot free it in between, and refused (Error{busy}) while
// another thread is inside a call on it. The World's own calls nest in the hold for free.
class Held {
 public:
  explicit Held(const haustra_world* w)
      : lock_(g_registry_mutex), handle_(registered(w)), use_(*handle_.world, std::string_view()) {
    lock_.unlock();
  }
  [[nodiscard]] haustra_world& handle() const { return handle_; }
  [[nodiscard]] haustra::World& world() const { return *handle_.world; }

 private:
  std::unique_lock<std::mutex> lock_;
  haustra_world& handle_;
  haustra::World::Use use_;
};

// A double-buffered world's render thread: its handle checked, the world not held (it runs beside
// the stepping thread; the frame publisher keeps the two apart).
haustra_world& frame_reader(haustra_world* w) {
  std::lock_guard lock(g_registry_mutex);
  return registered(w);
}

// For one expression: `live(world).world().step()` holds the world until the end of the statement.
Held live(const haustra_world* w) { return Held(w); }

// 0 or 1 for a C flag; anything else is refused rather than read as true.
bool flag(int value, const std::string& name) {
  if (value != 0 && value != 1)
    throw Error(ErrorCode::invalid_argument, fmt::format("{} = {}: expected 0 or 1", name, value));
  return value == 1;
}

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

// The sizes a struct has had since it carried its size: its own, and for the two defs the sizes
// before ABI 13 (frame limits), ABI 15 (mesh_on_host_gpu), ABI 17 (sleep), ABI 11 / 12 / 16 (the
// ring fields, the anchors, the skin) added fields at their end; the frame's before ABI 15 (gpu_rings); the profile's
// before ABI 16 (nodes_asleep); the GPU skin's before ABI 17 (ring_data_floats).
template <class T>
std::span<const std::size_t> sizes_of() {
  if constexpr (std::is_same_v<T, haustra_world_def>) {
    static constexpr std::size_t sizes[] = {offsetof(haustra_world_def, max_substeps),
                                            offsetof(haustra_world_def, mesh_on_host_gpu),
                                            offsetof(haustra_world_def, sleep), sizeof(T)};
    return sizes;
  } else if constexpr (std::is_same_v<T, haustra_segment_def>) {
    static constexpr std::size_t sizes[] = {offsetof(haustra_segment_def, max_rings_per_vertex),
                                            offsetof(haustra_segment_def, anchor_stiffness),
                                            offsetof(haustra_segment_def, skinning), sizeof(T)};
    return sizes;
  } else if constexpr (std::is_same_v<T, haustra_profile>) {
    static constexpr std::size_t sizes[] = {offsetof(haustra_profile, nodes_asleep), sizeof(T)};
    return sizes;
  } else if constexpr (std::is_same_v<T, haustra_gpu_skin>) {
    static constexpr std::size_t sizes[] = {offsetof(haustra_gpu_skin, ring_data_floats), sizeof(T)};
    return sizes;
  } else if constexpr (std::is_same_v<T, haustra_frame>) {
    static constexpr std::size_t sizes[] = {offsetof(haustra_frame, gpu_rings), sizeof(T)};
    return sizes;
  } else {
    static constexpr std::size_t sizes[] = {sizeof(T)};
    return sizes;
  }
}

// A struct_size the library knows, or an error naming it.
template <class T>
std::size_t known_size(std::size_t size, const std::string& name) {
  for (std::size_t k : sizes_of<T>())
    if (size == k) return size;
  throw Error(
      ErrorCode::invalid_argument,
      fmt::format(
          "{}.struct_size = {}: expected sizeof the struct, {} in this library's header{} (set it — a "
          "def by its _default() function, an output as `= {{.struct_size = sizeof x}}` — since ABI 14; a larger "
          "size is a newer header's than the library's, ABI {})",
          name, size, sizeof(T),
          sizes_of<T>().size() > 1 ? fmt::format(", or an older header's: {}",
                                                 fmt::join(sizes_of<T>().first(sizes_of<T>().size() - 1), ", "))
                                   : "",
          HAUSTRA_ABI_VERSION));
}

// A def as the library reads it: the host's bytes as far as its struct_size goes, over `defaults`.
template <class T>
T read_def(const T& host, const T& defaults, const std::string& name) {
  const std::size_t n = known_size<T>(host.struct_size, name);
  T out = defaults;
  std::memcpy(static_cast<void*>(&out), &host, n);
  out.struct_size = sizeof(T);
  return out;
}

// An output written as far as the host's struct_size goes.
template <class T>
void write_out(T* out, T value, const char* name) {
  if (out == nullptr) throw Error(ErrorCode::invalid_argument, fmt::format("{} is NULL", name));
  std::size_t size = 0;
  std::memcpy(&size, out, sizeof size);  // struct_size leads every struct
  const std::size_t n = known_size<T>(size, name);
  value.struct_size = n;
  std::memcpy(static_cast<void*>(out), &value, n);
}

// An array of outputs: its first element's struct_size is the stride; or 0 with no room.
template <class T>
std::size_t stride_of(const T* out, std::size_t capacity, const char* name) {
  if (capacity == 0) return 0;
  if (out == nullptr) throw Error(ErrorCode::invalid_argument, fmt::format("{} is NULL", name));
  std::size_t size = 0;
  std::memcpy(&size, out, sizeof size);
  return known_size<T>(size, fmt::format("{}[0]", name));
}

template <class T>
void write_at(T* out, std::size_t stride, std::size_t i, T value) {
  value.struct_size = stride;
  std::memcpy(reinterpret_cast<unsigned char*>(out) + i * stride, &value, stride);
}

// The exception in flight as a status, its message kept for haustra_last_error. Called only from a
// C function's catch (...), so every entry point reads as its body in one try block with no wrapper
// call between the host and the engine.
haustra_status failed(const char* function) noexcept {
  try {
    throw;
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

haustra_status succeeded() noexcept {
  g_last_error.clear();
  return HAUSTRA_OK;
}

haustra_world* make_handle(std::unique_ptr<haustra::World> world, bool double_buffered, bool gpu = false) {
  auto handle = std::make_unique<haustra_world>();
  handle->world = std::move(world);
  if (double_buffered) handle->frames = std::make_unique<haustra::FramePublisher>(*handle->world);
  if (double_buffered && gpu) handle->frames->skin_on_gpu(true);  // the render thread's acquire skins nothing
  std::lock_guard lock(g_registry_mutex);
  registry().insert(handle.get());
  return handle.release();
}

haustra_world_def world_defaults() {
  haustra_world_def d{};
  haustra_world_def_default(&d);
  return d;
}

haustra_world_def checked_def(const haustra_world_def& host) {
  const haustra_world_def d = read_def(host, world_defaults(), "def");
  if (d.newton < 0 || d.newton > 2)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("def.newton = {}: expected 0 (lagged), 1 (Newton) or 2 (fast)", d.newton));
  (void)flag(d.recover, "def.recover"), (void)flag(d.floor, "def.floor"),
      (void)flag(d.self_contact, "def.self_contact");
  if (flag(d.mesh_on_host_gpu, "def.mesh_on_host_gpu") && d.mesh_every_frame == 1)
    throw Error(ErrorCode::invalid_argument,
                "def.mesh_on_host_gpu = 1 with def.mesh_every_frame = 1: a host that skins on its GPU wants the "
                "step not to skin; set mesh_every_frame = 0");
  (void)flag(d.double_buffered, "def.double_buffered");
  if (d.sleep < 0 || d.sleep > 2)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("def.sleep = {}: expected 0 (off), 1 (rods) or 2 (rods and ranges within them)", d.sleep));
  return d;
}

// The world's fields of a def (checked with the rest of the description): every one, for a world
// from definitions; or over a scene's values, those changed from haustra_world_def_default's, so a
// field is honoured whenever a host set it and a scene's value kept otherwise.
void apply_world_fields(const haustra_world_def& d, bool only_changed, haustra::WorldDesc& w) {
  haustra_world_def base{};
  haustra_world_def_default(&base);
  auto changed = [&](const auto& mine, const auto& theirs) {
    return !only_changed || std::memcmp(&mine, &theirs, sizeof mine) != 0;
  };
  if (changed(d.dt, base.dt)) w.dt = d.dt;
  if (changed(d.gravity, base.gravity)) w.gravity = Eigen::Vector3d(d.gravity[0], d.gravity[1], d.gravity[2]);
  if (changed(d.newton, base.newton))
    w.solver.mode = d.newton == 0   ? haustra::SolverMode::lagged
                    : d.newton == 2 ? haustra::SolverMode::fast
                                    : haustra::SolverMode::newton;
  if (changed(d.iterations, base.iterations)) w.solver.iterations = d.iterations;
  if (changed(d.substeps, base.substeps)) w.solver.substeps = d.substeps;
  if (changed(d.recover, base.recover))
    w.solver.on_instability = d.recover == 1 ? haustra::InstabilityPolicy::recover : haustra::InstabilityPolicy::stop;
  if (changed(d.self_contact, base.self_contact)) w.contact.self = d.self_contact == 1;
  if (changed(d.max_substeps, base.max_substeps)) w.solver.max_substeps = d.max_substeps;
  if (changed(d.max_retries, base.max_retries)) w.solver.max_retries = d.max_retries;
  if (changed(d.calm_frames, base.calm_frames)) w.solver.calm_frames = d.calm_frames;
  if (changed(d.sleep, base.sleep)) {
    w.sleep.enabled = d.sleep >= 1;
    w.sleep.ranges = d.sleep == 2;
  }
  if (changed(d.sleep_speed, base.sleep_speed)) w.sleep.speed = d.sleep_speed;  // checked with the description
  if (changed(d.sleep_time, base.sleep_time)) w.sleep.time = d.sleep_time;
  if (d.floor == 1) {
    haustra::PlaneDesc floor;
    floor.name = "floor";
    floor.point = Eigen::Vector3d(0.0, 0.0, d.floor_height);
    w.environment.planes.push_back(floor);
  } else if (d.floor_height != 0.0) {
    throw Error(
        ErrorCode::invalid_argument,
        fmt::format("def.floor_height = {}: set with def.floor = 0 (no floor); set floor = 1 for one", d.floor_height));
  }
}

// The run-time settings: threads, or the host's job system; the memory the world may take.
void apply_runtime(const haustra_world_def& d, haustra::WorldDesc& w) {
  if (d.threads < 0 || d.threads > 1024)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("def.threads = {}: expected 0 (all cores) to 1024", d.threads));
  w.threads = d.threads;
  if (d.memory_limit != 0.0) w.memory_limit = d.memory_limit;
  if (flag(d.mesh_every_frame, "def.mesh_every_frame")) w.mesh_update = haustra::MeshUpdate::every_frame;
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

// The localization fields retired in ABI 17 (decision 0120), at the values they are ignored at.
constexpr int kRetiredRingsPerVertex = 4;
constexpr double kRetiredWeightLeftOut = 0.02;

// A host that still sets a retired field to anything but its old default is refused, naming it:
// the skin is one choice now, `skinning` (a silent default would change its mesh unseen). A struct
// the host zeroed itself (rings_per_vertex and weight_left_out both 0, which no def made by
// _default() has) never set them: there every field is ignored at 0 (decision 0124).
void refuse_retired_fields(const haustra_segment_def& d, const std::string& where) {
  const bool zeroed = d.rings_per_vertex == 0 && d.weight_left_out == 0.0;
  const auto refuse = [&](const char* field, double value) {
    throw Error(ErrorCode::invalid_argument,
                fmt::format("{}.{} = {}: retired in ABI 17 (decision 0120); use skinning: 1 along the rod, "
                            "0 the cage, 2 the cage with every ring, 3 linear blend",
                            where, field, value));
  };
  if (!zeroed && d.rings_per_vertex != kRetiredRingsPerVertex) refuse("rings_per_vertex", d.rings_per_vertex);
  if (d.max_rings_per_vertex != 0) refuse("max_rings_per_vertex", d.max_rings_per_vertex);
  if (d.mean_rings_per_vertex != 0.0) refuse("mean_rings_per_vertex", d.mean_rings_per_vertex);
  if (!zeroed && d.weight_left_out != kRetiredWeightLeftOut) refuse("weight_left_out", d.weight_left_out);
  if (d.skin_cost_limit != 0.0) refuse("skin_cost_limit", d.skin_cost_limit);
}

haustra::SegmentDesc segment_desc(const haustra_segment_def& host, std::size_t i) {
  const std::string where = fmt::format("segments[{}]", i);
  haustra_segment_def defaults{};
  haustra_segment_def_default(&defaults);
  const haustra_segment_def d = read_def(host, defaults, where);
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
  s.base = flag(d.free_base, where + ".free_base") ? haustra::BaseMode::free : haustra::BaseMode::clamped;
  if (!std::isfinite(d.drag))  // NaN is not "below 0": it would silently have meant the default
    throw Error(ErrorCode::invalid_argument,
                fmt::format("{}.drag = {}: expected a drag in N·s/m² (or below 0 for the default)", where, d.drag));
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
  if (d.mesh != 0) refuse_retired_fields(d, where);
  switch (d.skinning) {
    case 0: s.mesh.skinning = haustra::SkinningMethod::cage; break;
    case 1: s.mesh.skinning = haustra::SkinningMethod::along_rod; break;
    case 2: s.mesh.skinning = haustra::SkinningMethod::cage_full; break;
    case 3: s.mesh.skinning = haustra::SkinningMethod::linear_blend; break;
    default:
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("{}.skinning = {}: expected 1 (along the rod), 0 (the cage), 2 (the cage, every ring) "
                              "or 3 (linear blend)",
                              where, d.skinning));
  }
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

// A world's description from a (checked) def and segment defs, as haustra_world_create builds it.
haustra::WorldDesc world_from_defs(const haustra_world_def& d, const haustra_segment_def* segments,
                                   size_t segment_count) {
  if (segments == nullptr && segment_count > 0) throw Error(ErrorCode::invalid_argument, "segments is NULL");
  if (segment_count > 100'000)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("segment_count = {}: expected at most 100,000", segment_count));
  haustra::WorldDesc w;
  apply_world_fields(d, /*only_changed=*/false, w);
  apply_runtime(d, w);
  for (size_t i = 0; i < segment_count; ++i) w.segments.push_back(segment_desc(segments[i], i));
  return w;
}

// A scene file's description with a (checked) def's changes, as haustra_world_create_from_scene_def
// builds it.
haustra::SceneDesc scene_with_def(const char* scene_path, const haustra_world_def& d) {
  if (scene_path == nullptr) throw Error(ErrorCode::invalid_argument, "scene_path is NULL");
  haustra::SceneDesc scene = haustra::load_scene(scene_path);
  apply_world_fields(d, /*only_changed=*/true, scene.world);
  apply_runtime(d, scene.world);
  return scene;
}

haustra_estimate estimate_of(const haustra::WorldDesc& w) {
  const haustra::MemoryEstimate e = haustra::estimate_memory(w);
  haustra_estimate o{};
#define HAUSTRA_COPY_FIELD(type, name, initial, meaning) o.name = e.name;
  HAUSTRA_MEMORY_FIELDS(HAUSTRA_COPY_FIELD)
#undef HAUSTRA_COPY_FIELD
  o.available = haustra::available_memory();
  return o;
}

Eigen::Vector3d vec3_of(const double v[3]) { return {v[0], v[1], v[2]}; }

// An optional name: the host's string, or the default.
std::string name_or(const char* name, std::string fallback) {
  if (name == nullptr) return fallback;
  const std::size_t n = strnlen(name, 4097);
  if (n > 4096) throw Error(ErrorCode::invalid_argument, "name: longer than 4,096 bytes");
  return {name, n};
}

haustra_instrument_def instrument_defaults() {
  haustra_instrument_def d{};
  haustra_instrument_def_default(&d);
  return d;
}

haustra::InstrumentDesc instrument_desc(const haustra_instrument_def& host, std::size_t index) {
  const haustra_instrument_def d = read_def(host, instrument_defaults(), "def");
  haustra::InstrumentDesc in;
  in.name = name_or(d.name, fmt::format("instrument{}", index));
  in.radius = d.radius;
  in.length = d.length;
  in.grasp_reach = d.grasp_reach;
  in.hold_frame = flag(d.hold_frame, "def.hold_frame");
  in.force_filter = d.force_filter;
  in.coupling_stiffness = d.coupling_stiffness;
  in.coupling_damping = d.coupling_damping;
  in.force_limit = d.force_limit;
  in.holding_force = d.holding_force;
  in.proxy = flag(d.proxy, "def.proxy");
  in.cut_radius = d.cut_radius;
  in.tip = vec3_of(d.tip);  // the rest is checked with the instrument by the builder
  in.axis = vec3_of(d.axis);
  return in;
}

haustra_obstacle_def obstacle_defaults() {
  haustra_obstacle_def d{};
  haustra_obstacle_def_default(&d);
  return d;
}

const char* kind_word(int kind) {
  static constexpr const char* words[] = {"plane", "sphere", "capsule", "mesh"};
  return kind >= 0 && kind < 4 ? words[kind] : "obstacle";
}

int checked_kind(int kind, const char* name) {
  if (kind < HAUSTRA_OBSTACLE_PLANE || kind > HAUSTRA_OBSTACLE_MESH)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("{} = {}: expected 0 (plane), 1 (sphere), 2 (capsule) or 3 (mesh)", name, kind));
  return kind;
}

haustra::ObstacleDesc obstacle_desc(const haustra_obstacle_def& host, const haustra::World& w) {
  const haustra_obstacle_def d = read_def(host, obstacle_defaults(), "def");
  const int kind = checked_kind(d.kind, "def.kind");
  const std::string name =
      name_or(d.name, fmt::format("{}{}", kind_word(kind), w.obstacle_count(static_cast<haustra::ObstacleKind>(kind))));
  if (kind != HAUSTRA_OBSTACLE_MESH &&
      (d.vertices != nullptr || d.vertex_count > 0 || d.triangles != nullptr || d.triangle_count > 0))
    throw Error(ErrorCode::invalid_argument, fmt::format("def.vertices, def.triangles: only a mesh (kind 3) has them, "
                                                         "this is a {}",
                                                         kind_word(kind)));
  if (kind != HAUSTRA_OBSTACLE_MESH) (void)flag(d.container, "def.container");
  switch (kind) {
    case HAUSTRA_OBSTACLE_PLANE: return haustra::PlaneDesc{name, vec3_of(d.point), vec3_of(d.normal)};
    case HAUSTRA_OBSTACLE_SPHERE: return haustra::SphereObstacleDesc{name, vec3_of(d.point), d.radius};
    case HAUSTRA_OBSTACLE_CAPSULE: return haustra::CapsuleObstacleDesc{name, vec3_of(d.point), vec3_of(d.b), d.radius};
    default: break;
  }
  // A mesh: the host's arrays, bounded as a mesh file is (2^24 vertices).
  if (d.vertex_count > (std::size_t{1} << 24) || d.triangle_count > (std::size_t{1} << 25))
    throw Error(ErrorCode::invalid_argument,
                fmt::format("def: {} vertices and {} triangles: at most 16,777,216 and 33,554,432", d.vertex_count,
                            d.triangle_count));
  if ((d.vertices == nullptr && d.vertex_count > 0) || (d.triangles == nullptr && d.triangle_count > 0))
    throw Error(ErrorCode::invalid_argument, "def.vertices or def.triangles is NULL");
  haustra::MeshObstacleDesc m;
  m.name = name;
  m.source = fmt::format("the host's mesh '{}'", name);
  m.container = flag(d.container, "def.container");
  for (std::size_t v = 0; v < d.vertex_count; ++v)
    m.vertices.emplace_back(d.vertices[3 * v], d.vertices[3 * v + 1], d.vertices[3 * v + 2]);
  for (std::size_t t = 0; t < d.triangle_count; ++t)
    m.triangles.push_back({d.triangles[3 * t], d.triangles[3 * t + 1], d.triangles[3 * t + 2]});
  return m;
}

haustra_attachment_def attachment_defaults() {
  haustra_attachment_def d{};
  haustra_attachment_def_default(&d);
  return d;
}

haustra::AttachmentDesc attachment_desc(const haustra_attachment_def& host) {
  const haustra_attachment_def d = read_def(host, attachment_defaults(), "def");
  haustra::AttachmentDesc a;
  if (d.node < -10'000'000 || d.node > 10'000'000)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("def.node = {}: a node index within ±10,000,000 (negative: from the tip)", d.node));
  a.node = static_cast<int>(d.node);
  a.hold_frame = flag(d.hold_frame, "def.hold_frame");
  if (flag(d.has_target, "def.has_target")) a.target = vec3_of(d.target);
  a.active = flag(d.active, "def.active");
  return a;
}

haustra_anchors_def anchors_defaults() {
  haustra_anchors_def d{};
  haustra_anchors_def_default(&d);
  return d;
}

haustra::AnchorsDesc anchors_desc(const haustra_anchors_def& host) {
  const haustra_anchors_def d = read_def(host, anchors_defaults(), "def");
  haustra::AnchorsDesc a;
  a.name = name_or(d.name, a.name);
  a.from = d.from;
  a.to = d.to;
  a.stiffness = d.stiffness;
  a.damping = d.damping;
  a.slack = d.slack;
  a.strength = d.strength;
  a.support = d.support;
  if (d.root != nullptr || d.root_points > 0) {
    if (d.root == nullptr) throw Error(ErrorCode::invalid_argument, "def.root is NULL");
    if (d.root_points > 1'000'000)
      throw Error(ErrorCode::invalid_argument, fmt::format("def.root_points = {}: at most 1,000,000", d.root_points));
    a.target = haustra::AnchorTarget::root;
    for (std::size_t k = 0; k < d.root_points; ++k)
      a.root.emplace_back(d.root[3 * k], d.root[3 * k + 1], d.root[3 * k + 2]);
  }
  return a;
}

// A host moves or releases a segment's own attachments; a grasp slot is its instrument's.
void own_attachment(const haustra::World& w, std::size_t segment, std::size_t attachment) {
  if (w.attachment(segment, attachment).grasp_slot)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("attachment {} of segment {} is instrument {}'s grasp slot: the instrument's pose and "
                            "grasp move it",
                            attachment, segment, w.attachment(segment, attachment).instrument));
}

// A change that rebuilds the world: through the frame publisher for a double-buffered one (its
// render thread holds no frame meanwhile).
template <class F>
void rebuilding(haustra_world& h, F&& change) {
  auto run = [&]() -> const haustra::World& {
    change(*h.world);
    return *h.world;
  };
  if (h.frames)
    h.frames->resize(run);
  else
    run();
}

}  // namespace

extern "C" {

const char* haustra_version(void) { return HAUSTRA_VERSION; }

int haustra_abi_version(void) { return HAUSTRA_ABI_VERSION; }

haustra_status haustra_check_abi(int abi_version) {
  try {
    if (abi_version < HAUSTRA_ABI_OLDEST || abi_version > HAUSTRA_ABI_VERSION)
      throw Error(
          ErrorCode::invalid_argument,
          fmt::format("the host was built against ABI {}, this library is ABI {} (haustra {}) "
                      "and serves hosts of ABI {} to {}{}",
                      abi_version, HAUSTRA_ABI_VERSION, HAUSTRA_VERSION, HAUSTRA_ABI_OLDEST, HAUSTRA_ABI_VERSION,
                      abi_version > HAUSTRA_ABI_VERSION ? ": the host's header is newer than the library"
                      : abi_version == 14               ? ": ABI 15 took the stage \"prefactor\" and the counter "
                                                          "\"prefactors\" out of haustra_profile (decision 0108)"
                                                        : ": structs before ABI 14 carry no size"));
  } catch (...) {
    failed("haustra_check_abi");
    return HAUSTRA_ABI_MISMATCH;
  }
  return succeeded();
}

const char* haustra_last_error(void) { return g_last_error.c_str(); }

const char* haustra_stage_name(int stage) {
  if (stage < 0 || stage >= HAUSTRA_STAGE_COUNT) return nullptr;
  return haustra::stage_name(static_cast<haustra::Stage>(stage)).data();
}

haustra_status haustra_world_create_from_scene(const char* scene_path, int threads, haustra_world** out) {
  try {
    required(out, "out");
    if (scene_path == nullptr) throw Error(ErrorCode::invalid_argument, "scene_path is NULL");
    if (threads < 0 || threads > 1024)
      throw Error(ErrorCode::invalid_argument, fmt::format("threads = {}: expected 0 (all cores) to 1024", threads));
    haustra::SceneDesc scene = haustra::load_scene(scene_path);
    scene.world.threads = threads;
    *out = make_handle(haustra::create_world(scene), false);
  } catch (...) {
    return failed("haustra_world_create_from_scene");
  }
  return succeeded();
}

haustra_status haustra_world_create_from_scene_def(const char* scene_path, const haustra_world_def* def,
                                                   haustra_world** out) {
  try {
    required(out, "out");
    if (scene_path == nullptr) throw Error(ErrorCode::invalid_argument, "scene_path is NULL");
    const haustra_world_def d = def != nullptr ? checked_def(*def) : world_defaults();
    const haustra::SceneDesc scene = scene_with_def(scene_path, d);
    *out = make_handle(haustra::create_world(scene), d.double_buffered != 0, d.mesh_on_host_gpu != 0);
  } catch (...) {
    return failed("haustra_world_create_from_scene_def");
  }
  return succeeded();
}

haustra_status haustra_world_def_default(haustra_world_def* def) {
  try {
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
    d.max_substeps = w.solver.max_substeps;
    d.max_retries = w.solver.max_retries;
    d.calm_frames = w.solver.calm_frames;
    d.sleep = w.sleep.enabled ? (w.sleep.ranges ? 2 : 1) : 0;
    d.sleep_speed = w.sleep.speed;
    d.sleep_time = w.sleep.time;
  } catch (...) {
    return failed("haustra_world_def_default");
  }
  return succeeded();
}

haustra_status haustra_segment_def_default(haustra_segment_def* def) {
  try {
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
    d.rings_per_vertex = kRetiredRingsPerVertex;  // the retired fields at the values they are ignored at
    d.weight_left_out = kRetiredWeightLeftOut;
    d.skinning = 1;  // along the rod (decision 0120)
    d.chain_pieces = s.chain_pieces;
    d.exp2_alpha = s.material.exp2_alpha;
    d.exp2_beta = s.material.exp2_beta;
    d.exp2_gamma = s.material.exp2_gamma;
    const haustra::AnchorsDesc a;
    d.anchor_damping = a.damping;
    d.anchor_slack = a.slack;
    d.anchor_strength = a.strength;
  } catch (...) {
    return failed("haustra_segment_def_default");
  }
  return succeeded();
}

haustra_status haustra_world_create(const haustra_world_def* def, const haustra_segment_def* segments,
                                    size_t segment_count, haustra_world** out) {
  try {
    required(out, "out");
    const haustra_world_def d = checked_def(required(def, "def"));
    *out = make_handle(haustra::World::create(world_from_defs(d, segments, segment_count)), d.double_buffered != 0,
                       d.mesh_on_host_gpu != 0);
  } catch (...) {
    return failed("haustra_world_create");
  }
  return succeeded();
}

haustra_status haustra_world_destroy(haustra_world* world) {
  try {
    {
      std::lock_guard lock(g_registry_mutex);
      // Not while another thread is inside a call on it (Error{busy}); once out of the registry no
      // call can reach it, so it is freed after the hold is let go.
      const haustra::World::Use use(*registered(world).world, std::string_view());
      registry().erase(world);
    }
    delete world;
  } catch (...) {
    return failed("haustra_world_destroy");
  }
  return succeeded();
}

haustra_status haustra_world_step(haustra_world* world) {
  try {
    const Held held(world);
    haustra_world& h = held.handle();
    h.world->step();
    if (h.frames) h.frames->publish(*h.world);
  } catch (...) {
    return failed("haustra_world_step");
  }
  return succeeded();
}

haustra_status haustra_world_counts(const haustra_world* world, haustra_counts* out) {
  try {
    const Held held(world);
    const haustra::World& w = held.world();
    haustra_counts o{};
    o.segments = w.segment_count();
    o.nodes = w.node_count();
    o.beads = w.bead_count();
    o.instruments = w.instrument_count();
    o.mesh_vertices = w.mesh_buffer_size();
    o.mesh_triangles = w.mesh_triangles().size();
    for (int k = 0; k < 4; ++k) o.obstacles[k] = w.obstacle_count(static_cast<haustra::ObstacleKind>(k));
    o.anchors = w.anchor_count();
    write_out(out, o, "out");
  } catch (...) {
    return failed("haustra_world_counts");
  }
  return succeeded();
}

haustra_status haustra_world_time(const haustra_world* world, double* seconds, uint64_t* frame) {
  try {
    const Held held(world);
    const haustra::World& w = held.world();
    if (seconds == nullptr && frame == nullptr)
      throw Error(ErrorCode::invalid_argument, "seconds and frame are both NULL");
    if (seconds != nullptr) *seconds = w.time();
    if (frame != nullptr) *frame = w.frame();
  } catch (...) {
    return failed("haustra_world_time");
  }
  return succeeded();
}

haustra_status haustra_world_segment(const haustra_world* world, size_t segment, haustra_segment_info* out) {
  try {
    const Held held(world);
    const haustra::World& w = held.world();
    const haustra::SegmentInfo& info = w.segment(segment);
    const haustra::Range beads = w.beads(segment);
    const haustra::MeshInfo& mesh = w.mesh(segment);
    write_out(out,
              haustra_segment_info{sizeof(haustra_segment_info), info.name.c_str(), info.nodes.offset, info.nodes.count,
                                   beads.offset, beads.count, mesh.enabled ? mesh.vertices.offset : 0,
                                   mesh.enabled ? mesh.vertices.count : 0, w.chain_of(segment), info.length},
              "out");
  } catch (...) {
    return failed("haustra_world_segment");
  }
  return succeeded();
}

haustra_status haustra_world_add_segment(haustra_world* world, const haustra_segment_def* segment, size_t* index) {
  try {
    const Held held(world);
    haustra_world& h = held.handle();
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
  } catch (...) {
    return failed("haustra_world_add_segment");
  }
  return succeeded();
}

haustra_status haustra_world_remove_segment(haustra_world* world, size_t segment) {
  try {
    const Held held(world);
    haustra_world& h = held.handle();
    auto change = [&]() -> const haustra::World& {
      h.world->remove_segment(segment);
      return *h.world;
    };
    if (h.frames)
      h.frames->resize(change);
    else
      change();
  } catch (...) {
    return failed("haustra_world_remove_segment");
  }
  return succeeded();
}

haustra_status haustra_world_node_positions(const haustra_world* world, haustra_vec3_view* out) {
  try {
    const Held held(world);
    const haustra::World& w = held.world();
    const auto p = w.node_positions();
    required(out, "out") = haustra_vec3_view{p.x.data(), p.y.data(), p.z.data(), w.node_count()};
  } catch (...) {
    return failed("haustra_world_node_positions");
  }
  return succeeded();
}

haustra_status haustra_world_bead_radii(const haustra_world* world, const double** radii, size_t* count) {
  try {
    const Held held(world);
    const haustra::World& w = held.world();
    required(radii, "radii");
    required(count, "count");
    *radii = w.bead_radii().data();
    *count = w.bead_radii().size();
  } catch (...) {
    return failed("haustra_world_bead_radii");
  }
  return succeeded();
}

haustra_status haustra_world_mesh_positions(const haustra_world* world, haustra_vec3f_view* out) {
  try {
    const Held held(world);
    const haustra::World& w = held.world();
    const auto p = w.mesh_positions();
    required(out, "out") = haustra_vec3f_view{p.x.data(), p.y.data(), p.z.data(), w.mesh_buffer_size()};
  } catch (...) {
    return failed("haustra_world_mesh_positions");
  }
  return succeeded();
}

haustra_status haustra_world_mesh_normals(const haustra_world* world, haustra_vec3f_view* out) {
  try {
    const Held held(world);
    const haustra::World& w = held.world();
    const auto n = w.mesh_normals();
    required(out, "out") = haustra_vec3f_view{n.x.data(), n.y.data(), n.z.data(), w.mesh_buffer_size()};
  } catch (...) {
    return failed("haustra_world_mesh_normals");
  }
  return succeeded();
}

static_assert(HAUSTRA_GPU_RING_FLOATS == haustra::kGpuRingFloats);
static_assert(HAUSTRA_GPU_SCREW_SLOT == haustra::kGpuScrewSlot);

haustra_status haustra_world_gpu_skin(const haustra_world* world, haustra_gpu_skin* out) {
  try {
    const Held held(world);
    const std::size_t size = known_size<haustra_gpu_skin>(required(out, "out").struct_size, "out");
    const haustra::GpuSkinBinding& g = held.world().gpu_skin_binding();
    // A host before ABI 17 (its struct ends before ring_data_floats) has no screw in its shader: the
    // rigid-group form, the along-rod vertices linear on their stations.
    const bool linear = size < sizeof(haustra_gpu_skin) && !g.linear_slot_ring.empty();
    held.handle().gave_screws.store(!linear && !g.linear_slot_ring.empty());
    write_out(
        out,
        linear ? haustra_gpu_skin{sizeof(haustra_gpu_skin), g.vertices, g.rings, g.linear_slot_ring.size(),
                                  g.linear_max_slots, g.rest_position.data(), g.rest_normal.data(),
                                  g.linear_slot_range.data(), g.linear_slot_ring.data(),
                                  g.linear_slot_coefficient.data(), 0}
               : haustra_gpu_skin{sizeof(haustra_gpu_skin), g.vertices, g.rings, g.slots(), g.max_slots,
                                  g.rest_position.data(), g.rest_normal.data(), g.slot_range.data(), g.slot_ring.data(),
                                  g.slot_coefficient.data(), haustra::kGpuRingDataFloats * g.rings},
        "out");
  } catch (...) {
    return failed("haustra_world_gpu_skin");
  }
  return succeeded();
}

haustra_status haustra_world_gpu_rings(const haustra_world* world, float* out, size_t count) {
  try {
    const Held held(world);
    const haustra::World& w = held.world();
    const std::size_t want = 2 * HAUSTRA_GPU_RING_FLOATS * w.ring_count(),
                      rows = HAUSTRA_GPU_RING_FLOATS * w.ring_count();
    if (count != want && count != rows)  // the rings' rows alone: a host before ABI 17
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("count = {}: expected {} (2 x HAUSTRA_GPU_RING_FLOATS x {} rings: "
                              "haustra_gpu_skin.ring_data_floats), or {} from a host before ABI 17",
                              count, want, w.ring_count(), rows));
    if (count != want && held.handle().gave_screws.load())
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("count = {}: haustra_world_gpu_skin gave this host the along-rod screws (ABI 17), "
                              "whose data follow the rings' rows: expected haustra_gpu_skin.ring_data_floats = {}",
                              count, want));
    if (want > 0) required(out, "out");
    w.gpu_ring_frame(std::span<float>(out, count));
  } catch (...) {
    return failed("haustra_world_gpu_rings");
  }
  return succeeded();
}

haustra_status haustra_world_mesh_triangles(const haustra_world* world, haustra_triangles_view* out) {
  try {
    const Held held(world);
    const haustra::World& w = held.world();
    const auto t = w.mesh_triangles();
    required(out, "out") = haustra_triangles_view{t.empty() ? nullptr : t.front().data(), t.size()};
  } catch (...) {
    return failed("haustra_world_mesh_triangles");
  }
  return succeeded();
}

haustra_status haustra_world_set_node_load(haustra_world* world, size_t node, const double force[3],
                                           const double moment[3]) {
  try {
    const Held held(world);
    haustra::World& w = held.world();
    const Eigen::Vector3d f = finite_vec3(force, "force");
    const Eigen::Vector3d m = finite_vec3(moment, "moment");
    w.set_external_load(node, f, m);  // checks the node
  } catch (...) {
    return failed("haustra_world_set_node_load");
  }
  return succeeded();
}

haustra_status haustra_world_set_distributed_load(haustra_world* world, size_t segment, size_t count,
                                                  const double* force_per_length, const double* moment_per_length,
                                                  int add) {
  try {
    const Held held(world);
    haustra::World& w = held.world();
    const std::span<const double> forces(&required(force_per_length, "force_per_length"), 3 * count);
    const std::span<const double> moments = moment_per_length == nullptr
                                                ? std::span<const double>()
                                                : std::span<const double>(moment_per_length, 3 * count);
    w.set_distributed_load(segment, forces, moments, flag(add, "add"));  // checks the segment, the count and values
  } catch (...) {
    return failed("haustra_world_set_distributed_load");
  }
  return succeeded();
}

haustra_status haustra_world_set_instrument_pose(haustra_world* world, size_t instrument, const double tip[3],
                                                 const double axis[3]) {
  try {
    const Held held(world);
    haustra::World& w = held.world();
    w.set_instrument_pose(instrument, finite_vec3(tip, "tip"), finite_vec3(axis, "axis"));
  } catch (...) {
    return failed("haustra_world_set_instrument_pose");
  }
  return succeeded();
}

haustra_status haustra_world_set_instrument_grasp(haustra_world* world, size_t instrument, int closed) {
  try {
    live(world).world().set_instrument_grasp(instrument, flag(closed, "closed"));
  } catch (...) {
    return failed("haustra_world_set_instrument_grasp");
  }
  return succeeded();
}

haustra_status haustra_world_instrument(const haustra_world* world, size_t instrument,
                                        haustra_instrument_reading* out) {
  try {
    const haustra::InstrumentReading r = live(world).world().instrument(instrument);
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
    write_out(out, o, "out");
  } catch (...) {
    return failed("haustra_world_instrument");
  }
  return succeeded();
}

haustra_status haustra_world_set_instrument_cutting(haustra_world* world, size_t instrument, int cutting) {
  try {
    live(world).world().set_instrument_cutting(instrument, flag(cutting, "cutting"));
  } catch (...) {
    return failed("haustra_world_set_instrument_cutting");
  }
  return succeeded();
}

haustra_status haustra_world_anchors(const haustra_world* world, const uint32_t** nodes, const uint8_t** intact,
                                     size_t* count) {
  try {
    const Held held(world);
    const haustra::World& w = held.world();
    required(nodes, "nodes") = w.anchor_nodes().data();
    required(intact, "intact") = w.anchors_intact().data();
    required(count, "count") = w.anchor_count();
  } catch (...) {
    return failed("haustra_world_anchors");
  }
  return succeeded();
}

haustra_status haustra_world_anchor_tensions(const haustra_world* world, double* out, size_t count) {
  try {
    if (out == nullptr && count > 0) throw Error(ErrorCode::invalid_argument, "out is NULL");
    live(world).world().anchor_tensions(std::span<double>(out, count));
  } catch (...) {
    return failed("haustra_world_anchor_tensions");
  }
  return succeeded();
}

haustra_status haustra_world_cut_tissue(haustra_world* world, const double centre[3], double radius, size_t* cut) {
  try {
    const std::size_t n = live(world).world().cut_tissue(finite_vec3(centre, "centre"), radius);
    if (cut != nullptr) *cut = n;
  } catch (...) {
    return failed("haustra_world_cut_tissue");
  }
  return succeeded();
}

haustra_status haustra_world_profile(const haustra_world* world, haustra_profile* out) {
  try {
    const Held held(world);
    const haustra::FrameProfile& p = held.world().last_profile();
    haustra_profile o{};
    for (std::size_t s = 0; s < haustra::kStageCount; ++s) o.stage_seconds[s] = p.seconds[s];
    o.frame_seconds = p.frame_seconds;
    o.newton = p.newton ? 1 : 0;
#define HAUSTRA_COPY_FIELD(type, name, initial, meaning) o.name = p.name;
    HAUSTRA_PROFILE_COUNTERS(HAUSTRA_COPY_FIELD)
#undef HAUSTRA_COPY_FIELD
    write_out(out, o, "out");
  } catch (...) {
    return failed("haustra_world_profile");
  }
  return succeeded();
}

haustra_status haustra_world_set_frame_budget(haustra_world* world, double seconds) {
  try {
    live(world).world().set_frame_budget(seconds);
  } catch (...) {
    return failed("haustra_world_set_frame_budget");
  }
  return succeeded();
}

haustra_status haustra_world_late_frames(const haustra_world* world, uint64_t* count) {
  try {
    required(count, "count") = live(world).world().late_frames();
  } catch (...) {
    return failed("haustra_world_late_frames");
  }
  return succeeded();
}

haustra_status haustra_world_set_gravity(haustra_world* world, const double gravity[3]) {
  try {
    live(world).world().set_gravity(finite_vec3(gravity, "gravity"));
  } catch (...) {
    return failed("haustra_world_set_gravity");
  }
  return succeeded();
}

haustra_status haustra_world_gravity(const haustra_world* world, double gravity[3]) {
  try {
    double* out = &required(gravity, "gravity");
    const Eigen::Vector3d g = live(world).world().gravity();
    for (int i = 0; i < 3; ++i) out[i] = g[i];
  } catch (...) {
    return failed("haustra_world_gravity");
  }
  return succeeded();
}

haustra_status haustra_world_set_dt(haustra_world* world, double dt) {
  try {
    live(world).world().set_dt(dt);
  } catch (...) {
    return failed("haustra_world_set_dt");
  }
  return succeeded();
}

haustra_status haustra_world_dt(const haustra_world* world, double* dt) {
  try {
    required(dt, "dt") = live(world).world().dt();
  } catch (...) {
    return failed("haustra_world_dt");
  }
  return succeeded();
}

haustra_status haustra_world_set_instrument_coupling(haustra_world* world, size_t instrument, double stiffness,
                                                     double damping, double force_limit) {
  try {
    live(world).world().set_instrument_coupling(instrument, stiffness, damping, force_limit);
  } catch (...) {
    return failed("haustra_world_set_instrument_coupling");
  }
  return succeeded();
}

haustra_status haustra_world_material(const haustra_world* world, size_t segment, haustra_material* out) {
  try {
    const Held held(world);
    const haustra::SegmentDesc& d = held.world().segment_desc(segment);
    write_out(out,
              haustra_material{sizeof(haustra_material), d.material.youngs_modulus, d.material.poisson_ratio,
                               d.material.density, d.relaxation_time},
              "out");
  } catch (...) {
    return failed("haustra_world_material");
  }
  return succeeded();
}

haustra_status haustra_world_set_material(haustra_world* world, size_t segment, const haustra_material* material) {
  try {
    const Held held(world);
    haustra_world& h = held.handle();
    const haustra::SegmentDesc& now = h.world->segment_desc(segment);
    const haustra_material m =
        read_def(required(material, "material"),
                 haustra_material{sizeof(haustra_material), now.material.youngs_modulus, now.material.poisson_ratio,
                                  now.material.density, now.relaxation_time},
                 "material");
    haustra::MaterialDesc next = now.material;
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
  } catch (...) {
    return failed("haustra_world_set_material");
  }
  return succeeded();
}

haustra_status haustra_world_frame_limits(const haustra_world* world, haustra_frame_limits* out) {
  try {
    const haustra::FrameLimits l = live(world).world().frame_limits();
    write_out(out, haustra_frame_limits{sizeof(haustra_frame_limits), l.max_substeps, l.max_retries, l.calm_frames},
              "out");
  } catch (...) {
    return failed("haustra_world_frame_limits");
  }
  return succeeded();
}

haustra_status haustra_world_set_frame_limits(haustra_world* world, const haustra_frame_limits* limits) {
  try {
    const Held held(world);
    const haustra::FrameLimits now = held.world().frame_limits();
    const haustra_frame_limits l =
        read_def(required(limits, "limits"),
                 haustra_frame_limits{sizeof(haustra_frame_limits), now.max_substeps, now.max_retries, now.calm_frames},
                 "limits");
    held.world().set_frame_limits({l.max_substeps, l.max_retries, l.calm_frames});
  } catch (...) {
    return failed("haustra_world_set_frame_limits");
  }
  return succeeded();
}

haustra_status haustra_world_take_events(haustra_world* world, haustra_event* out, size_t capacity, size_t* count,
                                         uint64_t* dropped) {
  try {
    const Held held(world);
    const std::size_t stride = stride_of(out, capacity, "out");
    required(count, "count");
    // Taken one at a time through a local, so out[] is written only with events that left the queue.
    std::size_t taken = 0;
    std::uint64_t lost = 0;
    for (; taken < capacity; ++taken) {
      haustra::Event e;
      std::uint64_t lost_now = 0;
      if (held.world().take_events(std::span(&e, 1), &lost_now) == 0) break;
      lost += lost_now;
      haustra_event o{};
      o.kind = static_cast<int>(e.kind);
      o.frame = e.frame;
      o.segment = e.segment;
      o.node = e.node;
      o.stage = static_cast<int>(e.stage);
      o.substeps = e.substeps;
      std::memcpy(o.message, e.text.data(), sizeof o.message);
      write_at(out, stride, taken, o);
    }
    if (taken == 0) (void)held.world().take_events({}, &lost);
    *count = taken;
    if (dropped != nullptr) *dropped = lost;
  } catch (...) {
    return failed("haustra_world_take_events");
  }
  return succeeded();
}

haustra_status haustra_world_acquire_frame(haustra_world* world, haustra_frame* out) {
  try {
    haustra_world& h = frame_reader(world);  // beside the stepping thread: no hold (see haustra.h)
    if (!h.frames)
      throw Error(ErrorCode::invalid_argument,
                  "this world was not created with double_buffered = 1 (haustra_world_def)");
    (void)known_size<haustra_frame>(required(out, "out").struct_size, "out");  // before a frame is held
    const haustra::FramePublisher::Slot& s = h.frames->acquire();
    write_out(out,
              haustra_frame{sizeof(haustra_frame),
                            s.frame,
                            s.time,
                            {s.x.data(), s.y.data(), s.z.data(), s.x.size()},
                            {s.px.data(), s.py.data(), s.pz.data(), s.mesh_made ? s.px.size() : 0},
                            {s.nx.data(), s.ny.data(), s.nz.data(), s.mesh_made ? s.nx.size() : 0},
                            h.frames->skins_on_gpu() ? s.gpu_rings.data() : nullptr,
                            h.frames->skins_on_gpu() ? s.rings.size() : 0},
              "out");
  } catch (...) {
    return failed("haustra_world_acquire_frame");
  }
  return succeeded();
}

haustra_status haustra_world_release_frame(haustra_world* world) {
  try {
    haustra_world& h = frame_reader(world);  // beside the stepping thread: no hold (see haustra.h)
    if (!h.frames)
      throw Error(ErrorCode::invalid_argument,
                  "this world was not created with double_buffered = 1 (haustra_world_def)");
    h.frames->release();
  } catch (...) {
    return failed("haustra_world_release_frame");
  }
  return succeeded();
}

haustra_status haustra_world_save_checkpoint(const haustra_world* world, const char* path) {
  try {
    const Held held(world);
    const haustra::World& w = held.world();
    if (path == nullptr) throw Error(ErrorCode::invalid_argument, "path is NULL");
    w.save_checkpoint_file(path);
  } catch (...) {
    return failed("haustra_world_save_checkpoint");
  }
  return succeeded();
}

haustra_status haustra_world_restore_checkpoint(haustra_world* world, const char* path) {
  try {
    const Held held(world);
    haustra_world& h = held.handle();
    if (path == nullptr) throw Error(ErrorCode::invalid_argument, "path is NULL");
    auto restore = [&]() -> const haustra::World& {
      h.world->restore_checkpoint_file(path);
      return *h.world;
    };
    // A restore that rebuilds the rods (another material: decision 0099) is a change of the world
    // the render thread must not hold a frame through; any other is published as a step is.
    if (h.frames && h.world->checkpoint_rebuilds(path)) {
      h.frames->resize(restore);
    } else {
      restore();
      if (h.frames) h.frames->publish(*h.world);
    }
  } catch (...) {
    return failed("haustra_world_restore_checkpoint");
  }
  return succeeded();
}

// Since ABI 14: estimates, parts added and removed at run time, attachments, frames, velocities,
// beads' nodes, contacts.

haustra_status haustra_estimate_world(const haustra_world_def* def, const haustra_segment_def* segments,
                                      size_t segment_count, haustra_estimate* out) {
  try {
    const haustra_world_def d = checked_def(required(def, "def"));
    write_out(out, estimate_of(world_from_defs(d, segments, segment_count)), "out");
  } catch (...) {
    return failed("haustra_estimate_world");
  }
  return succeeded();
}

haustra_status haustra_estimate_scene(const char* scene_path, const haustra_world_def* def, haustra_estimate* out) {
  try {
    const haustra_world_def d = def != nullptr ? checked_def(*def) : world_defaults();
    write_out(out, estimate_of(scene_with_def(scene_path, d).world), "out");
  } catch (...) {
    return failed("haustra_estimate_scene");
  }
  return succeeded();
}

haustra_status haustra_instrument_def_default(haustra_instrument_def* def) {
  try {
    haustra_instrument_def& d = required(def, "def");
    const haustra::InstrumentDesc in;
    d = haustra_instrument_def{};
    d.struct_size = sizeof(haustra_instrument_def);
    d.radius = in.radius;
    d.length = in.length;
    d.grasp_reach = in.grasp_reach;
    d.hold_frame = in.hold_frame ? 1 : 0;
    d.force_filter = in.force_filter;
    d.coupling_stiffness = in.coupling_stiffness;
    d.coupling_damping = in.coupling_damping;
    d.force_limit = in.force_limit;
    d.holding_force = in.holding_force;
    d.proxy = in.proxy ? 1 : 0;
    d.cut_radius = in.cut_radius;
    copy3(in.tip, d.tip);
    copy3(in.axis, d.axis);
  } catch (...) {
    return failed("haustra_instrument_def_default");
  }
  return succeeded();
}

haustra_status haustra_world_add_instrument(haustra_world* world, const haustra_instrument_def* def, size_t* index) {
  try {
    const Held held(world);
    const haustra::InstrumentDesc desc = instrument_desc(required(def, "def"), held.world().instrument_count());
    std::size_t added = 0;
    rebuilding(held.handle(), [&](haustra::World& w) { added = w.add_instrument(desc); });
    if (index != nullptr) *index = added;
  } catch (...) {
    return failed("haustra_world_add_instrument");
  }
  return succeeded();
}

haustra_status haustra_world_remove_instrument(haustra_world* world, size_t instrument) {
  try {
    const Held held(world);
    rebuilding(held.handle(), [&](haustra::World& w) { w.remove_instrument(instrument); });
  } catch (...) {
    return failed("haustra_world_remove_instrument");
  }
  return succeeded();
}

haustra_status haustra_obstacle_def_default(haustra_obstacle_def* def) {
  try {
    haustra_obstacle_def& d = required(def, "def");
    d = haustra_obstacle_def{};
    d.struct_size = sizeof(haustra_obstacle_def);
    d.kind = HAUSTRA_OBSTACLE_PLANE;
    d.normal[2] = 1.0;
    d.b[0] = 1.0;
    d.radius = haustra::SphereObstacleDesc{}.radius;
  } catch (...) {
    return failed("haustra_obstacle_def_default");
  }
  return succeeded();
}

haustra_status haustra_world_add_obstacle(haustra_world* world, const haustra_obstacle_def* def, size_t* index) {
  try {
    const Held held(world);
    const haustra::ObstacleDesc desc = obstacle_desc(required(def, "def"), held.world());
    std::size_t added = 0;
    rebuilding(held.handle(), [&](haustra::World& w) { added = w.add_obstacle(desc); });
    if (index != nullptr) *index = added;
  } catch (...) {
    return failed("haustra_world_add_obstacle");
  }
  return succeeded();
}

haustra_status haustra_world_remove_obstacle(haustra_world* world, int kind, size_t index) {
  try {
    const Held held(world);
    const auto k = static_cast<haustra::ObstacleKind>(checked_kind(kind, "kind"));
    rebuilding(held.handle(), [&](haustra::World& w) { w.remove_obstacle(k, index); });
  } catch (...) {
    return failed("haustra_world_remove_obstacle");
  }
  return succeeded();
}

haustra_status haustra_attachment_def_default(haustra_attachment_def* def) {
  try {
    haustra_attachment_def& d = required(def, "def");
    d = haustra_attachment_def{};
    d.struct_size = sizeof(haustra_attachment_def);
    d.node = -1;
    d.active = 1;
  } catch (...) {
    return failed("haustra_attachment_def_default");
  }
  return succeeded();
}

haustra_status haustra_world_add_attachment(haustra_world* world, size_t segment, const haustra_attachment_def* def,
                                            size_t* index) {
  try {
    const Held held(world);
    const haustra::AttachmentDesc desc = attachment_desc(required(def, "def"));
    std::size_t added = 0;
    rebuilding(held.handle(), [&](haustra::World& w) { added = w.add_attachment(segment, desc); });
    if (index != nullptr) *index = added;
  } catch (...) {
    return failed("haustra_world_add_attachment");
  }
  return succeeded();
}

haustra_status haustra_world_remove_attachment(haustra_world* world, size_t segment, size_t attachment) {
  try {
    const Held held(world);
    rebuilding(held.handle(), [&](haustra::World& w) { w.remove_attachment(segment, attachment); });
  } catch (...) {
    return failed("haustra_world_remove_attachment");
  }
  return succeeded();
}

haustra_status haustra_world_attachment_count(const haustra_world* world, size_t segment, size_t* count) {
  try {
    required(count, "count") = live(world).world().attachment_count(segment);
  } catch (...) {
    return failed("haustra_world_attachment_count");
  }
  return succeeded();
}

haustra_status haustra_world_attachment(const haustra_world* world, size_t segment, size_t attachment,
                                        haustra_attachment_reading* out) {
  try {
    const Held held(world);
    const haustra::AttachmentReading r = held.world().attachment(segment, attachment);
    haustra_attachment_reading o{};
    o.node = r.node;
    o.active = r.active ? 1 : 0;
    o.grasp_slot = r.grasp_slot ? 1 : 0;
    o.instrument = r.instrument;
    copy3(r.target, o.target);
    copy3(r.force, o.force);
    copy3(r.moment, o.moment);
    write_out(out, o, "out");
  } catch (...) {
    return failed("haustra_world_attachment");
  }
  return succeeded();
}

haustra_status haustra_world_set_attachment_target(haustra_world* world, size_t segment, size_t attachment,
                                                   const double target[3]) {
  try {
    const Held held(world);
    own_attachment(held.world(), segment, attachment);
    held.world().set_attachment_target(segment, attachment, finite_vec3(target, "target"));
  } catch (...) {
    return failed("haustra_world_set_attachment_target");
  }
  return succeeded();
}

haustra_status haustra_world_set_attachment_active(haustra_world* world, size_t segment, size_t attachment,
                                                   int active) {
  try {
    const Held held(world);
    own_attachment(held.world(), segment, attachment);
    held.world().set_attachment_active(segment, attachment, flag(active, "active"));
  } catch (...) {
    return failed("haustra_world_set_attachment_active");
  }
  return succeeded();
}

haustra_status haustra_anchors_def_default(haustra_anchors_def* def) {
  try {
    haustra_anchors_def& d = required(def, "def");
    const haustra::AnchorsDesc a;
    d = haustra_anchors_def{};
    d.struct_size = sizeof(haustra_anchors_def);
    d.from = a.from;
    d.to = a.to;
    d.stiffness = a.stiffness;
    d.damping = a.damping;
    d.slack = a.slack;
    d.strength = a.strength;
    d.support = a.support;
  } catch (...) {
    return failed("haustra_anchors_def_default");
  }
  return succeeded();
}

haustra_status haustra_world_add_anchors(haustra_world* world, size_t segment, const haustra_anchors_def* def,
                                         size_t* range) {
  try {
    const Held held(world);
    const haustra::AnchorsDesc desc = anchors_desc(required(def, "def"));
    std::size_t added = 0;
    rebuilding(held.handle(), [&](haustra::World& w) { added = w.add_anchors(segment, desc); });
    if (range != nullptr) *range = added;
  } catch (...) {
    return failed("haustra_world_add_anchors");
  }
  return succeeded();
}

haustra_status haustra_world_remove_anchors(haustra_world* world, size_t segment, size_t range) {
  try {
    const Held held(world);
    rebuilding(held.handle(), [&](haustra::World& w) { w.remove_anchors(segment, range); });
  } catch (...) {
    return failed("haustra_world_remove_anchors");
  }
  return succeeded();
}

haustra_status haustra_world_anchor_ranges(const haustra_world* world, size_t segment, size_t* count) {
  try {
    required(count, "count") = live(world).world().anchor_range_count(segment);
  } catch (...) {
    return failed("haustra_world_anchor_ranges");
  }
  return succeeded();
}

haustra_status haustra_world_node_rotations(const haustra_world* world, haustra_quat_view* out) {
  try {
    const Held held(world);
    const haustra::World& w = held.world();
    const auto r = w.node_rotations();
    required(out, "out") = haustra_quat_view{r.w.data(), r.x.data(), r.y.data(), r.z.data(), w.node_count()};
  } catch (...) {
    return failed("haustra_world_node_rotations");
  }
  return succeeded();
}

haustra_status haustra_world_bead_nodes(const haustra_world* world, const uint32_t** nodes, size_t* count) {
  try {
    const Held held(world);
    const auto b = held.world().bead_nodes();
    required(nodes, "nodes") = b.data();
    required(count, "count") = b.size();
  } catch (...) {
    return failed("haustra_world_bead_nodes");
  }
  return succeeded();
}

haustra_status haustra_world_node_velocities(const haustra_world* world, double* linear, double* angular,
                                             size_t count) {
  try {
    const Held held(world);
    const haustra::World& w = held.world();
    if (linear == nullptr && angular == nullptr)
      throw Error(ErrorCode::invalid_argument, "linear and angular are both NULL");
    if (count != 3 * w.node_count())
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("count = {}: expected 3 × {} nodes = {}", count, w.node_count(), 3 * w.node_count()));
    // Into scratch first: a NULL output is skipped, and nothing is written on a failure.
    std::vector<double> lin(count), ang(count);
    w.node_velocities(lin, ang);
    if (linear != nullptr) std::copy(lin.begin(), lin.end(), linear);
    if (angular != nullptr) std::copy(ang.begin(), ang.end(), angular);
  } catch (...) {
    return failed("haustra_world_node_velocities");
  }
  return succeeded();
}

haustra_status haustra_world_contacts(const haustra_world* world, haustra_contact* out, size_t capacity, size_t* count,
                                      size_t* total) {
  try {
    const Held held(world);
    const std::size_t stride = stride_of(out, capacity, "out");
    required(count, "count");
    const std::span<const haustra::Contact> list = held.world().contact_list();
    const std::size_t n = std::min(capacity, list.size());
    for (std::size_t i = 0; i < n; ++i) {
      const haustra::Contact& c = list[i];
      haustra_contact o{};
      o.kind = static_cast<int>(c.kind);
      o.bead = c.bead;
      o.other = c.other;
      copy3(c.point, o.point);
      copy3(c.direction, o.normal);
      copy3(c.force, o.force);
      o.depth = c.depth;
      write_at(out, stride, i, o);
    }
    *count = n;
    if (total != nullptr) *total = list.size();
  } catch (...) {
    return failed("haustra_world_contacts");
  }
  return succeeded();
}

}  // extern "C"
