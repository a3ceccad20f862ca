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
 *   The exception is a world created with double_buffered = 1: one other thread (a render
 *   thread) may call haustra_world_acquire_frame / haustra_world_release_frame while the world
 *   steps, and reads the last completed frame without blocking the stepping thread.
 *   A host job system's callbacks are called from the thread that steps the world; its tasks may
 *   run on any thread. haustra_last_error() is per thread.
 * - Structs a host fills (haustra_world_def, haustra_segment_def) start with struct_size; fill
 *   them with their _default() function first, then change what differs.
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
#define HAUSTRA_ABI_VERSION 12

typedef enum haustra_status {
  HAUSTRA_OK = 0,
  HAUSTRA_INVALID_ARGUMENT = 1, /* a value outside its range, an index out of range, a null pointer */
  HAUSTRA_IO = 2,               /* a file that cannot be read or written */
  HAUSTRA_PARSE = 3,            /* a file that is not what its format says */
  HAUSTRA_INVALID_GEOMETRY = 4, /* a centreline or mesh the model cannot be built from */
  HAUSTRA_UNSTABLE = 5,         /* the frame diverged; the world kept its last good frame */
  HAUSTRA_INTERNAL = 6,
  HAUSTRA_INVALID_HANDLE = 7, /* not a live world */
  HAUSTRA_ABI_MISMATCH = 8
} haustra_status;

typedef struct haustra_world haustra_world;

typedef struct haustra_counts {
  size_t segments;
  size_t nodes; /* all segments */
  size_t beads;
  size_t instruments;
  size_t mesh_vertices; /* all segments' organ meshes */
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
  int slipped; /* closed, but the grasp let go: pulled past the instrument's holding_force */
  size_t grasped_segment;
  size_t grasped_node; /* local to the segment */
  /* Where it is commanded; `tip` is where its capsule is — for a proxy (decision 0096) where its
   * coupling and what it meets balance. Since ABI 12. */
  double commanded_tip[3];
  int cutting; /* cuts the connective tissue within its cut radius (decision 0095). Since ABI 12. */
} haustra_instrument_reading;

#define HAUSTRA_STAGE_COUNT 21

typedef struct haustra_profile {
  double stage_seconds[HAUSTRA_STAGE_COUNT]; /* in the order of haustra_stage_name(0..) */
  double frame_seconds;
  int substeps;
  int retries;
  int newton;
  int fallbacks;   /* Newton iterations the banded LU solved (the condensed sweep's pivots were unsafe) */
  int backtracks;  /* line-search halvings of Newton steps */
  int stiffenings; /* Newton steps solved again with the law stiffened (the plain step went uphill) */
  int chords;      /* fast mode: Newton iterations that reused the last factorization */
  int stalls;      /* Newton iterations whose line search took none of a step that was not small */
  int iterations;  /* fixed-point iterations run, summed over substeps */
  int late;        /* 1 when the frame took longer than the world's frame budget (decision 0061) */
  int prefactors;  /* fast mode: records swapped in that were made two frames before, in the background */
  /* One field per counter of report_fields.h's HAUSTRA_PROFILE_COUNTERS (new ones at the end). */
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
  int rings_per_vertex;    /* mean value coordinates kept per vertex; default 4; 0: all */
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
  /* The most rings a mesh vertex keeps (the scene's mesh.max_rings_per_vertex, decision 0083):
   * 0 (default): no bound; else rings_per_vertex to 4096. Since ABI 11. */
  int max_rings_per_vertex;
  /* A budget on the rings a mesh vertex keeps on average (the scene's mesh.mean_rings_per_vertex,
   * decision 0090): 0 (default): none; else up to 4096. Since ABI 11. */
  double mean_rings_per_vertex;
  /* More rings per mesh vertex while the weight it leaves out exceeds this fraction (the scene's
   * mesh.weight_left_out, decision 0048): default 0.02; 0: exactly rings_per_vertex. Since ABI 11. */
  double weight_left_out;
  /* At most this many times the skinning cost of rings_per_vertex rings a mesh vertex (the scene's
   * mesh.skin_cost_limit, decision 0092): 0 (default): no limit; else 1 to 4096. Since ABI 11. */
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
} haustra_segment_def;

/* One segment as the world holds it (haustra_world_segment). */
typedef struct haustra_segment_info {
  const char* name;               /* valid until segments are added or removed, or the world is destroyed */
  size_t node_offset, node_count; /* its nodes in the node buffers; a chain's pieces share their joint node */
  size_t bead_offset, bead_count; /* its beads (a joint node's bead belongs to the later piece) */
  size_t mesh_vertex_offset, mesh_vertex_count; /* its organ mesh's vertices; 0, 0 without one */
  size_t chain;                                 /* the first segment of its chain; itself when not chained */
  double length;                                /* m, at rest */
} haustra_segment_info;

/* The last completed frame, for a render thread (double_buffered worlds). */
typedef struct haustra_frame {
  uint64_t frame;
  double time;
  haustra_vec3_view nodes;
  haustra_vec3f_view mesh_positions;
  haustra_vec3f_view mesh_normals;
} haustra_frame;

/* Version and ABI. */
HAUSTRA_API const char* haustra_version(void);
HAUSTRA_API haustra_status haustra_check_abi(int abi_version);
/* The message of this thread's last failed call ("" after a success). */
HAUSTRA_API const char* haustra_last_error(void);
/* A stage's name ("collide", "solve", ...), or NULL beyond HAUSTRA_STAGE_COUNT. */
HAUSTRA_API const char* haustra_stage_name(int stage);

/* Worlds. threads: 0 for all cores, 1 for the calling thread only, n for n. */
HAUSTRA_API haustra_status haustra_world_create_from_scene(const char* scene_path, int threads, haustra_world** out);
/* The same with run-time settings from `def` (threads, jobs, double_buffered; its other fields are
 * the scene's). def may be NULL: the defaults. */
HAUSTRA_API haustra_status haustra_world_create_from_scene_def(const char* scene_path, const haustra_world_def* def,
                                                               haustra_world** out);
HAUSTRA_API haustra_status haustra_world_def_default(haustra_world_def* def);
HAUSTRA_API haustra_status haustra_segment_def_default(haustra_segment_def* def);
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

/* Buffers, without copies (see Views above). */
HAUSTRA_API haustra_status haustra_world_node_positions(const haustra_world* world, haustra_vec3_view* out);
HAUSTRA_API haustra_status haustra_world_bead_radii(const haustra_world* world, const double** radii, size_t* count);
HAUSTRA_API haustra_status haustra_world_mesh_positions(const haustra_world* world, haustra_vec3f_view* out);
HAUSTRA_API haustra_status haustra_world_mesh_normals(const haustra_world* world, haustra_vec3f_view* out);
HAUSTRA_API haustra_status haustra_world_mesh_triangles(const haustra_world* world, haustra_triangles_view* out);

/* Loads and instruments. A pose or grasp set here hands the instrument from its script to the host. */
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
  double youngs_modulus; /* Pa */
  double poisson_ratio;
  double density;         /* kg/m³ */
  double relaxation_time; /* s: the viscous law's η / E */
} haustra_material;
HAUSTRA_API haustra_status haustra_world_material(const haustra_world* world, size_t segment, haustra_material* out);
HAUSTRA_API haustra_status haustra_world_set_material(haustra_world* world, size_t segment,
                                                      const haustra_material* material);

/* Double-buffered output (worlds created with double_buffered = 1). acquire gives the last
 * completed frame; its views stay valid, and unchanged, until release, however many frames the
 * world steps meanwhile. One acquire at a time; never blocks the stepping thread. */
HAUSTRA_API haustra_status haustra_world_acquire_frame(haustra_world* world, haustra_frame* out);
HAUSTRA_API haustra_status haustra_world_release_frame(haustra_world* world);

/* Checkpoints: the world's state to a file and back. Stepping on from a restore gives the same
 * bits as never having stopped. A checkpoint of another model, or a damaged one, is refused
 * (HAUSTRA_PARSE) and the world is left as it was. Restoring moves the time back or forth. */
HAUSTRA_API haustra_status haustra_world_save_checkpoint(const haustra_world* world, const char* path);
HAUSTRA_API haustra_status haustra_world_restore_checkpoint(haustra_world* world, const char* path);

#ifdef __cplusplus
}
#endif

#endif /* HAUSTRA_H */
