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
 * - Threads: one world is used by one thread at a time; different worlds are independent. A call
 *   on a world while another thread is inside a call on it returns HAUSTRA_BUSY at once and
 *   changes nothing (decision 0100), and so does a call on a world from inside its own step (a job
 *   system's callback). The exception is a world created with double_buffered = 1: one other
 *   thread (a render thread) may call haustra_world_acquire_frame / haustra_world_release_frame
 *   while the world steps, and reads the last completed frame without blocking the stepping thread.
 *   A host job system's callbacks are called from the thread that steps the world; its tasks may
 *   run on any thread. haustra_last_error() is per thread.
 * - Structs carry their size (since ABI 14): every struct a host passes or receives starts with
 *   struct_size, which the host sets — sizeof(the struct) as its header has it: a def by its
 *   _default() function, an output as `haustra_counts c = {.struct_size = sizeof c};` (an array of
 *   them: its first element's struct_size, the stride). A library newer than the host's header reads a def only as
 *   far as its struct_size goes (the fields past it keep their defaults) and writes an output only
 *   that far, so an older host's smaller struct is served; a struct_size that is not one of the
 *   sizes the struct has had (0, a newer header's) is refused with HAUSTRA_INVALID_ARGUMENT naming
 *   it. Views (haustra_vec3_view and the like) never grow and carry no size.
 * - Versions: haustra_abi_version() is the library's ABI; haustra_check_abi(HAUSTRA_ABI_VERSION)
 *   accepts a host built against this ABI or an older one back to 15 (14 was the first whose
 *   structs all carry their size; 15 took a stage and a counter out of haustra_profile; 16 added
 *   nodes_asleep at the end of haustra_profile and skinning at the end of haustra_segment_def; 17
 *   made the skin along the rod the default and retired the five localization fields of
 *   haustra_segment_def, same layout: decision 0120; and added ring_data_floats at the end of
 *   haustra_gpu_skin: the along-rod skin's screws, decision 0122).
 * - Units: metres, seconds, newtons, radians; world frame.
 */
#ifndef HAUSTRA_H
#define HAUSTRA_H

#include <stddef.h>
#include <stdint.h>

#include "haustra/report_fields.h"

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
#define HAUSTRA_ABI_VERSION 17
/* The oldest host ABI this library serves (haustra_check_abi). */
#define HAUSTRA_ABI_OLDEST 15

typedef enum haustra_status {
  HAUSTRA_OK = 0,
  HAUSTRA_INVALID_ARGUMENT = 1, /* a value outside its range, an index out of range, a null pointer */
  HAUSTRA_IO = 2,               /* a file that cannot be read or written */
  HAUSTRA_PARSE = 3,            /* a file that is not what its format says */
  HAUSTRA_INVALID_GEOMETRY = 4, /* a centreline or mesh the model cannot be built from */
  HAUSTRA_UNSTABLE = 5,         /* the frame diverged; the world kept its last good frame */
  HAUSTRA_INTERNAL = 6,
  HAUSTRA_INVALID_HANDLE = 7, /* not a live world */
  HAUSTRA_ABI_MISMATCH = 8,
  HAUSTRA_BUSY = 9 /* another thread is inside a call on this world, or the call came from inside its
                      step; nothing was changed (since ABI 13) */
} haustra_status;

typedef struct haustra_world haustra_world;

/* Obstacles by kind (haustra_obstacle_def.kind; the scene's environment.plane, sphere, capsule, mesh). */
typedef enum haustra_obstacle_kind {
  HAUSTRA_OBSTACLE_PLANE = 0,
  HAUSTRA_OBSTACLE_SPHERE = 1,
  HAUSTRA_OBSTACLE_CAPSULE = 2,
  HAUSTRA_OBSTACLE_MESH = 3
} haustra_obstacle_kind;

typedef struct haustra_counts {
  size_t struct_size;
  size_t segments;
  size_t nodes; /* all segments */
  size_t beads;
  size_t instruments;
  size_t mesh_vertices; /* all segments' organ meshes */
  size_t mesh_triangles;
  size_t obstacles[4]; /* by haustra_obstacle_kind. Since ABI 14 */
  size_t anchors;      /* of connective tissue, all segments. Since ABI 14 */
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

/* A node's frame as a quaternion (w, x, y, z; d1, d2, d3 are its columns' rotation of x, y, z). */
typedef struct haustra_quat_view {
  const double* w;
  const double* x;
  const double* y;
  const double* z;
  size_t count;
} haustra_quat_view;

typedef struct haustra_instrument_reading {
  size_t struct_size;
  double tip[3];
  double force[3];          /* the tissue's force on the instrument, N */
  double torque[3];         /* about the tip, N·m */
  double filtered_force[3]; /* low-passed (the scene's force_filter) */
  int closed;
  int grasping;
  int slipped; /* closed, but the grasp let go: pulled past the instrument's holding_force */
  size_t grasped_segment;
  size_t grasped_node; /* local to the segment */
  /* Where it is commanded; `tip` is where its capsule is — for a proxy (decision 0096) where its
   * coupling and what it meets balance. Since ABI 12. */
  double commanded_tip[3];
  int cutting; /* cuts the connective tissue within its cut radius (decision 0095). Since ABI 12. */
} haustra_instrument_reading;

/* The frame's stages (report_fields.h: HAUSTRA_STAGES lists them, with what each does); their
 * names by haustra_stage_name. */
#define HAUSTRA_STAGE_COUNT (0 HAUSTRA_STAGES(HAUSTRA_COUNT_STAGE))

typedef struct haustra_profile {
  size_t struct_size;
  double stage_seconds[HAUSTRA_STAGE_COUNT]; /* in the order of haustra_stage_name(0..) */
  double frame_seconds;
  /* The counters of report_fields.h's HAUSTRA_PROFILE_COUNTERS, what each means written there, in
   * the ABI's order: substeps, retries, newton, fallbacks, backtracks, stiffenings, chords, stalls,
   * iterations, late and (ABI 16) nodes_asleep. */
  HAUSTRA_PROFILE_COUNTERS_BEFORE_NEWTON(HAUSTRA_C_FIELD)
  int newton; /* 1 when the frame that was kept ran Newton iterations */
  HAUSTRA_PROFILE_COUNTERS_AFTER_NEWTON(HAUSTRA_C_FIELD)
} haustra_profile;

/* A host's own job system (instead of oneTBB): a step hands it ranges of independent work with
 * enqueue, then calls wait once, which returns when every range enqueued since the last wait has
 * run. task(task_data, first, last) never fails. workers: how many ranges a batch is split into. */
typedef void (*haustra_task_fn)(void* task_data, size_t first, size_t last);
typedef struct haustra_job_system {
  void (*enqueue)(void* host, haustra_task_fn task, void* task_data, size_t first, size_t last);
  void (*wait)(void* host);
  void* host;
  int workers;
} haustra_job_system;

/* A world built without a scene file; also the run-time settings of one built from a scene. */
typedef struct haustra_world_def {
  size_t struct_size;      /* sizeof(haustra_world_def), set by haustra_world_def_default */
  double dt;               /* s per frame; default 1/60 */
  double gravity[3];       /* m/s²; default (0, 0, -9.81) */
  int threads;             /* 0: all cores (default), 1: the stepping thread only, n: n */
  haustra_job_system jobs; /* enqueue == NULL (default): oneTBB with `threads` */
  int newton;              /* 1 (default): Newton; 0: the paper's lagged scheme; 2: fast (Newton
                            * reusing its factorization while contacts and grasps stay; decision 0037) */
  int iterations;          /* per substep; default 1 */
  int substeps;            /* per frame; default 1 */
  int recover;             /* 1 (default): redo an unstable frame with Newton and more substeps; 0: stop */
  int floor;               /* 1: a floor plane z = floor_height; default 0 */
  double floor_height;     /* m */
  int self_contact;        /* 1 (default): beads of one segment collide */
  double memory_limit;     /* bytes the world may take (its estimate); 0 (default): what the machine has */
  int double_buffered;     /* 1: publish every frame for haustra_world_acquire_frame; default 0 */
  int mesh_every_frame;    /* 1: skin the meshes at the end of every step; 0 (default): when read —
                            * the accessors, or the render thread's acquire in its own thread (decision 0060) */
  double frame_budget;     /* s a frame may take; one over it is counted (haustra_profile.late,
                            * haustra_world_late_frames); 0 (default): none (decision 0061) */
  /* What a frame may cost (haustra_frame_limits below; decision 0100). Since ABI 13. */
  int max_substeps; /* the robust mode's top rung; default 64 */
  int max_retries;  /* redone attempts a frame may take; default 16 */
  int calm_frames;  /* the longest calm spell before a climbed rung halves its substeps; default 120 */
  /* 1: the host skins the organ meshes on its GPU (haustra_world_gpu_skin below; decision 0110): a
   * double_buffered world's acquire makes the frame's ring data (haustra_frame.gpu_rings) and skins
   * nothing, so the frame's mesh work is the cage alone; not with mesh_every_frame = 1. 0 (default):
   * acquire skins the mesh on the CPU. Since ABI 15. */
  int mesh_on_host_gpu;
  /* Rods at rest sleep (the scene's [sleep], decision 0119): 1 on, 0 off (default). A rod whose
   * nodes all move slower than sleep_speed (m/s; default 0.001) for sleep_time (s; default 0.1),
   * with no instrument holding it, is not solved until something wakes it. Since ABI 17.
   * 2: ranges within a rod sleep too (sleep.ranges, decision 0127; not with newton = 0). */
  int sleep;
  double sleep_speed;
  double sleep_time;
} haustra_world_def;

/* One segment: a rod along a centreline (or straight), its beads, and its organ mesh. */
typedef struct haustra_segment_def {
  size_t struct_size;       /* sizeof(haustra_segment_def), set by haustra_segment_def_default */
  const char* name;         /* NULL: "segment<i>" */
  int nodes;                /* default 167 (the paper's) */
  const double* centreline; /* x, y, z per point (m), from the base; NULL: straight, see below */
  size_t centreline_points;
  double length;           /* m, when straight; default 1.66 */
  double base_position[3]; /* m, when straight; default the origin */
  double base_tangent[3];  /* when straight; default +x */
  int free_base;           /* 0 (default): node 0 is clamped; 1: the rod moves freely in a viscous medium */
  double drag;             /* N·s/m² per metre; < 0 (default): 4 for a free base, 0 for a clamped one */
  double radius;           /* m; default 0.02 */
  double wall_thickness;   /* m; default 0.003 */
  double youngs_modulus;   /* Pa; default 33.2e3 (the paper's) */
  double density;          /* kg/m³; default 1050 */
  int beads;               /* beads spread over the nodes; 0 (default): none */
  double bead_radius;      /* m; 0 (default): the radius */
  int mesh;                /* 0 (default): none; 1: procedural organ; 2: mesh_file */
  int mesh_vertices;       /* procedural: about this many; default 10,000 */
  const char* mesh_file;   /* .obj .stl .off .gltf .glb, at the rod's rest pose */
  double mesh_scale;       /* file units to metres; default 1 */
  int rings_per_vertex;    /* retired in ABI 17 (decision 0120): ignored at its old default 4 (or
                              without a mesh, or with all five retired fields 0: a zeroed struct,
                              decision 0124), refused otherwise; choose `skinning` instead */
  int chain_pieces;        /* 1 (default); K > 1: the rod runs as K chained segments "<name>-1".."<name>-K"
                              of `nodes` nodes, `beads` beads and a procedural mesh each, sharing their
                              joint nodes (position and frame) and solved as one rod; centreline or
                              length cover the whole chain */
  int tissue;              /* 0 (default): Hooke's law with youngs_modulus; 1: the EXP2 law
                              sigma = beta (exp(alpha eps^2) - 1) + gamma eps in bending and stretch
                              (needs the Newton solver; torsion stays Hooke's) */
  double exp2_alpha;       /* default 8 */
  double exp2_beta;        /* Pa; default 6700 */
  double exp2_gamma;       /* Pa; default 20000 */
  /* Four more localization fields of the cage (ABI 11 to 16), retired in ABI 17 (decision 0120):
   * each is ignored at its old default (0, 0, 0.02, 0; or without a mesh; or at 0 in a struct the
   * host zeroed, decision 0124) and refused otherwise, naming the field; choose `skinning`
   * instead. Kept so the struct's layout stays. */
  int max_rings_per_vertex;
  double mean_rings_per_vertex;
  double weight_left_out;
  double skin_cost_limit;
  /* Connective tissue along the whole segment, holding each node where it rests (the scene's
   * [[segment.anchors]] from 0 to 1, target "rest"; decision 0095). Since ABI 12. No tissue unless
   * anchor_stiffness or anchor_support is above 0 (both 0 by default).
   * anchor_stiffness: the tether, N/m per metre of organ. */
  double anchor_stiffness;
  double anchor_damping;  /* N·s/m per metre of organ; default 50 */
  double anchor_slack;    /* m of free play; default 0 */
  double anchor_strength; /* N per metre of organ: an anchor pulled past it tears; default 1000; 0: never */
  double anchor_support;  /* N/m per metre of organ, against sinking along gravity only; default 0 */
  /* The skin (the scene's mesh.skinning, decisions 0117 and 0120): 1 (default since ABI 17) along
   * the rod, each mesh vertex on the rod's own frames either side of its place; 0 the cage's mean
   * value coordinates, localized by decision 0048's rule ("cage"); 2 the cage with every ring
   * ("cage-full", full MVC; since ABI 17); 3 linear blend on the bead rings ("linear-blend", for
   * comparison; decision 0124). A struct zeroed by the host has 0: the cage. Since ABI 16. */
  int skinning;
} haustra_segment_def;

/* One segment as the world holds it (haustra_world_segment). */
typedef struct haustra_segment_info {
  size_t struct_size;
  const char* name;               /* valid until segments are added or removed, or the world is destroyed */
  size_t node_offset, node_count; /* its nodes in the node buffers; a chain's pieces share their joint node */
  size_t bead_offset, bead_count; /* its beads (a joint node's bead belongs to the later piece) */
  size_t mesh_vertex_offset, mesh_vertex_count; /* its organ mesh's vertices; 0, 0 without one */
  size_t chain;                                 /* the first segment of its chain; itself when not chained */
  double length;                                /* m, at rest */
} haustra_segment_info;

/* The last completed frame, for a render thread (double_buffered worlds). */
typedef struct haustra_frame {
  size_t struct_size;
  uint64_t frame;
  double time;
  haustra_vec3_view nodes;
  haustra_vec3f_view mesh_positions; /* count 0 in a mesh_on_host_gpu world: the GPU skins */
  haustra_vec3f_view mesh_normals;
  /* The frame's ring data for the skinning shader: HAUSTRA_GPU_RING_FLOATS floats a ring,
   * gpu_ring_count rings (mesh_on_host_gpu worlds; NULL and 0 otherwise). Since ABI 15. */
  const float* gpu_rings;
  size_t gpu_ring_count;
} haustra_frame;

/* Version and ABI. haustra_check_abi: HAUSTRA_OK for an ABI from HAUSTRA_ABI_OLDEST to the
 * library's own, HAUSTRA_ABI_MISMATCH otherwise (a newer host, or one whose structs lack sizes). */
HAUSTRA_API const char* haustra_version(void);
HAUSTRA_API int haustra_abi_version(void); /* since ABI 14 */
HAUSTRA_API haustra_status haustra_check_abi(int abi_version);
/* The message of this thread's last failed call ("" after a success). */
HAUSTRA_API const char* haustra_last_error(void);
/* A stage's name ("collide", "solve", ...), or NULL beyond HAUSTRA_STAGE_COUNT. */
HAUSTRA_API const char* haustra_stage_name(int stage);

/* Worlds. threads: 0 for all cores, 1 for the calling thread only, n for n. */
HAUSTRA_API haustra_status haustra_world_create_from_scene(const char* scene_path, int threads, haustra_world** out);
/* The same with settings from `def`. threads, jobs, double_buffered, memory_limit, mesh_every_frame
 * and frame_budget apply as in haustra_world_create; every other field left at its
 * haustra_world_def_default() value keeps the scene's, and one changed from it overrides the
 * scene's (dt, gravity, newton, iterations, substeps, recover, self_contact, floor with
 * floor_height, max_substeps, max_retries, calm_frames), checked as the scene's field. def may be
 * NULL: the defaults. */
HAUSTRA_API haustra_status haustra_world_create_from_scene_def(const char* scene_path, const haustra_world_def* def,
                                                               haustra_world** out);
HAUSTRA_API haustra_status haustra_world_def_default(haustra_world_def* def);
HAUSTRA_API haustra_status haustra_segment_def_default(haustra_segment_def* def);

/* What a world will take before it is built (since ABI 14; decisions 0038, 0106): the same numbers as
 * `haustra estimate`, World's estimate_memory and Python's haustra.estimate_memory. Creating a world
 * refuses one whose bytes exceed def.memory_limit (or what the machine has available) with the
 * reason. Seconds are on one core of the reference machine, for a world at rest. */
typedef struct haustra_estimate {
  size_t struct_size;
  size_t total; /* bytes */
  size_t nodes;
  size_t rod_bytes;    /* the rods' model and state */
  size_t solver_bytes; /* the Newton solves' workspace */
  size_t bead_bytes;
  size_t mesh_bytes; /* procedural organ meshes (a mesh file's is checked as it loads) */
  size_t beads;
  size_t bead_pairs; /* pairs of one segment's beads within reach of each other at rest */
  size_t pair_bytes;
  double build_seconds;
  double step_seconds;
  size_t available; /* bytes the machine has available now */
} haustra_estimate;
/* Of a world from definitions (as haustra_world_create would build it), or of a scene file with a
 * def's changes (as haustra_world_create_from_scene_def; def may be NULL). */
HAUSTRA_API haustra_status haustra_estimate_world(const haustra_world_def* def, const haustra_segment_def* segments,
                                                  size_t segment_count, haustra_estimate* out);
HAUSTRA_API haustra_status haustra_estimate_scene(const char* scene_path, const haustra_world_def* def,
                                                  haustra_estimate* out);
/* A world from definitions alone: segments[0..segment_count). Errors name the segment and field
 * ("segments[1].radius"). */
HAUSTRA_API haustra_status haustra_world_create(const haustra_world_def* def, const haustra_segment_def* segments,
                                                size_t segment_count, haustra_world** out);
HAUSTRA_API haustra_status haustra_world_destroy(haustra_world* world);
/* One frame of the scene's dt. HAUSTRA_UNSTABLE: the frame was refused and every buffer still
 * holds the last good frame (the message names segment, node and stage); the world can step on. */
HAUSTRA_API haustra_status haustra_world_step(haustra_world* world);
HAUSTRA_API haustra_status haustra_world_counts(const haustra_world* world, haustra_counts* out);
HAUSTRA_API haustra_status haustra_world_time(const haustra_world* world, double* seconds, uint64_t* frame);
HAUSTRA_API haustra_status haustra_world_segment(const haustra_world* world, size_t segment, haustra_segment_info* out);

/* Between frames (from the thread that steps): a segment, or a chain, joins the world, or leaves
 * it. The model is rebuilt, costing what creating the world cost; every other segment keeps its
 * state and steps on as if nothing had changed. Segments after a removed one move down by its
 * piece count; every view and name obtained before is invalid afterwards. A definition the
 * builder refuses leaves the world as it was. A chain is removed whole, through its first
 * segment. Double-buffered worlds: refused while the render thread holds a frame (an acquire
 * meanwhile waits for the change). `index` (may be NULL) receives the new segment's index. */
HAUSTRA_API haustra_status haustra_world_add_segment(haustra_world* world, const haustra_segment_def* segment,
                                                     size_t* index);
HAUSTRA_API haustra_status haustra_world_remove_segment(haustra_world* world, size_t segment);

/* Between frames, what a host adds to a world or takes out of it (since ABI 14; decision 0106):
 * instruments, obstacles, a segment's attachments and ranges of connective tissue. Each rebuilds the
 * model as adding a segment does, and everything else steps on exactly as if nothing had changed
 * (fast mode refactors a rod whose attachments, grasp slots or tissue changed); a definition the
 * builder refuses leaves the world as it was, its message naming the field ("instrument[2].radius").
 * `index` (may be NULL) receives the new part's index: an instrument after the others, an obstacle
 * after the others of its kind, an attachment after the segment's own (its grasp slots, one per
 * instrument, move up by one), a range of anchors after the segment's. Removing one moves those
 * after it down by one; removing an instrument lets go of what it grasped. Views and names obtained
 * before are invalid afterwards; double-buffered worlds: as haustra_world_add_segment. A segment
 * names its chain (any piece), and nodes count along the whole chain (negative: from its tip).
 * At most 64 instruments, 4,096 obstacles of a kind and 1,024 ranges of anchors a segment. */
typedef struct haustra_instrument_def { /* the scene's [[instrument]]; defaults from _default() */
  size_t struct_size;
  const char* name;          /* NULL: "instrument<i>" */
  double radius;             /* m, 1e-4 to 0.5; default 0.004 */
  double length;             /* m, (0, 10]; default 0.3 */
  double grasp_reach;        /* m beyond a bead's surface, [0, 0.5]; default 0.01 */
  int hold_frame;            /* 1: a grasp holds the node's frame too; default 0 */
  double force_filter;       /* s, [0, 100]; default 0 */
  double coupling_stiffness; /* N/m, [0, 1e7] (0: a rigid grasp); default 1000 */
  double coupling_damping;   /* N·s/m, [0, 1e5]; default 2 */
  double force_limit;        /* N, (0, 1e5]; default 8 */
  double holding_force;      /* N, [0, 1e5] (0: never slips); default 0 */
  int proxy;                 /* 1 (default): a proxy (decision 0096); 0: kinematic */
  double cut_radius;         /* m, (0, 0.5]; default 0.005 */
  double tip[3];             /* m; default the origin */
  double axis[3];            /* from the tip towards the handle; default +z */
} haustra_instrument_def;
HAUSTRA_API haustra_status haustra_instrument_def_default(haustra_instrument_def* def);
HAUSTRA_API haustra_status haustra_world_add_instrument(haustra_world* world, const haustra_instrument_def* def,
                                                        size_t* index);
HAUSTRA_API haustra_status haustra_world_remove_instrument(haustra_world* world, size_t instrument);

typedef struct haustra_obstacle_def { /* the scene's [[environment.*]] */
  size_t struct_size;
  int kind;         /* a haustra_obstacle_kind; default HAUSTRA_OBSTACLE_PLANE */
  const char* name; /* NULL: "<kind><i>" */
  double point[3];  /* plane: a point on it; sphere: its centre; capsule: its end a. m */
  double normal[3]; /* plane: its free side (normalized); default +z */
  double b[3];      /* capsule: its end b, m */
  double radius;    /* sphere, capsule: m, (0, 1e5]; default 0.1 */
  /* mesh: vertices (x, y, z each, m) and triangles (3 indices each), copied; closed and wound one
   * way for a container (it keeps beads inside); checked as a mesh file is */
  const double* vertices;
  size_t vertex_count;
  const uint32_t* triangles;
  size_t triangle_count;
  int container; /* mesh: 1 keeps beads inside it; default 0 */
} haustra_obstacle_def;
HAUSTRA_API haustra_status haustra_obstacle_def_default(haustra_obstacle_def* def);
HAUSTRA_API haustra_status haustra_world_add_obstacle(haustra_world* world, const haustra_obstacle_def* def,
                                                      size_t* index);
HAUSTRA_API haustra_status haustra_world_remove_obstacle(haustra_world* world, int kind, size_t index);

typedef struct haustra_attachment_def { /* the scene's [[segment.attachment]] */
  size_t struct_size;
  int64_t node;     /* along the chain; negative: from its tip (-1: the tip). Default -1 */
  int hold_frame;   /* 1: holds the node's frame too (a clamp); default 0 */
  int has_target;   /* 1: target below; 0 (default): where the node rests */
  double target[3]; /* m */
  int active;       /* default 1 */
} haustra_attachment_def;
HAUSTRA_API haustra_status haustra_attachment_def_default(haustra_attachment_def* def);
HAUSTRA_API haustra_status haustra_world_add_attachment(haustra_world* world, size_t segment,
                                                        const haustra_attachment_def* def, size_t* index);
HAUSTRA_API haustra_status haustra_world_remove_attachment(haustra_world* world, size_t segment, size_t attachment);
/* A segment's attachments (its own, then a grasp slot per instrument when it has beads): how many,
 * one's state, and a host moving or releasing one between frames. */
typedef struct haustra_attachment_reading {
  size_t struct_size;
  size_t node;    /* along the chain (a grasp slot: the node it holds) */
  int active;     /* holding */
  int grasp_slot; /* 1: instrument `instrument`'s grasp on this segment */
  size_t instrument;
  double target[3]; /* m */
  double force[3];  /* on the rod in the last frame, N */
  double moment[3]; /* N·m */
} haustra_attachment_reading;
HAUSTRA_API haustra_status haustra_world_attachment_count(const haustra_world* world, size_t segment, size_t* count);
HAUSTRA_API haustra_status haustra_world_attachment(const haustra_world* world, size_t segment, size_t attachment,
                                                    haustra_attachment_reading* out);
HAUSTRA_API haustra_status haustra_world_set_attachment_target(haustra_world* world, size_t segment, size_t attachment,
                                                               const double target[3]);
HAUSTRA_API haustra_status haustra_world_set_attachment_active(haustra_world* world, size_t segment, size_t attachment,
                                                               int active);

typedef struct haustra_anchors_def { /* the scene's [[segment.anchors]] (decision 0095) */
  size_t struct_size;
  const char* name;   /* NULL: "tissue" */
  double from, to;    /* fractions of the chain's rest length, 0 <= from <= to <= 1; default 0, 1 */
  double stiffness;   /* N/m per metre of organ, [0, 1e9]; default 1000 */
  double damping;     /* N·s/m per metre, [0, 1e9]; default 50 */
  double slack;       /* m, [0, 10]; default 0 */
  double strength;    /* N per metre, [0, 1e9] (0: never tears); default 1000 */
  double support;     /* N/m per metre against sinking along gravity, [0, 1e9]; default 0 */
  const double* root; /* NULL (default): each node held where it rests; else a root line of */
  size_t root_points; /* root_points >= 2 points (x, y, z each, m), each anchor a tether to it */
} haustra_anchors_def;
HAUSTRA_API haustra_status haustra_anchors_def_default(haustra_anchors_def* def);
HAUSTRA_API haustra_status haustra_world_add_anchors(haustra_world* world, size_t segment,
                                                     const haustra_anchors_def* def, size_t* range);
HAUSTRA_API haustra_status haustra_world_remove_anchors(haustra_world* world, size_t segment, size_t range);
HAUSTRA_API haustra_status haustra_world_anchor_ranges(const haustra_world* world, size_t segment, size_t* count);

/* Buffers, without copies (see Views above). */
HAUSTRA_API haustra_status haustra_world_node_positions(const haustra_world* world, haustra_vec3_view* out);
HAUSTRA_API haustra_status haustra_world_bead_radii(const haustra_world* world, const double** radii, size_t* count);
HAUSTRA_API haustra_status haustra_world_mesh_positions(const haustra_world* world, haustra_vec3f_view* out);
HAUSTRA_API haustra_status haustra_world_mesh_normals(const haustra_world* world, haustra_vec3f_view* out);
HAUSTRA_API haustra_status haustra_world_mesh_triangles(const haustra_world* world, haustra_triangles_view* out);
/* Since ABI 14: the nodes' frames (quaternions, zero-copy), which node each bead sits on (global
 * node indices, zero-copy; beads ordered by segment then node), and the nodes' velocities over the
 * last frame, copied: 3 per node (x, y, z) into linear[0..count) and angular[0..count) (rad/s,
 * world frame), count = 3 × nodes; either may be NULL. Zero before the first step and after a
 * pose, a restore or a rebuild. */
HAUSTRA_API haustra_status haustra_world_node_rotations(const haustra_world* world, haustra_quat_view* out);
HAUSTRA_API haustra_status haustra_world_bead_nodes(const haustra_world* world, const uint32_t** nodes, size_t* count);
HAUSTRA_API haustra_status haustra_world_node_velocities(const haustra_world* world, double* linear, double* angular,
                                                         size_t count);
/* Skinning on the host's GPU (since ABI 15; decision 0110; docs/skinning.md "Skinning on the host's
 * GPU"; the shader is render/shaders/haustra_skin.glsl, installed in share/haustra/shaders). Every
 * mesh vertex (indexed as the mesh buffers) is its rest position plus a sum over its slots, each a
 * cage ring g and four coefficients (b, Ax, Ay, Az):
 *     x' = x + sum_s [ dR_g (Ax, Ay, Az) + b dc_g ],   dR_g = R'_g - R_g, dc_g = c'_g - c_g,
 * the CPU's sum (docs/skinning.md). Its normal: the rest normal under the cofactor of
 * M = I + sum_s b (R'_g - R_g) R_g^T, normalized. haustra_world_gpu_skin's arrays are the world's
 * (no copy), made on the first call and valid until the world is rebuilt (a segment added or
 * removed, a material, a restore that rebuilds: as names and views) or destroyed; upload them once.
 * haustra_world_gpu_rings copies the current frame's ring data into out[0..count), count =
 * HAUSTRA_GPU_RING_FLOATS x rings: per ring six rows of four floats, [dR_g | dc_g] (3 rows) and
 * [(R'_g - R_g) R_g^T | 0] (3 rows); it makes the rings alone (no vertex is skinned). A render thread
 * of a double-buffered world reads the same from haustra_frame.gpu_rings (mesh_on_host_gpu = 1).
 * Since ABI 17 (decision 0122) a vertex of a mesh skinned along the rod (skinning = 1) is a screw
 * instead. After the rings' rows the ring data has HAUSTRA_GPU_RING_FLOATS floats a ring more: for
 * each station of an along-rod mesh the screw to the next station, [R | c] of the station (3 rows),
 * [axis | angle], [P | c], [Q | d] (axis, P and Q in the station's frame); zeros for other rings. A
 * screw slot has the top bit (HAUSTRA_GPU_SCREW_SLOT) of its ring set; the low bits are rings + the
 * station's ring, so ring x HAUSTRA_GPU_RING_FLOATS finds its screw as it finds a ring's rows. It
 * takes two slots' coefficients, (t, ox, oy, oz) and (w, nx, ny, nz), and the vertex is
 *     x' = sum w (R y + c),  y = Rot(axis, f) o + kP P + kQ Q + t d axis,  f = t angle,
 *     kP = (1 - cos f)/2 + t c sin(f)/f,  kQ = t c (1 - cos f)/f - sin(f)/2
 * (their limits t and 0 as f -> 0), its normal sum w R Rot(axis, f) n, normalized. Such a host
 * passes count = 2 x HAUSTRA_GPU_RING_FLOATS x rings (haustra_gpu_skin.ring_data_floats) to
 * haustra_world_gpu_rings (the rows alone are refused once the world has handed it the screws) and
 * reads as many from haustra_frame.gpu_rings. A host built before ABI 17
 * (its smaller haustra_gpu_skin) is given every vertex in the rigid-group form (an along-rod vertex
 * on its two stations, linear along them, as in ABI 16) and reads the rings' rows alone. */
#define HAUSTRA_GPU_RING_FLOATS 24
#define HAUSTRA_GPU_SCREW_SLOT 0x80000000u
typedef struct haustra_gpu_skin {
  size_t struct_size;
  size_t vertices; /* haustra_counts.mesh_vertices */
  size_t rings;    /* all segments' cage rings */
  size_t slots;
  uint32_t max_slots;             /* the most slots one vertex has */
  const float* rest_positions;    /* 3 a vertex: x y z (m), the curved rest pose */
  const float* rest_normals;      /* 3 a vertex: unit, the CPU's normals at rest (0 0 0: none) */
  const uint32_t* vertex_slots;   /* 2 a vertex: its first slot and how many */
  const uint32_t* slot_rings;     /* 1 a slot: the ring, 0 .. rings - 1 (a screw: see above) */
  const float* slot_coefficients; /* 4 a slot: b, Ax, Ay, Az (a screw: see above) */
  /* Floats of a frame's ring data: 2 x HAUSTRA_GPU_RING_FLOATS x rings (the rings' rows, then the
   * screws). Since ABI 17. */
  size_t ring_data_floats;
} haustra_gpu_skin;
HAUSTRA_API haustra_status haustra_world_gpu_skin(const haustra_world* world, haustra_gpu_skin* out);
HAUSTRA_API haustra_status haustra_world_gpu_rings(const haustra_world* world, float* out, size_t count);

/* The contacts of the last substep (since ABI 14): every bead and what it may touch, listed within
 * the margin at the substep's start; depth > 0 touches. Copied into out[0..capacity) (stride:
 * out[0].struct_size); `count` receives how many were written, `total` (may be NULL) how many there
 * are. */
typedef enum haustra_contact_kind {
  HAUSTRA_CONTACT_BEAD = 0,  /* another bead: other is its index */
  HAUSTRA_CONTACT_PLANE = 1, /* other: the plane's index; likewise for the kinds below */
  HAUSTRA_CONTACT_SPHERE = 2,
  HAUSTRA_CONTACT_CAPSULE = 3,
  HAUSTRA_CONTACT_MESH = 4,
  HAUSTRA_CONTACT_INSTRUMENT = 5
} haustra_contact_kind;
typedef struct haustra_contact {
  size_t struct_size;
  int kind; /* a haustra_contact_kind */
  size_t bead;
  size_t other;
  double point[3];  /* where the other surface comes nearest the bead's centre, m */
  double normal[3]; /* the separating direction */
  double force[3];  /* N, on `bead` (a second bead gets the opposite) */
  double depth;     /* m; > 0 overlapping */
} haustra_contact;
HAUSTRA_API haustra_status haustra_world_contacts(const haustra_world* world, haustra_contact* out, size_t capacity,
                                                  size_t* count, size_t* total);

/* Loads and instruments. A pose or grasp set here hands the instrument from its script to the host.
 * A load is at most 1e5 N and 1e5 N·m in each component (as every vector); closed and cutting are 0 or 1. */
HAUSTRA_API haustra_status haustra_world_set_node_load(haustra_world* world, size_t node, const double force[3],
                                                       const double moment[3]);
/* A load per metre of rest length along a segment (decision 0102): force_per_length (N/m) and
 * moment_per_length (N·m/m, or NULL for none), 3 doubles (x y z, world frame) per node of the segment,
 * `count` nodes (the segment's node count), lumped onto its nodes by their share of the rest length.
 * It replaces what those nodes held (add = 0) or adds to it (add = 1). */
HAUSTRA_API haustra_status haustra_world_set_distributed_load(haustra_world* world, size_t segment, size_t count,
                                                              const double* force_per_length,
                                                              const double* moment_per_length, int add);
HAUSTRA_API haustra_status haustra_world_set_instrument_pose(haustra_world* world, size_t instrument,
                                                             const double tip[3], const double axis[3]);
HAUSTRA_API haustra_status haustra_world_set_instrument_grasp(haustra_world* world, size_t instrument, int closed);
HAUSTRA_API haustra_status haustra_world_instrument(const haustra_world* world, size_t instrument,
                                                    haustra_instrument_reading* out);
/* While cutting is 1, the instrument cuts the connective tissue within its cut radius of its tip. */
HAUSTRA_API haustra_status haustra_world_set_instrument_cutting(haustra_world* world, size_t instrument, int cutting);
HAUSTRA_API haustra_status haustra_world_profile(const haustra_world* world, haustra_profile* out);

/* Connective tissue (decision 0095). Anchors, ordered by segment, range and node: the global node
 * each holds and whether it still holds (1) or was torn or cut (0); views valid until the next
 * step or rebuild. Tensions (N, 0 once torn or cut) into out[0..count). A cut takes every
 * anchor whose tissue passes within `radius` (m) of `centre`; `cut` (may be NULL) receives how many. */
HAUSTRA_API haustra_status haustra_world_anchors(const haustra_world* world, const uint32_t** nodes,
                                                 const uint8_t** intact, size_t* count);
HAUSTRA_API haustra_status haustra_world_anchor_tensions(const haustra_world* world, double* out, size_t count);
HAUSTRA_API haustra_status haustra_world_cut_tissue(haustra_world* world, const double centre[3], double radius,
                                                    size_t* cut);
/* Deadline mode (decision 0061): seconds a frame may take (0: none), and the frames over it so far. */
HAUSTRA_API haustra_status haustra_world_set_frame_budget(haustra_world* world, double seconds);
HAUSTRA_API haustra_status haustra_world_late_frames(const haustra_world* world, uint64_t* count);

/* Run-time parameters (decision 0082): changed between steps, each as if the world had been
 * built with the value (the same bits from the next step on), checked as the scene's fields are.
 * gravity in m/s² (world frame, at most 100 g); dt in s (world.dt's range). */
HAUSTRA_API haustra_status haustra_world_set_gravity(haustra_world* world, const double gravity[3]);
HAUSTRA_API haustra_status haustra_world_gravity(const haustra_world* world, double gravity[3]);
HAUSTRA_API haustra_status haustra_world_set_dt(haustra_world* world, double dt);
HAUSTRA_API haustra_status haustra_world_dt(const haustra_world* world, double* dt);
/* A grasp's virtual coupling (N/m, N·s/m, N; decision 0057), from the next step. A grasp does not
 * switch between rigid (stiffness 0) and coupled here. */
HAUSTRA_API haustra_status haustra_world_set_instrument_coupling(haustra_world* world, size_t instrument,
                                                                 double stiffness, double damping, double force_limit);
/* A segment's (a chain's, through its first piece) material: read it, change fields, set it. The
 * rods are rebuilt and their state carried over; the organ mesh's cage and binding are kept (a
 * fraction of a rebuild). Views into the world are invalidated, as by haustra_world_add_segment. */
typedef struct haustra_material {
  size_t struct_size;
  double youngs_modulus; /* Pa */
  double poisson_ratio;
  double density;         /* kg/m³ */
  double relaxation_time; /* s: the viscous law's η / E */
} haustra_material;
HAUSTRA_API haustra_status haustra_world_material(const haustra_world* world, size_t segment, haustra_material* out);
HAUSTRA_API haustra_status haustra_world_set_material(haustra_world* world, size_t segment,
                                                      const haustra_material* material);

/* What a frame may cost (decision 0100): the robust mode redoes a frame that fails its guard with
 * Newton, then with twice the substeps each time, up to max_substeps and at most max_retries times;
 * a frame it cannot hold within them returns HAUSTRA_UNSTABLE (the world keeps its last good frame)
 * and its event names the limit. A rung it climbed to is kept for a calm spell, then its substeps
 * halve: 8 frames, doubled each time a rung is needed again within calm_frames calm frames, at most
 * calm_frames (decision 0109). So a frame costs at most (1 + max_retries) attempts of at most max_substeps
 * substeps, and a recovery at most calm_frames x log2(max_substeps) slow frames. From the next step;
 * checked as the scene's solver fields; lowering max_substeps lowers the rung in force. */
typedef struct haustra_frame_limits {
  size_t struct_size;
  int max_substeps; /* 1 (or the scene's substeps) to 65536 */
  int max_retries;  /* 0 to 64 */
  int calm_frames;  /* 1 to 1,000,000 */
} haustra_frame_limits;
HAUSTRA_API haustra_status haustra_world_frame_limits(const haustra_world* world, haustra_frame_limits* out);
HAUSTRA_API haustra_status haustra_world_set_frame_limits(haustra_world* world, const haustra_frame_limits* limits);

/* Events, as a queue (since ABI 13): what the steps recorded — a frame redone, a frame refused
 * (unstable), a grasp that slipped, connective tissue torn or cut — oldest first. take moves up to
 * `capacity` of the waiting events into out[0..*count) (stride: out[0].struct_size) and removes them
 * from the queue. At most
 * 1,024 wait; later ones are dropped until some are taken, and `dropped` (may be NULL) receives how
 * many were lost since the last take. */
typedef enum haustra_event_kind {
  HAUSTRA_EVENT_RECOVERED = 0, /* a frame failed its guard and was redone on a higher rung */
  HAUSTRA_EVENT_UNSTABLE = 1,  /* a frame failed on every rung its limits allow: it was refused */
  HAUSTRA_EVENT_SLIPPED = 2,   /* a grasp let go */
  HAUSTRA_EVENT_TORN = 3,      /* anchors of connective tissue tore */
  HAUSTRA_EVENT_CUT = 4        /* anchors were cut */
} haustra_event_kind;
typedef struct haustra_event {
  size_t struct_size;
  int kind;       /* a haustra_event_kind */
  uint64_t frame; /* the frame it happened in */
  size_t segment; /* the segment (a chain's piece) and its local node */
  size_t node;
  int stage;         /* the stage that failed or reported it (haustra_stage_name) */
  int substeps;      /* of the rung the frame ran on */
  char message[512]; /* what happened and what to change, NUL-terminated */
} haustra_event;
HAUSTRA_API haustra_status haustra_world_take_events(haustra_world* world, haustra_event* out, size_t capacity,
                                                     size_t* count, uint64_t* dropped);

/* Double-buffered output (worlds created with double_buffered = 1). acquire gives the last
 * completed frame; its views stay valid, and unchanged, until release, however many frames the
 * world steps meanwhile. One acquire at a time; never blocks the stepping thread. */
HAUSTRA_API haustra_status haustra_world_acquire_frame(haustra_world* world, haustra_frame* out);
HAUSTRA_API haustra_status haustra_world_release_frame(haustra_world* world);

/* Checkpoints: the world's state to a file and back, with the run-time parameters in force (gravity,
 * dt, frame budget and limits, grasp couplings, materials; decision 0099), which restoring puts
 * back. Stepping on from a restore gives the same bits as never having stopped, whatever was set
 * before or after the save. A checkpoint of another model, or a damaged one, is refused
 * (HAUSTRA_PARSE) and the world is left as it was. Restoring moves the time back or forth; one
 * whose material differs from the world's rebuilds the rods as haustra_world_set_material does
 * (views are invalidated; a double-buffered world's is refused while the render thread holds a
 * frame). */
HAUSTRA_API haustra_status haustra_world_save_checkpoint(const haustra_world* world, const char* path);
HAUSTRA_API haustra_status haustra_world_restore_checkpoint(haustra_world* world, const char* path);

#ifdef __cplusplus
}
#endif

#endif /* HAUSTRA_H */
