// The C API (haustra/haustra.h) over the C++ World: handles checked against the live worlds,
// exceptions turned into status codes and a per-thread message, outputs written only on success.
#include "haustra/haustra.h"

#include <fmt/format.h>

#include <cmath>
#include <exception>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <unordered_set>

#include "haustra/error.hpp"
#include "haustra/scene.hpp"
#include "haustra/world.hpp"

struct haustra_world {
  std::unique_ptr<haustra::World> world;
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

haustra::World& live(const haustra_world* w) {
  std::lock_guard lock(g_registry_mutex);
  if (w == nullptr) throw HandleError{"the world handle is NULL"};
  if (registry().count(w) == 0)
    throw HandleError{fmt::format("{} is not a live world (never created, or already destroyed)", fmt::ptr(w))};
  return *w->world;
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
    throw Error(ErrorCode::invalid_argument, fmt::format("{} = ({}, {}, {}): expected finite numbers", name, v[0], v[1], v[2]));
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

void copy3(const Eigen::Vector3d& v, double out[3]) {
  for (int i = 0; i < 3; ++i) out[i] = v[i];
}

}  // namespace

extern "C" {

const char* haustra_version(void) { return HAUSTRA_VERSION; }

haustra_status haustra_check_abi(int abi_version) {
  return guarded("haustra_check_abi", [&] {
    if (abi_version != HAUSTRA_ABI_VERSION)
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("the host was built against ABI {}, this library is ABI {} (haustra {})", abi_version,
                              HAUSTRA_ABI_VERSION, HAUSTRA_VERSION));
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
    auto handle = std::make_unique<haustra_world>();
    handle->world = haustra::create_world(scene);
    {
      std::lock_guard lock(g_registry_mutex);
      registry().insert(handle.get());
    }
    *out = handle.release();
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
  return guarded("haustra_world_step", [&] { live(world).step(); });
}

haustra_status haustra_world_counts(const haustra_world* world, haustra_counts* out) {
  return guarded("haustra_world_counts", [&] {
    const haustra::World& w = live(world);
    haustra_counts& o = required(out, "out");
    o = haustra_counts{w.segment_count(), w.node_count(), w.bead_count(), w.instrument_count(),
                       w.mesh_buffer_size(), w.mesh_triangles().size()};
  });
}

haustra_status haustra_world_time(const haustra_world* world, double* seconds, uint64_t* frame) {
  return guarded("haustra_world_time", [&] {
    const haustra::World& w = live(world);
    if (seconds == nullptr && frame == nullptr) throw Error(ErrorCode::invalid_argument, "seconds and frame are both NULL");
    if (seconds != nullptr) *seconds = w.time();
    if (frame != nullptr) *frame = w.frame();
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

haustra_status haustra_world_set_node_load(haustra_world* world, size_t node, const double force[3], const double moment[3]) {
  return guarded("haustra_world_set_node_load", [&] {
    haustra::World& w = live(world);
    const Eigen::Vector3d f = finite_vec3(force, "force");
    const Eigen::Vector3d m = finite_vec3(moment, "moment");
    if (node >= w.node_count())
      throw Error(ErrorCode::invalid_argument, fmt::format("node {} out of range (the world has {})", node, w.node_count()));
    w.set_external_load(node, f, m);
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
  return guarded("haustra_world_set_instrument_grasp", [&] { live(world).set_instrument_grasp(instrument, closed != 0); });
}

haustra_status haustra_world_instrument(const haustra_world* world, size_t instrument, haustra_instrument_reading* out) {
  return guarded("haustra_world_instrument", [&] {
    const haustra::InstrumentReading r = live(world).instrument(instrument);
    haustra_instrument_reading o{};
    copy3(r.tip, o.tip);
    copy3(r.force, o.force);
    copy3(r.torque, o.torque);
    copy3(r.filtered_force, o.filtered_force);
    o.closed = r.closed ? 1 : 0;
    o.grasping = r.grasping ? 1 : 0;
    o.grasped_segment = r.grasped_segment;
    o.grasped_node = r.grasped_node;
    required(out, "out") = o;
  });
}

haustra_status haustra_world_profile(const haustra_world* world, haustra_profile* out) {
  return guarded("haustra_world_profile", [&] {
    const haustra::FrameProfile& p = live(world).last_profile();
    haustra_profile o{};
    for (std::size_t s = 0; s < haustra::kStageCount; ++s) o.stage_seconds[s] = p.seconds[s];
    o.frame_seconds = p.frame_seconds;
    o.substeps = p.substeps;
    o.retries = p.retries;
    o.newton = p.newton ? 1 : 0;
    required(out, "out") = o;
  });
}

}  // extern "C"
