/* A C host of haustra, as a surgical simulator would be: a haptic thread steps the world at 1 kHz
 * of simulated time, moves a grasper down onto the organ, grasps it, lifts it and lets go, and
 * reads the force on the grasper every frame; a render thread wakes 60 times a second and reads
 * the organ's mesh. The world is double-buffered: the render thread acquires the last completed
 * frame and reads it while the haptic thread steps on, neither waiting for the other.
 *
 *   cc haptic_host.c -I$PREFIX/include -L$PREFIX/lib -Wl,-rpath,$PREFIX/lib -lhaustra -lpthread -lm
 *   ./a.out scenes/haptic-host.toml [seconds] [threads]
 *
 * The world has a 1 ms frame budget (deadline mode): the host reports the frames over it and the
 * physics frames' median, p99, p99.9 and max. The render thread's acquire makes the mesh of the
 * frame it takes, in the render thread (the stepping thread publishes the rod and rings only).
 *
 * Before it builds the world the host asks what it will cost (haustra_estimate_scene). Then it adds
 * what its own scene graph holds through the C API alone: a retractor beside the grasper, a
 * neighbouring organ (a sphere), the organ's tip held where it rests (an attachment) and connective
 * tissue under its first fifth (anchors); it takes the retractor out again at 8 s. Every frame it
 * reads the nodes' velocities, the contacts and the events into buffers it allocated up front; at
 * the start, which node each bead sits on and the nodes' frames. Every struct carries its size.
 */
#define _POSIX_C_SOURCE 200809L /* clock_gettime, nanosleep */
#include <haustra/haustra.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

typedef struct Shared {
  pthread_mutex_t lock; /* guards `done` only */
  haustra_world* world;
  int done;
  /* Written by the render thread. */
  long mesh_reads;
  float lowest_vertex;
  int bad_vertices;
} Shared;

static int fail(const char* what, haustra_status s) {
  fprintf(stderr, "%s failed (status %d): %s\n", what, (int)s, haustra_last_error());
  return 1;
}

static double smooth(double a, double b, double s) {
  s = s < 0.0 ? 0.0 : (s > 1.0 ? 1.0 : s);
  s = s * s * (3.0 - 2.0 * s);
  return a + (b - a) * s;
}

static int by_value(const void* a, const void* b) {
  const double x = *(const double*)a, y = *(const double*)b;
  return (x > y) - (x < y);
}

/* The q-quantile of n sorted values. */
static double quantile(const double* sorted, size_t n, double q) {
  size_t i = (size_t)(q * (double)(n - 1) + 0.5);
  return sorted[i < n ? i : n - 1];
}

static void* render_loop(void* arg) {
  Shared* sh = (Shared*)arg;
  const struct timespec frame = {0, 16666667}; /* 60 Hz */
  for (;;) {
    nanosleep(&frame, NULL);
    pthread_mutex_lock(&sh->lock);
    const int done = sh->done;
    pthread_mutex_unlock(&sh->lock);
    if (done) break;
    haustra_frame shown = {.struct_size = sizeof shown};
    if (haustra_world_acquire_frame(sh->world, &shown) == HAUSTRA_OK) {
      float lowest = 1e30f;
      for (size_t v = 0; v < shown.mesh_positions.count; ++v) {
        const float x = shown.mesh_positions.x[v], y = shown.mesh_positions.y[v], z = shown.mesh_positions.z[v];
        if (!isfinite(x) || !isfinite(y) || !isfinite(z)) sh->bad_vertices++;
        if (z < lowest) lowest = z;
      }
      haustra_world_release_frame(sh->world);
      sh->lowest_vertex = lowest;
      sh->mesh_reads++;
    }
  }
  return NULL;
}

int main(int argc, char** argv) {
  const char* scene = argc > 1 ? argv[1] : "scenes/haptic-host.toml";
  const double seconds = argc > 2 ? atof(argv[2]) : 10.0;
  const int threads = argc > 3 ? atoi(argv[3]) : 1;
  haustra_status s = haustra_check_abi(HAUSTRA_ABI_VERSION);
  if (s != HAUSTRA_OK) return fail("haustra_check_abi", s);

  Shared sh = {PTHREAD_MUTEX_INITIALIZER, NULL, 0, 0, 0.0f, 0};
  haustra_world_def def;
  haustra_world_def_default(&def);
  def.threads = threads;   /* 1: the haptic thread steps alone */
  def.double_buffered = 1; /* the render thread reads completed frames */
  def.frame_budget = 1e-3; /* a haptic frame's deadline: frames over it are counted */
  haustra_estimate cost = {.struct_size = sizeof cost};
  s = haustra_estimate_scene(scene, &def, &cost);
  if (s != HAUSTRA_OK) return fail("haustra_estimate_scene", s);
  printf("haustra %s (ABI %d): the world will take about %.1f MB and %.0f us a frame on one core (%.1f GB available)\n",
         haustra_version(), haustra_abi_version(), (double)cost.total / 1e6, 1e6 * cost.step_seconds,
         (double)cost.available / 1e9);
  s = haustra_world_create_from_scene_def(scene, &def, &sh.world);
  if (s != HAUSTRA_OK) return fail("haustra_world_create_from_scene_def", s);

  /* What the host's own scene graph holds, added through the API. */
  haustra_instrument_def retractor;
  haustra_instrument_def_default(&retractor);
  retractor.name = "retractor";
  retractor.radius = 0.006;
  retractor.tip[0] = -0.1;
  retractor.tip[2] = 0.1;
  size_t retractor_index = 0;
  s = haustra_world_add_instrument(sh.world, &retractor, &retractor_index);
  if (s != HAUSTRA_OK) return fail("haustra_world_add_instrument", s);
  haustra_obstacle_def neighbour;
  haustra_obstacle_def_default(&neighbour);
  neighbour.kind = HAUSTRA_OBSTACLE_SPHERE;
  neighbour.name = "bladder";
  neighbour.point[0] = 0.25;
  neighbour.point[1] = 0.09;
  neighbour.point[2] = 0.05;
  neighbour.radius = 0.05;
  s = haustra_world_add_obstacle(sh.world, &neighbour, NULL);
  if (s != HAUSTRA_OK) return fail("haustra_world_add_obstacle", s);
  haustra_attachment_def tip_held;
  haustra_attachment_def_default(&tip_held); /* node -1, where it rests */
  s = haustra_world_add_attachment(sh.world, 0, &tip_held, NULL);
  if (s != HAUSTRA_OK) return fail("haustra_world_add_attachment", s);
  haustra_anchors_def tissue;
  haustra_anchors_def_default(&tissue);
  tissue.name = "mesorectum";
  tissue.to = 0.2;
  tissue.support = 2000.0;
  s = haustra_world_add_anchors(sh.world, 0, &tissue, NULL);
  if (s != HAUSTRA_OK) return fail("haustra_world_add_anchors", s);

  haustra_counts counts = {.struct_size = sizeof counts};
  haustra_world_counts(sh.world, &counts);
  printf("%zu nodes, %zu beads, %zu mesh vertices, %zu instruments, %zu spheres, %zu anchors\n", counts.nodes,
         counts.beads, counts.mesh_vertices, counts.instruments, counts.obstacles[HAUSTRA_OBSTACLE_SPHERE],
         counts.anchors);
  /* Which node each bead sits on, and the nodes' frames: d3 of the first node. */
  const uint32_t* bead_nodes = NULL;
  size_t bead_count = 0;
  haustra_world_bead_nodes(sh.world, &bead_nodes, &bead_count);
  haustra_quat_view frames;
  haustra_world_node_rotations(sh.world, &frames);
  for (size_t b = 0; b < bead_count; ++b)
    if (bead_nodes[b] >= counts.nodes) return fail("haustra_world_bead_nodes: a node out of range", HAUSTRA_INTERNAL);
  printf("beads on nodes %u .. %u; node 0's frame (%.3f, %.3f, %.3f, %.3f)\n", bead_nodes[0],
         bead_nodes[bead_count - 1], frames.w[0], frames.x[0], frames.y[0], frames.z[0]);
  /* The per-frame buffers, allocated once. */
  double* velocities = malloc(3 * counts.nodes * sizeof(double));
  haustra_contact contacts[64];
  contacts[0].struct_size = sizeof(haustra_contact);
  haustra_event events[16];
  events[0].struct_size = sizeof(haustra_event);
  if (velocities == NULL) return 1;
  double fastest = 0.0;
  size_t most_contacts = 0, touching_floor = 0, event_count = 0;
  int removal_tries = 0;

  pthread_t render;
  if (pthread_create(&render, NULL, render_loop, &sh) != 0) return 1;

  /* The grasp target: the middle node as it lies at the start. */
  haustra_vec3_view nodes;
  haustra_world_node_positions(sh.world, &nodes);
  const size_t middle = counts.nodes / 2;
  const double gx = nodes.x[middle], gy = nodes.y[middle], gz = nodes.z[middle] + 0.026;
  const double park[3] = {gx, gy, gz + 0.08}, up[3] = {0.0, 0.0, 1.0};
  double time = 0.0, max_force = 0.0;
  uint64_t frame = 0;
  /* Every physics frame's time, kept before the loop so the loop allocates nothing. */
  const size_t capacity = (size_t)(seconds * 1000.0) + 16;
  double* frame_seconds = malloc(capacity * sizeof(double));
  size_t timed = 0;
  if (frame_seconds == NULL) return 1;
  int grasped_frames = 0, status = 0;
  struct timespec t0, t1;
  clock_gettime(CLOCK_MONOTONIC, &t0);
  while (time < seconds - 1e-9) {
    /* 0–1 s down to the organ, close at 1 s, lift 6 cm by 3 s, hold, open at 7 s, back up. */
    double tip[3] = {gx, gy, gz};
    if (time < 1.0)
      tip[2] = smooth(park[2], gz, time);
    else if (time < 7.0)
      tip[2] = smooth(gz, gz + 0.06, (time - 1.0) / 2.0);
    else
      tip[2] = smooth(gz + 0.06, park[2], (time - 7.0) / 1.0);
    haustra_world_set_instrument_pose(sh.world, 0, tip, up);
    haustra_world_set_instrument_grasp(sh.world, 0, time >= 1.0 && time < 7.0);
    if (time >= 8.0 && retractor_index != 0) { /* the retractor's work is done */
      /* Refused while the render thread holds a frame: tried again at the next frame. */
      s = haustra_world_remove_instrument(sh.world, retractor_index);
      if (s == HAUSTRA_OK)
        retractor_index = 0;
      else if (s != HAUSTRA_INVALID_ARGUMENT || ++removal_tries > 1000) {
        status = fail("haustra_world_remove_instrument", s);
        break;
      }
    }
    s = haustra_world_step(sh.world);
    haustra_instrument_reading r = {.struct_size = sizeof r};
    haustra_world_instrument(sh.world, 0, &r);
    haustra_world_time(sh.world, &time, &frame);
    if (s != HAUSTRA_OK) {
      status = fail("haustra_world_step", s);
      break;
    }
    haustra_profile profile = {.struct_size = sizeof profile};
    haustra_world_profile(sh.world, &profile);
    if (timed < capacity) frame_seconds[timed++] = profile.frame_seconds;
    /* Velocities, contacts and events: what a host's own systems (audio, scoring) read. */
    haustra_world_node_velocities(sh.world, velocities, NULL, 3 * counts.nodes);
    for (size_t k = 0; k < counts.nodes; ++k) {
      const double* v = velocities + 3 * k;
      const double speed = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
      if (speed > fastest) fastest = speed;
    }
    size_t listed = 0, taken = 0;
    haustra_world_contacts(sh.world, contacts, 64, &listed, NULL);
    if (listed > most_contacts) most_contacts = listed;
    for (size_t c = 0; c < listed; ++c)
      if (contacts[c].kind == HAUSTRA_CONTACT_PLANE && contacts[c].depth > 0.0) touching_floor++;
    haustra_world_take_events(sh.world, events, 16, &taken, NULL);
    for (size_t e = 0; e < taken; ++e)
      printf("  event at frame %llu: %s\n", (unsigned long long)events[e].frame, events[e].message);
    event_count += taken;
    const double f = sqrt(r.force[0] * r.force[0] + r.force[1] * r.force[1] + r.force[2] * r.force[2]);
    if (f > max_force) max_force = f;
    grasped_frames += r.grasping;
  }
  clock_gettime(CLOCK_MONOTONIC, &t1);
  pthread_mutex_lock(&sh.lock);
  sh.done = 1;
  pthread_mutex_unlock(&sh.lock);
  pthread_join(render, NULL);

  const double wall = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
  printf("%.3f s simulated in %llu frames, %.2f s wall (%.0f us per frame)\n", time, (unsigned long long)frame, wall,
         1e6 * wall / (double)(frame ? frame : 1));
  printf("grasping for %d frames, largest force on the grasper %.3f N\n", grasped_frames, max_force);
  printf("fastest node %.3f m/s; up to %zu contacts listed a frame, %zu bead-frames on the floor; %zu events\n",
         fastest, most_contacts, touching_floor, event_count);
  printf("render thread: %ld mesh reads, lowest vertex %.4f m, %d non-finite vertices\n", sh.mesh_reads,
         (double)sh.lowest_vertex, sh.bad_vertices);
  uint64_t late = 0;
  haustra_world_late_frames(sh.world, &late);
  if (timed > 0) {
    qsort(frame_seconds, timed, sizeof(double), by_value);
    printf(
        "physics frame (%d threads): median %.0f us, p99 %.0f us, p99.9 %.0f us, max %.0f us; %llu of %zu over the 1 "
        "ms budget\n",
        threads, 1e6 * quantile(frame_seconds, timed, 0.5), 1e6 * quantile(frame_seconds, timed, 0.99),
        1e6 * quantile(frame_seconds, timed, 0.999), 1e6 * frame_seconds[timed - 1], (unsigned long long)late, timed);
  }
  free(frame_seconds);
  free(velocities);
  haustra_counts after = {.struct_size = sizeof after};
  haustra_world_counts(sh.world, &after);
  haustra_world_destroy(sh.world);
  if (status == 0 && (grasped_frames == 0 || sh.mesh_reads == 0 || sh.bad_vertices != 0)) {
    fprintf(stderr, "the host saw no grasp, no mesh read, or a non-finite vertex\n");
    status = 1;
  }
  if (status == 0 && (!(fastest > 0.0) || touching_floor == 0 || after.instruments != 1)) {
    fprintf(stderr, "the host saw no motion, no bead on the floor, or the retractor was not removed\n");
    status = 1;
  }
  return status;
}
