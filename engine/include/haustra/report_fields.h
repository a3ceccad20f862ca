/* The fields of the engine's reports, each listed once (MuJoCo's mjxmacro.h): X(type, name, initial,
 * meaning). The C++ structs declare their fields from these lists (FrameProfile in profile.hpp,
 * ContactReport in world_types.hpp, MemoryEstimate in world.hpp), and every copy of them — the C
 * API, the Python module, the run's summary, checkpoints — is written from them, so a new field is
 * one line here (and, for the profile, its line in haustra.h's haustra_profile, which the C API's
 * copy will not compile without). Plain C: haustra.h's users may read it too. */
#ifndef HAUSTRA_REPORT_FIELDS_H
#define HAUSTRA_REPORT_FIELDS_H

#include <stddef.h>

/* The tables keep one field per line. */
/* clang-format off */
/* The frame's stages in pipeline order, X(name, meaning): the C++ enum Stage (profile.hpp), the
 * stages' names (stage_name, haustra_stage_name, Python's profile) and HAUSTRA_STAGE_COUNT
 * (haustra.h) come from this list. A new stage at the end keeps the C ABI's stage indices. */
#define HAUSTRA_STAGES(X)                                                                           \
  X(instruments, "scripted poses, grasps and releases")                                             \
  X(snapshot, "a substep's start: the strains, poses and bases its drag and potential measure from") \
  X(collide, "beads follow nodes; broad and narrow phase -> contact candidates")                    \
  X(contacts, "penalty forces (and their stiffness) at the current positions")                      \
  X(proxy, "instruments' capsules where their couplings and contacts balance (0096)")               \
  X(loads, "gravity + external loads + contacts -> node forces")                                   \
  X(free_base, "rigid drag of free bases")                                                          \
  X(backward_sweep, "node forces -> generalized forces R")                                          \
  X(condense, "Newton: linearize and condense the system tip -> base (or the banded LU's fallback); a split rod's parts also make their responses here, each in its own task (0087)") \
  X(solve, "lagged: prefactored M and the strain law; Newton: the coupled unknowns' responses (a split rod's: folded with the join's result), multipliers and the step") \
  X(line_search, "Newton: the step's fraction that lowers the frame's incremental potential")       \
  X(constraints, "lagged: attachments, implicit through the Schur complement")                      \
  X(forward_sweep, "strains -> node poses")                                                         \
  X(filter, "inertia filter")                                                                       \
  X(contraction, "lagged: the next step from the new strains, to see that the iteration contracts") \
  X(guard, "finite values and bounds")                                                              \
  X(report, "penetrations, instrument forces and sleeping rods at the frame's end")                  \
  X(cage, "cage rings follow the rod")                                                              \
  X(skin, "the organ meshes follow the rings (rigid-group MVC); a chain's cuts welded")             \
  X(normals, "per-vertex normals of the skinned meshes")

/* How many entries a list has: (0 LIST(HAUSTRA_COUNT_STAGE)) is a constant expression in C. */
#define HAUSTRA_COUNT_STAGE(name, meaning) +1
/* FrameProfile's counters (beside its per-stage times and calls, its frame time and `newton`), in
 * two parts: the C API's haustra_profile declares its fields from them around its `newton` flag, in
 * the order its ABI has had since 15 (a new counter goes at the end of the second part). */
#define HAUSTRA_PROFILE_COUNTERS_BEFORE_NEWTON(X)                                                   \
  X(int, substeps, 1, "substeps the frame was split into")                                          \
  X(int, retries, 0, "frames redone by the robust mode")
#define HAUSTRA_PROFILE_COUNTERS_AFTER_NEWTON(X)                                                    \
  X(int, fallbacks, 0, "Newton iterations solved by the banded LU (the condensed sweep's pivots unsafe)") \
  X(int, backtracks, 0, "line-search halvings")                                                     \
  X(int, stiffenings, 0, "Newton steps solved again with stiffened law rows (the plain step went uphill)") \
  X(int, chords, 0, "fast mode: Newton iterations that reused the last factorization")                   \
  X(int, stalls, 0, "Newton iterations whose line search took no part of a step that was not small (a guard failure)") \
  X(int, iterations, 0, "fixed-point iterations run, summed over substeps")                         \
  X(int, late, 0, "1 when the frame took longer than world.frame_budget (decision 0061)")                 \
  X(int, nodes_asleep, 0, "nodes of the rods and ranges that slept through the frame, held where they were (decisions 0119, 0127)")
#define HAUSTRA_PROFILE_COUNTERS(X) HAUSTRA_PROFILE_COUNTERS_BEFORE_NEWTON(X) HAUSTRA_PROFILE_COUNTERS_AFTER_NEWTON(X)
/* A C struct's field from a list's entry (its meaning is the list's). */
#define HAUSTRA_C_FIELD(type, name, initial, meaning) type name;

/* ContactReport: the contacts at the end of the last frame. */
#define HAUSTRA_CONTACT_FIELDS(X)                                                                   \
  X(size_t, candidates, 0, "pairs and bead-shape pairs within the margin at the frame's start")    \
  X(size_t, touching, 0, "of those, overlapping at its end")                                       \
  X(double, max_environment_depth, 0.0, "m: deepest bead into a plane, obstacle, mesh or instrument") \
  X(double, max_environment_depth_ratio, 0.0, "the same over that bead's radius")                  \
  X(double, max_bead_overlap, 0.0, "m: deepest overlap of two beads that may collide")             \
  X(double, max_bead_overlap_ratio, 0.0, "the same over the smaller radius")

/* MemoryEstimate: what a world of a description will take, in memory and time, before it is built
 * (decisions 0038, 0106). The same numbers through C++, C, Python and `haustra estimate`. */
#define HAUSTRA_MEMORY_FIELDS(X)                                                                    \
  X(size_t, total, 0, "bytes")                                                                      \
  X(size_t, nodes, 0, "rod nodes")                                                                  \
  X(size_t, rod_bytes, 0, "the rods' model and state (and what building them takes)")               \
  X(size_t, solver_bytes, 0, "the Newton solves' workspace")                                        \
  X(size_t, bead_bytes, 0, "beads and their contacts")                                              \
  X(size_t, mesh_bytes, 0, "procedural organ meshes (a mesh file's size is checked as it loads)")   \
  X(size_t, beads, 0, "beads (a count)")                                                            \
  X(size_t, bead_pairs, 0, "pairs of one segment's beads within reach of each other at rest: the broad phase lists them every substep") \
  X(size_t, pair_bytes, 0, "the rest-pose exclusions and the broad phase's lists of those pairs")   \
  X(double, build_seconds, 0.0, "s to build it on one core of the reference machine (procedural meshes included, mesh files not)") \
  X(double, step_seconds, 0.0, "s a frame takes on one core of the reference machine at rest (contacts and the robust mode's retries add to it)")

/* A struct's member declaration from a list's line. */
#define HAUSTRA_DECLARE_FIELD(type, name, initial, meaning) type name = initial;

/* clang-format on */

#endif
