// Fuzz target: random sequences of C API calls on a small world — steps, host loads and
// instrument poses with any bit pattern (NaN, infinities, huge values), grasps, reads of every
// buffer, stale and made-up handles, NULL pointers, destroy and re-create, checkpoints saved and
// restored (and damaged ones refused), double-buffered frames acquired and released, segments
// (and chains) added and removed between frames; instruments, obstacles, attachments and ranges of
// tissue added and removed, attachments moved, frames, velocities, beads' nodes, contacts and
// estimates read, and structs of any size. Every call must return a status; after every OK step
// every buffer a host reads must be finite.
#include <haustra/haustra.h>

#include "gpu_skin_sum.hpp"

#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

namespace {

// A C API struct as a host fills one: zeroed, its struct_size this header's.
template <class T>
T sized() {
  T t{};
  t.struct_size = sizeof(T);
  return t;
}

struct Input {
  const std::uint8_t* data;
  std::size_t size;
  std::size_t at = 0;
  bool empty() const { return at >= size; }
  std::uint8_t byte() { return at < size ? data[at++] : 0; }
  double number() {
    // Half the time a plausible value, half the time any bit pattern.
    if (byte() & 1) return (static_cast<int>(byte()) - 128) / 256.0;
    std::uint64_t bits = 0;
    for (int i = 0; i < 8; ++i) bits = (bits << 8) | byte();
    double d;
    std::memcpy(&d, &bits, sizeof d);
    return d;
  }
};

void require(bool ok, const char* what) {
  if (!ok) {
    std::fprintf(stderr, "finding: %s\n", what);
    __builtin_trap();  // a finding: make libFuzzer keep the input
  }
}

void check_finite(haustra_world* w) {
  haustra_vec3_view nodes{};
  require(haustra_world_node_positions(w, &nodes) == HAUSTRA_OK, "node view");
  for (std::size_t k = 0; k < nodes.count; ++k)
    require(std::isfinite(nodes.x[k]) && std::isfinite(nodes.y[k]) && std::isfinite(nodes.z[k]), "finite nodes");
  haustra_vec3f_view mesh{}, normals{};
  require(haustra_world_mesh_positions(w, &mesh) == HAUSTRA_OK, "mesh view");
  require(haustra_world_mesh_normals(w, &normals) == HAUSTRA_OK, "normal view");
  for (std::size_t v = 0; v < mesh.count; ++v)
    require(std::isfinite(mesh.x[v]) && std::isfinite(mesh.y[v]) && std::isfinite(mesh.z[v]) &&
                std::isfinite(normals.x[v]) && std::isfinite(normals.y[v]) && std::isfinite(normals.z[v]),
            "finite mesh");
}

std::size_t instruments(haustra_world* w) {
  haustra_counts c = sized<haustra_counts>();
  require(haustra_world_counts(w, &c) == HAUSTRA_OK, "counts");
  return c.instruments;
}

bool parts_status(haustra_status s) {
  return s == HAUSTRA_OK || s == HAUSTRA_INVALID_ARGUMENT || s == HAUSTRA_INVALID_GEOMETRY;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Input in{data, size};
  // Building the mesh's cage and weights is most of an input's time under the sanitizers, so one
  // input in eight gets the world with a mesh, the rest the same world without one.
  const char* scene = (in.byte() % 8 == 0) ? HAUSTRA_SOURCE_DIR "/fuzz/c_api_world.toml"
                                           : HAUSTRA_SOURCE_DIR "/fuzz/c_api_world_no_mesh.toml";
  haustra_world_def def;
  if (haustra_world_def_default(&def) != HAUSTRA_OK) std::abort();
  def.threads = 1;
  def.double_buffered = in.byte() & 1;
  haustra_world* w = nullptr;
  if (haustra_world_create_from_scene_def(scene, &def, &w) != HAUSTRA_OK) std::abort();
  const std::string checkpoint = "/tmp/haustra-fuzz-" + std::to_string(::getpid()) + ".ckpt";
  bool saved = false, acquired = false;
  haustra_world* stale = nullptr;
  int steps = 0;
  while (!in.empty() && steps < 40) {
    const std::size_t index = in.byte() % 4;  // 0 is valid for nodes and the instrument; 1..3 mostly not
    double a[3] = {in.number(), in.number(), in.number()};
    double b[3] = {in.number(), in.number(), in.number()};
    haustra_world* target = w;
    switch (in.byte() % 24) {
      case 0:
      case 1:
      case 2: {
        const haustra_status s = haustra_world_step(w);
        require(s == HAUSTRA_OK || s == HAUSTRA_UNSTABLE, "step status");
        require(s == HAUSTRA_OK || std::strstr(haustra_last_error(), "last good frame") != nullptr, "unstable message");
        check_finite(w);
        ++steps;
        break;
      }
      case 3: {
        const haustra_status s = haustra_world_set_node_load(w, index * 5, a, b);
        require(s == HAUSTRA_OK || s == HAUSTRA_INVALID_ARGUMENT, "load status");
        break;
      }
      case 4: {
        const haustra_status s = haustra_world_set_instrument_pose(w, index, a, b);
        require(s == HAUSTRA_OK || s == HAUSTRA_INVALID_ARGUMENT, "pose status");
        break;
      }
      case 5:
        require(haustra_world_set_instrument_grasp(w, index, in.byte() & 1) ==
                    (index < instruments(w) ? HAUSTRA_OK : HAUSTRA_INVALID_ARGUMENT),
                "grasp status");
        break;
      case 6: {
        haustra_instrument_reading r = sized<haustra_instrument_reading>();
        require(
            haustra_world_instrument(w, index, &r) == (index < instruments(w) ? HAUSTRA_OK : HAUSTRA_INVALID_ARGUMENT),
            "reading");
        // A struct of another size than the library's is refused, never overrun.
        haustra_counts c{};
        c.struct_size = in.byte();
        require(haustra_world_counts(w, &c) == (c.struct_size == sizeof c ? HAUSTRA_OK : HAUSTRA_INVALID_ARGUMENT),
                "struct size");
        break;
      }
      case 7: {
        haustra_counts c = sized<haustra_counts>();
        haustra_triangles_view t{};
        require(haustra_world_counts(w, &c) == HAUSTRA_OK, "counts");
        require(haustra_world_mesh_triangles(w, &t) == HAUSTRA_OK && t.count == c.mesh_triangles, "triangles");
        for (std::size_t i = 0; i < 3 * t.count; ++i) require(t.indices[i] < c.mesh_vertices, "index range");
        break;
      }
      case 8: {
        haustra_profile p = sized<haustra_profile>();
        double seconds = 0.0;
        std::uint64_t frame = 0;
        require(haustra_world_profile(w, &p) == HAUSTRA_OK, "profile");
        require(haustra_world_time(w, &seconds, &frame) == HAUSTRA_OK, "time");
        break;
      }
      case 9:  // destroy and re-create; the old handle becomes stale
        require(haustra_world_destroy(w) == HAUSTRA_OK, "destroy");
        stale = w;
        w = nullptr;
        acquired = saved = false;  // a checkpoint of the old world fits the new one too, but start clean
        if (haustra_world_create_from_scene_def(scene, &def, &w) != HAUSTRA_OK) std::abort();
        break;
      case 10:
        target = stale != nullptr && stale != w ? stale : nullptr;
        require(haustra_world_step(target) == HAUSTRA_INVALID_HANDLE, "stale handle");
        break;
      case 11: {
        haustra_world* made_up = reinterpret_cast<haustra_world*>(&in);
        haustra_counts c = sized<haustra_counts>();
        require(haustra_world_counts(made_up, &c) == HAUSTRA_INVALID_HANDLE, "made-up handle");
        break;
      }
      case 12:
        require(haustra_world_node_positions(w, nullptr) == HAUSTRA_INVALID_ARGUMENT, "NULL out");
        require(haustra_world_set_instrument_pose(w, 0, nullptr, b) == HAUSTRA_INVALID_ARGUMENT, "NULL tip");
        break;
      case 13:  // save, or restore what was saved: the same world takes it back
        if (!saved || (in.byte() & 1)) {
          require(haustra_world_save_checkpoint(w, checkpoint.c_str()) == HAUSTRA_OK, "save");
          saved = true;
        } else {
          // Its run-time parameters come back with it (decision 0099); one that rebuilds the rods (another
          // material) waits until the render thread lets go of its frame.
          const haustra_status s = haustra_world_restore_checkpoint(w, checkpoint.c_str());
          require(s == HAUSTRA_OK || (acquired && s == HAUSTRA_INVALID_ARGUMENT), "restore");
          check_finite(w);
        }
        break;
      case 14: {  // a damaged checkpoint: refused, the world untouched and finite
        std::ofstream(checkpoint + ".bad", std::ios::binary)
            .write(reinterpret_cast<const char*>(data + in.at), static_cast<std::streamsize>(size - in.at));
        const haustra_status s = haustra_world_restore_checkpoint(w, (checkpoint + ".bad").c_str());
        require(s == HAUSTRA_PARSE || s == HAUSTRA_IO, "damaged checkpoint refused");
        check_finite(w);
        break;
      }
      case 15: {  // frames: valid only on a double-buffered world, one acquire at a time
        haustra_frame f = sized<haustra_frame>();
        if (!acquired) {
          const haustra_status s = haustra_world_acquire_frame(w, &f);
          require(s == (def.double_buffered ? HAUSTRA_OK : HAUSTRA_INVALID_ARGUMENT), "acquire");
          acquired = s == HAUSTRA_OK;
          for (std::size_t k = 0; acquired && k < f.nodes.count; ++k)
            require(std::isfinite(f.nodes.z[k]), "finite frame");
        } else {
          require(haustra_world_release_frame(w) == HAUSTRA_OK, "release");
          acquired = false;
        }
        break;
      }
      case 16: {  // a small rod or chain joins: any values, refused by name or added
        haustra_segment_def seg;
        require(haustra_segment_def_default(&seg) == HAUSTRA_OK, "segment default");
        const std::string name = "added" + std::to_string(in.byte() % 4);
        seg.name = name.c_str();
        seg.nodes = 2 + in.byte() % 12;
        seg.chain_pieces = in.byte() % 4;  // 0 is refused
        seg.length = in.number();
        seg.radius = in.number();
        for (int i = 0; i < 3; ++i) seg.base_position[i] = a[i];
        seg.beads = in.byte() % 6;
        seg.tissue = in.byte() % 3;  // 2 is refused; EXP2 is refused in a lagged world
        seg.exp2_beta = in.number();
        haustra_counts c = sized<haustra_counts>();
        require(haustra_world_counts(w, &c) == HAUSTRA_OK, "counts");
        if (c.segments > 6) break;
        size_t added = 0;
        const haustra_status s = haustra_world_add_segment(w, &seg, &added);
        require(s == HAUSTRA_OK || s == HAUSTRA_INVALID_ARGUMENT || s == HAUSTRA_INVALID_GEOMETRY, "add status");
        require(s != HAUSTRA_OK || !acquired, "no change while a frame is held");
        if (s == HAUSTRA_OK) {
          require(added == c.segments, "added last");
          saved = false;  // a checkpoint of the old model no longer fits
        }
        check_finite(w);
        break;
      }
      case 17: {  // a segment leaves (a chain only through its first piece)
        const haustra_status s = haustra_world_remove_segment(w, index);
        require(s == HAUSTRA_OK || s == HAUSTRA_INVALID_ARGUMENT, "remove status");
        require(s != HAUSTRA_OK || !acquired, "no change while a frame is held");
        if (s == HAUSTRA_OK) saved = false;
        check_finite(w);
        break;
      }
      case 18: {  // run-time parameters: any values, refused by name or in force from the next step;
                  // the frame's limits; the event queue
        const int which = in.byte() % 6;
        haustra_status s = HAUSTRA_OK;
        if (which == 0) s = haustra_world_set_gravity(w, a);
        if (which == 1) s = haustra_world_set_dt(w, b[0]);
        if (which == 2) s = haustra_world_set_instrument_coupling(w, index, a[0], a[1], a[2]);
        if (which == 3) {
          const haustra_material m{sizeof(haustra_material), a[0], a[1], a[2], b[0]};
          s = haustra_world_set_material(w, index, &m);
          require(s != HAUSTRA_OK || !acquired, "no material change while a frame is held");
        }
        if (which == 4) {
          const haustra_frame_limits l{sizeof(haustra_frame_limits), static_cast<int>(in.byte()) - 8,
                                       static_cast<int>(in.byte()) % 80 - 4, static_cast<int>(in.byte()) * 1000 - 1};
          s = haustra_world_set_frame_limits(w, &l);
        }
        if (which == 5) {
          haustra_event events[4];
          events[0].struct_size = sizeof(haustra_event);
          std::size_t n = 99;
          std::uint64_t dropped = 0;
          s = haustra_world_take_events(w, events, in.byte() % 5, &n, &dropped);
          require(s == HAUSTRA_OK && n <= 4, "events taken");
          for (std::size_t e = 0; e < n; ++e)
            require(std::memchr(events[e].message, 0, sizeof events[e].message) != nullptr, "an event's text ends");
        }
        require(s == HAUSTRA_OK || s == HAUSTRA_INVALID_ARGUMENT, "parameter status");
        check_finite(w);
        break;
      }
      case 19: {  // an instrument joins (any values) or leaves
        if (in.byte() & 1) {
          if (instruments(w) > 3) break;
          haustra_instrument_def d;
          require(haustra_instrument_def_default(&d) == HAUSTRA_OK, "instrument default");
          for (int i = 0; i < 3; ++i) d.tip[i] = a[i];
          if (in.byte() & 1) d.radius = in.number();
          if (in.byte() & 1) d.force_limit = in.number();
          d.proxy = in.byte() % 3;  // 2 is refused
          size_t added = 99;
          const haustra_status s = haustra_world_add_instrument(w, &d, &added);
          require(parts_status(s), "add instrument status");
          require(s != HAUSTRA_OK || !acquired, "no change while a frame is held");
          if (s == HAUSTRA_OK) {
            require(added + 1 == instruments(w), "added last");
            saved = false;
          }
        } else {
          const haustra_status s = haustra_world_remove_instrument(w, index);
          require(s == HAUSTRA_OK || s == HAUSTRA_INVALID_ARGUMENT, "remove instrument status");
          if (s == HAUSTRA_OK) saved = false;
        }
        check_finite(w);
        break;
      }
      case 20: {  // an obstacle of any kind (4 is refused) joins, or one leaves
        const int kind = in.byte() % 5;
        if (in.byte() & 1) {
          haustra_obstacle_def d;
          require(haustra_obstacle_def_default(&d) == HAUSTRA_OK, "obstacle default");
          d.kind = kind;
          for (int i = 0; i < 3; ++i) {
            d.point[i] = a[i];
            d.normal[i] = b[i];
          }
          d.radius = in.number();
          // A tetrahedron, its corners scaled by a number (closed: a container too).
          const double r = in.number();
          const double vertices[] = {0, 0, 0, r, 0, 0, 0, r, 0, 0, 0, r};
          const std::uint32_t triangles[] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
          if (kind == 3) {
            d.vertices = vertices;
            d.vertex_count = 4;
            d.triangles = triangles;
            d.triangle_count = in.byte() % 5;
            d.container = in.byte() % 3;
          }
          haustra_counts before = sized<haustra_counts>();
          require(haustra_world_counts(w, &before) == HAUSTRA_OK, "counts");
          if (kind < 4 && before.obstacles[kind] > 3) break;
          const haustra_status s = haustra_world_add_obstacle(w, &d, nullptr);
          require(parts_status(s), "add obstacle status");
          require(s != HAUSTRA_OK || !acquired, "no change while a frame is held");
          if (s == HAUSTRA_OK) saved = false;
        } else {
          const haustra_status s = haustra_world_remove_obstacle(w, kind, index);
          require(s == HAUSTRA_OK || s == HAUSTRA_INVALID_ARGUMENT, "remove obstacle status");
          if (s == HAUSTRA_OK) saved = false;
        }
        check_finite(w);
        break;
      }
      case 21: {  // a segment's attachments: one joins or leaves, one is moved, released or read
        const std::size_t segment = in.byte() % 2;
        const int what = in.byte() % 4;
        haustra_status s = HAUSTRA_OK;
        if (what == 0) {
          haustra_attachment_def d;
          require(haustra_attachment_def_default(&d) == HAUSTRA_OK, "attachment default");
          d.node = static_cast<int>(in.byte()) - 128;
          d.hold_frame = in.byte() % 3;
          d.has_target = in.byte() % 2;
          for (int i = 0; i < 3; ++i) d.target[i] = a[i];
          s = haustra_world_add_attachment(w, segment, &d, nullptr);
          require(s != HAUSTRA_OK || !acquired, "no change while a frame is held");
          if (s == HAUSTRA_OK) saved = false;
        } else if (what == 1) {
          s = haustra_world_remove_attachment(w, segment, index);
          if (s == HAUSTRA_OK) saved = false;
        } else if (what == 2) {
          s = haustra_world_set_attachment_target(w, segment, index, a);
          if (s == HAUSTRA_OK) s = haustra_world_set_attachment_active(w, segment, index, in.byte() % 3);
        } else {
          size_t count = 0;
          haustra_attachment_reading r = sized<haustra_attachment_reading>();
          s = haustra_world_attachment_count(w, segment, &count);
          if (s == HAUSTRA_OK) s = haustra_world_attachment(w, segment, index, &r);
          require(s != HAUSTRA_OK || (index < count && std::isfinite(r.force[0])), "attachment reading");
        }
        require(parts_status(s), "attachment status");
        check_finite(w);
        break;
      }
      case 22: {  // a range of connective tissue joins or leaves
        const std::size_t segment = in.byte() % 2;
        haustra_status s = HAUSTRA_OK;
        if (in.byte() & 1) {
          haustra_anchors_def d;
          require(haustra_anchors_def_default(&d) == HAUSTRA_OK, "anchors default");
          d.from = in.number();
          d.to = in.number();
          if (in.byte() & 1) d.stiffness = in.number();
          const double root[] = {a[0], a[1], a[2], b[0], b[1], b[2]};
          if (in.byte() & 1) {
            d.root = root;
            d.root_points = in.byte() % 3;
          }
          s = haustra_world_add_anchors(w, segment, &d, nullptr);
          require(s != HAUSTRA_OK || !acquired, "no change while a frame is held");
        } else {
          s = haustra_world_remove_anchors(w, segment, index);
        }
        if (s == HAUSTRA_OK) saved = false;
        require(parts_status(s), "anchors status");
        check_finite(w);
        break;
      }
      case 23: {  // what a host reads: frames, beads' nodes, velocities, contacts, an estimate, the GPU binding
        haustra_counts c = sized<haustra_counts>();
        require(haustra_world_counts(w, &c) == HAUSTRA_OK, "counts");
        haustra_quat_view q{};
        require(haustra_world_node_rotations(w, &q) == HAUSTRA_OK && q.count == c.nodes, "frames");
        for (std::size_t k = 0; k < q.count; ++k) require(std::isfinite(q.w[k]), "finite frames");
        const std::uint32_t* beads = nullptr;
        size_t n = 0;
        require(haustra_world_bead_nodes(w, &beads, &n) == HAUSTRA_OK && n == c.beads, "bead nodes");
        for (std::size_t k = 0; k < n; ++k) require(beads[k] < c.nodes, "bead node range");
        std::string velocities(3 * c.nodes * sizeof(double), '\0');
        auto* v = reinterpret_cast<double*>(velocities.data());
        require(haustra_world_node_velocities(w, v, nullptr, 3 * c.nodes) == HAUSTRA_OK, "velocities");
        for (std::size_t k = 0; k < 3 * c.nodes; ++k) require(std::isfinite(v[k]), "finite velocities");
        haustra_contact contacts[8];
        contacts[0].struct_size = sizeof(haustra_contact);
        size_t written = 99, total = 0;
        require(haustra_world_contacts(w, contacts, in.byte() % 9, &written, &total) == HAUSTRA_OK, "contacts");
        require(written <= 8 && written <= total, "contact count");
        for (std::size_t k = 0; k < written; ++k) require(contacts[k].bead < c.beads, "contact bead");
        haustra_estimate e = sized<haustra_estimate>();
        require(haustra_estimate_scene(scene, &def, &e) == HAUSTRA_OK && e.nodes > 0, "estimate");
        // The GPU binding (decision 0110): its rings in range, and its sum the library's mesh.
        haustra_gpu_skin g = sized<haustra_gpu_skin>();
        require(haustra_world_gpu_skin(w, &g) == HAUSTRA_OK && g.vertices == c.mesh_vertices, "gpu skin");
        require(g.ring_data_floats == 2 * HAUSTRA_GPU_RING_FLOATS * g.rings, "gpu ring data size");
        std::vector<float> rings(g.ring_data_floats);
        require(haustra_world_gpu_rings(w, rings.data(), rings.size()) == HAUSTRA_OK, "gpu rings");
        haustra_vec3f_view mesh{};
        require(haustra_world_mesh_positions(w, &mesh) == HAUSTRA_OK, "mesh view");
        for (std::size_t i = 0; i < g.vertices; ++i) {
          const std::uint32_t first = g.vertex_slots[2 * i], count = g.vertex_slots[2 * i + 1];
          for (std::uint32_t k = first; k < first + count; ++k) {
            // A screw takes the next slot too (its weight), and names its screw past the rings' rows.
            const bool screw = (g.slot_rings[k] & HAUSTRA_GPU_SCREW_SLOT) != 0;
            const std::size_t at = g.slot_rings[k] & ~HAUSTRA_GPU_SCREW_SLOT;
            require(k + (screw ? 1U : 0U) < std::min<std::size_t>(g.slots, first + count) &&
                        (screw ? at >= g.rings && at < 2 * g.rings : at < g.rings),
                    "gpu slot range");
            k += screw ? 1U : 0U;
          }
          double x[3];
          haustra::test::shader_sum(g, rings, i, x);
          const double off = std::hypot(x[0] - mesh.x[i], x[1] - mesh.y[i], x[2] - mesh.z[i]);
          require(off <= 1e-5 * (1.0 + std::abs(mesh.x[i]) + std::abs(mesh.y[i]) + std::abs(mesh.z[i])), "gpu sum");
        }
        break;
      }
      default: check_finite(w); break;
    }
  }
  if (acquired) require(haustra_world_release_frame(w) == HAUSTRA_OK, "final release");
  require(haustra_world_destroy(w) == HAUSTRA_OK, "final destroy");
  std::remove(checkpoint.c_str());
  std::remove((checkpoint + ".bad").c_str());
  return 0;
}
