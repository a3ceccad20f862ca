/* haustra's C API: for hosts in any language (game engines, simulators, bindings).
 *
 * Conventions
 * - Every function returns a haustra_status; HAUSTRA_OK (0) is success. On failure the calling
 *   thread's haustra_last_error() says what was wrong (which file, field, index or value), and
 *   nothing the call would have written has been written. No C++ exception crosses this API.
 * - A world is an opaque handle. A handle that was never created, or was destroyed, is answered
 *   with HAUSTRA_INVALID_HANDLE (handles are checked against the live worlds, never dereferenced
 *   blindly).
 * - Views (haustra_vec3_view, haustra_vec3f_view, haustra_triangles_view) point into the world's
 *   own buffers: no copies. They stay valid until the next haustra_world_step() or
 *   haustra_world_destroy() of that world. Layout: structure of arrays, x[i], y[i], z[i].
 * - Threads: one world may be used by one thread at a time; different worlds are independent.
 *   haustra_last_error() is per thread.
 * - Units: metres, seconds, newtons, radians; world frame.
 */
#ifndef HAUSTRA_H
#define HAUSTRA_H

#include <stddef.h>
#include <stdint.h>

#if defined(_WIN32)
#define HAUSTRA_API __declspec(dllexport)
#else
#define HAUSTRA_API __attribute__((visibility("default")))
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* The ABI this header describes. A host checks it against the library's with
 * haustra_check_abi(HAUSTRA_ABI_VERSION) before any other call. */
#define HAUSTRA_ABI_VERSION 1

typedef enum haustra_status {
  HAUSTRA_OK = 0,
  HAUSTRA_INVALID_ARGUMENT = 1, /* a value outside its range, an index out of range, a null pointer */
  HAUSTRA_IO = 2,               /* a file that cannot be read or written */
  HAUSTRA_PARSE = 3,            /* a file that is not what its format says */
  HAUSTRA_INVALID_GEOMETRY = 4, /* a centreline or mesh the model cannot be built from */
  HAUSTRA_UNSTABLE = 5,         /* the frame diverged; the world kept its last good frame */
  HAUSTRA_INTERNAL = 6,
  HAUSTRA_INVALID_HANDLE = 7,   /* not a live world */
  HAUSTRA_ABI_MISMATCH = 8
} haustra_status;

typedef struct haustra_world haustra_world;

typedef struct haustra_counts {
  size_t segments;
  size_t nodes;          /* all segments */
  size_t beads;
  size_t instruments;
  size_t mesh_vertices;  /* all segments' organ meshes */
  size_t mesh_triangles;
} haustra_counts;

typedef struct haustra_vec3_view {
  const double* x;
  const double* y;
  const double* z;
  size_t count;
} haustra_vec3_view;

typedef struct haustra_vec3f_view {
  const float* x;
  const float* y;
  const float* z;
  size_t count;
} haustra_vec3f_view;

typedef struct haustra_triangles_view {
  const uint32_t* indices; /* 3 per triangle, into the mesh vertex buffers */
  size_t count;            /* triangles */
} haustra_triangles_view;

typedef struct haustra_instrument_reading {
  double tip[3];
  double force[3];          /* the tissue's force on the instrument, N */
  double torque[3];         /* about the tip, N·m */
  double filtered_force[3]; /* low-passed (the scene's force_filter) */
  int closed;
  int grasping;
  size_t grasped_segment;
  size_t grasped_node;      /* local to the segment */
} haustra_instrument_reading;

#define HAUSTRA_STAGE_COUNT 16

typedef struct haustra_profile {
  double stage_seconds[HAUSTRA_STAGE_COUNT]; /* in the order of haustra_stage_name(0..) */
  double frame_seconds;
  int substeps;
  int retries;
  int newton;
} haustra_profile;

/* Version and ABI. */
HAUSTRA_API const char* haustra_version(void);
HAUSTRA_API haustra_status haustra_check_abi(int abi_version);
/* The message of this thread's last failed call ("" after a success). */
HAUSTRA_API const char* haustra_last_error(void);
/* A stage's name ("collide", "solve", ...), or NULL beyond HAUSTRA_STAGE_COUNT. */
HAUSTRA_API const char* haustra_stage_name(int stage);

/* Worlds. threads: 0 for all cores, 1 for the calling thread only, n for n. */
HAUSTRA_API haustra_status haustra_world_create_from_scene(const char* scene_path, int threads, haustra_world** out);
HAUSTRA_API haustra_status haustra_world_destroy(haustra_world* world);
/* One frame of the scene's dt. HAUSTRA_UNSTABLE: the frame was refused and every buffer still
 * holds the last good frame (the message names segment, node and stage); the world can step on. */
HAUSTRA_API haustra_status haustra_world_step(haustra_world* world);
HAUSTRA_API haustra_status haustra_world_counts(const haustra_world* world, haustra_counts* out);
HAUSTRA_API haustra_status haustra_world_time(const haustra_world* world, double* seconds, uint64_t* frame);

/* Buffers, without copies (see Views above). */
HAUSTRA_API haustra_status haustra_world_node_positions(const haustra_world* world, haustra_vec3_view* out);
HAUSTRA_API haustra_status haustra_world_bead_radii(const haustra_world* world, const double** radii, size_t* count);
HAUSTRA_API haustra_status haustra_world_mesh_positions(const haustra_world* world, haustra_vec3f_view* out);
HAUSTRA_API haustra_status haustra_world_mesh_normals(const haustra_world* world, haustra_vec3f_view* out);
HAUSTRA_API haustra_status haustra_world_mesh_triangles(const haustra_world* world, haustra_triangles_view* out);

/* Loads and instruments. A pose or grasp set here hands the instrument from its script to the host. */
HAUSTRA_API haustra_status haustra_world_set_node_load(haustra_world* world, size_t node, const double force[3],
                                                       const double moment[3]);
HAUSTRA_API haustra_status haustra_world_set_instrument_pose(haustra_world* world, size_t instrument,
                                                             const double tip[3], const double axis[3]);
HAUSTRA_API haustra_status haustra_world_set_instrument_grasp(haustra_world* world, size_t instrument, int closed);
HAUSTRA_API haustra_status haustra_world_instrument(const haustra_world* world, size_t instrument,
                                                    haustra_instrument_reading* out);
HAUSTRA_API haustra_status haustra_world_profile(const haustra_world* world, haustra_profile* out);

#ifdef __cplusplus
}
#endif

#endif /* HAUSTRA_H */
