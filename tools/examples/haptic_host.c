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
    haustra_frame shown;
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
  s = haustra_world_create_from_scene_def(scene, &def, &sh.world);
  if (s != HAUSTRA_OK) return fail("haustra_world_create_from_scene_def", s);
  haustra_counts counts;
  haustra_world_counts(sh.world, &counts);
  printf("haustra %s: %zu nodes, %zu beads, %zu mesh vertices\n", haustra_version(), counts.nodes, counts.beads,
         counts.mesh_vertices);

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
    s = haustra_world_step(sh.world);
    haustra_instrument_reading r;
    haustra_world_instrument(sh.world, 0, &r);
    haustra_world_time(sh.world, &time, &frame);
    if (s != HAUSTRA_OK) {
      status = fail("haustra_world_step", s);
      break;
    }
    haustra_profile profile;
    haustra_world_profile(sh.world, &profile);
    if (timed < capacity) frame_seconds[timed++] = profile.frame_seconds;
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
  printf("render thread: %ld mesh reads, lowest vertex %.4f m, %d non-finite vertices\n", sh.mesh_reads,
         (double)sh.lowest_vertex, sh.bad_vertices);
  uint64_t late = 0;
  haustra_world_late_frames(sh.world, &late);
  if (timed > 0) {
    qsort(frame_seconds, timed, sizeof(double), by_value);
    printf("physics frame (%d threads): median %.0f us, p99 %.0f us, p99.9 %.0f us, max %.0f us; %llu of %zu over the 1 ms budget\n",
           threads, 1e6 * quantile(frame_seconds, timed, 0.5), 1e6 * quantile(frame_seconds, timed, 0.99),
           1e6 * quantile(frame_seconds, timed, 0.999), 1e6 * frame_seconds[timed - 1], (unsigned long long)late,
           timed);
  }
  free(frame_seconds);
  haustra_world_destroy(sh.world);
  if (status == 0 && (grasped_frames == 0 || sh.mesh_reads == 0 || sh.bad_vertices != 0)) {
    fprintf(stderr, "the host saw no grasp, no mesh read, or a non-finite vertex\n");
    status = 1;
  }
  return status;
}
