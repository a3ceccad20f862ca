// What a game-engine host relies on through the C API (issue 36): inputs that once crashed it
// refused on a worker thread of 1 MiB of stack, checkpoints that keep what the setters changed,
// one thread at a time on a world, a frame's cost capped and its events read.
#include <doctest/doctest.h>
#include <haustra/haustra.h>

#include <pthread.h>
#include <sys/stat.h>
#include <unistd.h>
#include "c_sized.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>
#include <thread>
#include <vector>

#include "lockstep_jobs.hpp"

namespace {

// A folder of this process's own, with the files a case writes.
struct Folder {
  std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("haustra-c-hosts-" + std::to_string(::getpid()));
  Folder() { std::filesystem::create_directories(dir); }
  ~Folder() { std::filesystem::remove_all(dir); }
  Folder(const Folder&) = delete;
  Folder& operator=(const Folder&) = delete;
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(dir / name, std::ios::binary) << text;
    return (dir / name).string();
  }
};

std::string nested(const std::string& open, const std::string& close, int levels) {
  std::string text;
  for (int i = 0; i < levels; ++i) text += open;
  for (int i = 0; i < levels; ++i) text += close;
  return text;
}

// What a call returned on the thread that made it: its status and that thread's message.
struct Outcome {
  haustra_status status = HAUSTRA_INTERNAL;
  std::string message;
};

// Runs fn on a thread with `stack` bytes of stack, as a host's worker thread would, and waits.
void on_thread_with_stack(const std::function<void()>& fn, std::size_t stack) {
  pthread_attr_t attr;
  REQUIRE(pthread_attr_init(&attr) == 0);
  REQUIRE(pthread_attr_setstacksize(&attr, stack) == 0);
  pthread_t thread;
  auto run = [](void* f) -> void* {
    (*static_cast<const std::function<void()>*>(f))();
    return nullptr;
  };
  REQUIRE(pthread_create(&thread, &attr, run, const_cast<std::function<void()>*>(&fn)) == 0);
  pthread_join(thread, nullptr);
  pthread_attr_destroy(&attr);
}

// A world from a scene file on a 1 MiB thread: the outcome, and the world destroyed if made.
Outcome create_on_small_stack(const std::string& scene) {
  Outcome o;
  on_thread_with_stack(
      [&] {
        haustra_world* w = nullptr;
        o.status = haustra_world_create_from_scene(scene.c_str(), 1, &w);
        o.message = haustra_last_error();
        if (o.status == HAUSTRA_OK) {
          o.status = haustra_world_step(w);
          haustra_world_destroy(w);
        }
      },
      std::size_t{1} << 20);
  return o;
}

}  // namespace

TEST_CASE("C API on a host thread of 1 MiB of stack: deep, endless and blocking inputs are refused, not fatal") {
  const Folder f;
  const std::string segment = "[[segment]]\nnodes = 21\n[segment.beads]\ncount = 11\n";
  struct Case {
    std::string scene;
    haustra_status status;
    std::vector<std::string> words;
  };
  const std::vector<Case> cases = {
      {f.write("header.toml", "[" + nested("a.", "", 100'000) + "a]\n"),
       HAUSTRA_INVALID_ARGUMENT,
       {"header.toml:1:1", "nests more than 64 levels"}},  // 200 KB
      {f.write("arrays.toml", "x = " + nested("[", "]", 5'000) + "\n"),
       HAUSTRA_INVALID_ARGUMENT,
       {"arrays.toml:1:68", "nests more than 64"}},  // 10 KB
      {f.write("centreline.toml",
               "[[segment]]\nnodes = 21\n[segment.rest]\nshape = \"centreline\"\nfile = \"deep.json\"\n"),
       HAUSTRA_INVALID_ARGUMENT,
       {"centreline.toml:5", "deep.json:1:", "nests more than 64"}},
      {f.write("mesh.toml", segment + "[segment.mesh]\nfile = \"deep.gltf\"\n"),
       HAUSTRA_INVALID_ARGUMENT,
       {"mesh.toml:6", "deep.gltf:1:", "nests more than 64"}},
      {"/dev/zero", HAUSTRA_IO, {"/dev/zero: a character device, not a scene file"}},
      {(f.dir / "pipe.toml").string(), HAUSTRA_IO, {"pipe.toml: a FIFO (named pipe), not a scene file"}},
      {f.dir.string(), HAUSTRA_IO, {"a folder, not a scene file"}},
  };
  f.write("deep.json", "{\"units\": \"m\", \"points\": " + nested("[", "]", 20'000) + "}");  // 40 KB
  f.write("deep.gltf", "{\"asset\": {\"version\": \"2.0\"}, \"extras\": " + nested("[", "]", 20'000) + "}");
  REQUIRE(::mkfifo((f.dir / "pipe.toml").c_str(), 0600) == 0);
  for (const Case& c : cases) {
    INFO(c.scene);
    const Outcome o = create_on_small_stack(c.scene);
    INFO(o.message);
    CHECK(o.status == c.status);
    for (const std::string& w : c.words) CHECK_MESSAGE(o.message.find(w) != std::string::npos, "missing: " << w);
  }
  // A good scene builds and steps on the same thread.
  const Outcome good = create_on_small_stack(std::string(HAUSTRA_SOURCE_DIR) + "/tests/scenes/c-api-colon.toml");
  INFO(good.message);
  CHECK(good.status == HAUSTRA_OK);
}

namespace {

const std::string kTwoSegments = std::string(HAUSTRA_SOURCE_DIR) + "/tests/scenes/c-api-two-segments.toml";

// Node positions as bits.
std::vector<double> nodes(const haustra_world* w) {
  haustra_vec3_view v{};
  REQUIRE(haustra_world_node_positions(w, &v) == HAUSTRA_OK);
  std::vector<double> out(v.x, v.x + v.count);
  out.insert(out.end(), v.y, v.y + v.count);
  out.insert(out.end(), v.z, v.z + v.count);
  return out;
}

Outcome outcome(haustra_status status) { return {status, haustra_last_error()}; }

}  // namespace

TEST_CASE("C API, one thread at a time: calls from another thread during a step return HAUSTRA_BUSY, change nothing") {
  LockstepJobs jobs;
  haustra_world_def def;
  REQUIRE(haustra_world_def_default(&def) == HAUSTRA_OK);
  def.jobs = haustra_job_system{&LockstepJobs::enqueue, &LockstepJobs::wait, &jobs, 2};
  haustra_world* w = nullptr;
  haustra_world* reference = nullptr;
  REQUIRE(haustra_world_create_from_scene_def(kTwoSegments.c_str(), &def, &w) == HAUSTRA_OK);
  REQUIRE(haustra_world_create_from_scene(kTwoSegments.c_str(), 1, &reference) == HAUSTRA_OK);
  Outcome inside;
  std::vector<Outcome> other_thread;
  jobs.arm([&] { inside = outcome(haustra_world_step(w)); });  // the host's callback, on the stepping thread
  std::thread other([&] {
    jobs.while_stepping([&] {
      const double g[3] = {0.0, 0.0, -1.0};
      haustra_vec3_view v{};
      other_thread.push_back(outcome(haustra_world_step(w)));
      other_thread.push_back(outcome(haustra_world_set_gravity(w, g)));
      other_thread.push_back(outcome(haustra_world_node_positions(w, &v)));
      other_thread.push_back(outcome(haustra_world_destroy(w)));
      CHECK(v.x == nullptr);  // a refused call writes nothing
    });
  });
  REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  jobs.stepped();
  other.join();
  CHECK(inside.status == HAUSTRA_BUSY);
  CHECK(inside.message ==
        "haustra_world_step: called from inside a step of this world (a job system's callback?): the "
        "world takes calls again once its step returns");
  REQUIRE(other_thread.size() == 4);
  for (const Outcome& o : other_thread) {
    INFO(o.message);
    CHECK(o.status == HAUSTRA_BUSY);
    CHECK(o.message.find(": the world is in use by another thread") != std::string::npos);
  }
  CHECK(other_thread[0].message.find("haustra_world_step: ") == 0);
  CHECK(other_thread[3].message.find("haustra_world_destroy: ") == 0);
  // The world was neither changed nor destroyed: it steps on as one never disturbed.
  for (int f = 0; f < 6; ++f) {
    REQUIRE(haustra_world_step(reference) == HAUSTRA_OK);
    if (f > 0) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  }
  CHECK(nodes(w) == nodes(reference));
  CHECK(haustra_world_destroy(w) == HAUSTRA_OK);
  CHECK(haustra_world_destroy(reference) == HAUSTRA_OK);
}

TEST_CASE("C API: a checkpoint keeps gravity, dt, the material and the frame limits set before the save") {
  const std::string file =
      (std::filesystem::temp_directory_path() / ("haustra-c-hosts-" + std::to_string(::getpid()) + ".ckpt")).string();
  haustra_world* w = nullptr;
  REQUIRE(haustra_world_create_from_scene(kTwoSegments.c_str(), 1, &w) == HAUSTRA_OK);
  for (int f = 0; f < 5; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  const double gravity[3] = {0.5, 0.0, -6.0}, other_gravity[3] = {0.0, 1.0, -2.0};
  haustra_material m = sized<haustra_material>();
  REQUIRE(haustra_world_material(w, 1, &m) == HAUSTRA_OK);
  haustra_material stiffer = m, softer = m;
  stiffer.youngs_modulus *= 2.0;
  softer.relaxation_time = 0.25;
  const haustra_frame_limits limits{sizeof(haustra_frame_limits), 8, 2, 40},
      other_limits{sizeof(haustra_frame_limits), 64, 16, 120};
  REQUIRE(haustra_world_set_gravity(w, gravity) == HAUSTRA_OK);
  REQUIRE(haustra_world_set_dt(w, 0.005) == HAUSTRA_OK);
  REQUIRE(haustra_world_set_material(w, 1, &stiffer) == HAUSTRA_OK);
  REQUIRE(haustra_world_set_frame_limits(w, &limits) == HAUSTRA_OK);
  for (int f = 0; f < 5; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  REQUIRE(haustra_world_save_checkpoint(w, file.c_str()) == HAUSTRA_OK);
  for (int f = 0; f < 8; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
  const std::vector<double> uninterrupted = nodes(w);
  // A fresh world with other values set, and the first world changed after the save.
  haustra_world* fresh = nullptr;
  REQUIRE(haustra_world_create_from_scene(kTwoSegments.c_str(), 1, &fresh) == HAUSTRA_OK);
  for (haustra_world* x : {fresh, w}) {
    REQUIRE(haustra_world_set_gravity(x, other_gravity) == HAUSTRA_OK);
    REQUIRE(haustra_world_set_dt(x, 0.02) == HAUSTRA_OK);
    REQUIRE(haustra_world_set_material(x, 1, &softer) == HAUSTRA_OK);
    REQUIRE(haustra_world_set_frame_limits(x, &other_limits) == HAUSTRA_OK);
    REQUIRE(haustra_world_restore_checkpoint(x, file.c_str()) == HAUSTRA_OK);
    double dt = 0.0, g[3] = {};
    haustra_material read = sized<haustra_material>();
    haustra_frame_limits l = sized<haustra_frame_limits>();
    REQUIRE(haustra_world_dt(x, &dt) == HAUSTRA_OK);
    REQUIRE(haustra_world_gravity(x, g) == HAUSTRA_OK);
    REQUIRE(haustra_world_material(x, 1, &read) == HAUSTRA_OK);
    REQUIRE(haustra_world_frame_limits(x, &l) == HAUSTRA_OK);
    CHECK(dt == 0.005);
    CHECK(g[0] == 0.5);
    CHECK(read.youngs_modulus == stiffer.youngs_modulus);
    CHECK(read.relaxation_time == stiffer.relaxation_time);
    CHECK(l.max_substeps == 8);
    CHECK(l.max_retries == 2);
    CHECK(l.calm_frames == 40);
    for (int f = 0; f < 8; ++f) REQUIRE(haustra_world_step(x) == HAUSTRA_OK);
    CHECK(nodes(x) == uninterrupted);
  }
  CHECK(haustra_world_destroy(fresh) == HAUSTRA_OK);
  CHECK(haustra_world_destroy(w) == HAUSTRA_OK);
  std::filesystem::remove(file);
}

// Decision 0119 through the C API (ABI 17's def.sleep): a rod at rest (no gravity) sleeps after
// sleep_time, every node; without sleep none does.
TEST_CASE("C API: def.sleep puts a rod at rest to sleep, off by default") {
  auto asleep_after = [](int sleep) {
    haustra_world_def def;
    REQUIRE(haustra_world_def_default(&def) == HAUSTRA_OK);
    CHECK(def.sleep == 0);
    CHECK(def.sleep_speed == 1e-3);
    CHECK(def.sleep_time == 0.1);
    def.sleep = sleep;
    def.threads = 1;
    def.gravity[2] = 0.0;
    haustra_segment_def seg;
    REQUIRE(haustra_segment_def_default(&seg) == HAUSTRA_OK);
    seg.nodes = 21;
    seg.length = 0.3;
    haustra_world* w = nullptr;
    REQUIRE(haustra_world_create(&def, &seg, 1, &w) == HAUSTRA_OK);
    for (int f = 0; f < 12; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);  // 0.2 s at 60 Hz
    haustra_profile p;
    p.struct_size = sizeof p;
    REQUIRE(haustra_world_profile(w, &p) == HAUSTRA_OK);
    haustra_world_destroy(w);
    return p.nodes_asleep;
  };
  CHECK(asleep_after(1) == 21);
  CHECK(asleep_after(0) == 0);
}

TEST_CASE("C API: a scene's world takes the def's dt, gravity and limits when changed, the scene's otherwise") {
  haustra_world_def def;
  REQUIRE(haustra_world_def_default(&def) == HAUSTRA_OK);
  CHECK(def.max_substeps == 64);
  CHECK(def.max_retries == 16);
  CHECK(def.calm_frames == 120);
  haustra_world* kept = nullptr;
  REQUIRE(haustra_world_create_from_scene_def(kTwoSegments.c_str(), &def, &kept) == HAUSTRA_OK);
  double dt = 0.0, g[3] = {};
  REQUIRE(haustra_world_dt(kept, &dt) == HAUSTRA_OK);
  CHECK(dt == 0.01);  // the scene's
  def.dt = 0.004;
  def.gravity[0] = 1.0;
  def.max_retries = 3;
  haustra_world* honoured = nullptr;
  REQUIRE(haustra_world_create_from_scene_def(kTwoSegments.c_str(), &def, &honoured) == HAUSTRA_OK);
  haustra_frame_limits l = sized<haustra_frame_limits>();
  REQUIRE(haustra_world_dt(honoured, &dt) == HAUSTRA_OK);
  REQUIRE(haustra_world_gravity(honoured, g) == HAUSTRA_OK);
  REQUIRE(haustra_world_frame_limits(honoured, &l) == HAUSTRA_OK);
  CHECK(dt == 0.004);
  CHECK(g[0] == 1.0);
  CHECK(g[2] == -9.81);
  CHECK(l.max_retries == 3);
  CHECK(l.max_substeps == 64);
  def.dt = 5e-324;  // refused with the field, not accepted and then failing every step
  haustra_world* refused = nullptr;
  CHECK(haustra_world_create_from_scene_def(kTwoSegments.c_str(), &def, &refused) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(std::string(haustra_last_error()).find("world.dt") != std::string::npos);
  CHECK(std::string(haustra_last_error()).find("below the plausible minimum 1e-06 s") != std::string::npos);
  CHECK(refused == nullptr);
  CHECK(haustra_world_destroy(kept) == HAUSTRA_OK);
  CHECK(haustra_world_destroy(honoured) == HAUSTRA_OK);
}

TEST_CASE("C API: flags are 0 or 1, a NaN drag and out-of-range loads and values are refused up front") {
  haustra_world_def def;
  REQUIRE(haustra_world_def_default(&def) == HAUSTRA_OK);
  haustra_segment_def seg;
  REQUIRE(haustra_segment_def_default(&seg) == HAUSTRA_OK);
  seg.nodes = 21;
  seg.length = 0.5;
  haustra_world* w = nullptr;
  struct Refused {
    std::function<void(haustra_world_def&, haustra_segment_def&)> change;
    std::string words;
  };
  const std::vector<Refused> cases = {
      {[](auto&, auto& s) { s.drag = std::nan(""); }, "segments[0].drag = nan: expected a drag"},
      {[](auto&, auto& s) { s.free_base = 2; }, "segments[0].free_base = 2: expected 0 or 1"},
      {[](auto& d, auto&) { d.floor = -1; }, "def.floor = -1: expected 0 or 1"},
      {[](auto& d, auto&) { d.floor_height = 0.3; }, "def.floor_height = 0.3: set with def.floor = 0"},
      {[](auto& d, auto&) { d.recover = 7; }, "def.recover = 7: expected 0 or 1"},
      {[](auto& d, auto&) { d.double_buffered = 2; }, "def.double_buffered = 2"},
      {[](auto& d, auto&) {
         d.floor = 1;
         d.floor_height = 1e300;
       },
       "environment.plane[0].point"},
      {[](auto&, auto& s) { s.youngs_modulus = 1e-300; },
       "segment[0].youngs_modulus: 1e-300 Pa is below the plausible minimum 1 Pa"},
      {[](auto&, auto& s) { s.length = 1e-300; }, "segment[0].rest.length"},
      {[](auto& d, auto&) { d.max_retries = 65; }, "solver.max_retries"},
      {[](auto& d, auto&) { d.sleep = 3; }, "def.sleep = 3: expected 0 (off), 1 (rods) or 2"},
      {[](auto& d, auto&) {
         d.sleep = 2;
         d.newton = 0;
       },
       "sleep.ranges: needs solver.mode"},
      {[](auto& d, auto&) { d.sleep_speed = -1.0; }, "sleep.speed"},
      {[](auto& d, auto&) { d.sleep_time = 1e9; }, "sleep.time"},
  };
  for (const Refused& c : cases) {
    haustra_world_def d = def;
    haustra_segment_def s = seg;
    c.change(d, s);
    CHECK(haustra_world_create(&d, &s, 1, &w) == HAUSTRA_INVALID_ARGUMENT);
    INFO(haustra_last_error());
    CHECK(std::string(haustra_last_error()).find(c.words) != std::string::npos);
    CHECK(w == nullptr);
  }
  REQUIRE(haustra_world_create(&def, &seg, 1, &w) == HAUSTRA_OK);
  const double huge[3] = {0.0, 0.0, 1e30}, none[3] = {0.0, 0.0, 0.0};
  CHECK(haustra_world_set_node_load(w, 5, huge, none) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(std::string(haustra_last_error()).find("within ±100000 in each component") != std::string::npos);
  CHECK(haustra_world_set_instrument_grasp(w, 0, 2) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(std::string(haustra_last_error()).find("closed = 2: expected 0 or 1") != std::string::npos);
  const haustra_frame_limits below_substeps{sizeof(haustra_frame_limits), 0, 1, 1};
  CHECK(haustra_world_set_frame_limits(w, &below_substeps) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(std::string(haustra_last_error()).find("solver.max_substeps") != std::string::npos);
  CHECK(haustra_world_step(w) == HAUSTRA_OK);
  CHECK(haustra_world_destroy(w) == HAUSTRA_OK);
}

namespace {

// The colon of tests/scenes/c-api-colon.toml (clamped at the origin, lying along +x), stepped by the
// lagged scheme, its middle node (10) held by the rigid grasper; the host then moves the jaws along
// the colon's axis by a chosen distance in one frame. The grasp's target is where the jaws are for
// the whole frame, so the frame must close the jump within its iterations: Newton's 8 a substep
// (solver.max_iterations; with 16 the distances below double, measured) close about 15 cm of it.
// The rung a single jump needs grows with it (measured in 2.5 cm steps): the lagged scheme holds up
// to 2.5 cm, Newton with 1 substep to 15 cm, 2 to 30, 4 to 60 (8 at 62.5; from 65 cm the colon
// stretches past its axial strain limit on every rung). Measured on two builds whose rod sweeps
// differ in their last bits, every count below is the same on both for a first jump of 8 to 12 cm
// with a second of 34 to 48 cm (a second of 32 cm needs only 2 substeps after a first of 8 cm).
struct GraspedColon {
  static constexpr double kFirstJump = 0.10;   // m: the lagged scheme misses, Newton holds
  static constexpr double kSecondJump = 0.40;  // m, 3 frames later: Newton needs 4 substeps
  haustra_world* world(const haustra_frame_limits* limits) const {
    haustra_world_def def;
    REQUIRE(haustra_world_def_default(&def) == HAUSTRA_OK);
    def.threads = 1;
    def.newton = 0;
    haustra_world* w = nullptr;
    REQUIRE(haustra_world_create_from_scene_def(
                (std::string(HAUSTRA_SOURCE_DIR) + "/tests/scenes/c-api-colon.toml").c_str(), &def, &w) == HAUSTRA_OK);
    if (limits != nullptr) REQUIRE(haustra_world_set_frame_limits(w, limits) == HAUSTRA_OK);
    for (int f = 0; f < 3; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
    haustra_vec3_view v{};
    REQUIRE(haustra_world_node_positions(w, &v) == HAUSTRA_OK);
    tip_[0] = v.x[10];
    tip_[1] = v.y[10];
    tip_[2] = v.z[10] + 0.03;
    REQUIRE(haustra_world_set_instrument_pose(w, 0, tip_, kUp) == HAUSTRA_OK);
    REQUIRE(haustra_world_set_instrument_grasp(w, 0, 1) == HAUSTRA_OK);
    for (int f = 0; f < 5; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);  // frames 0 to 7
    haustra_instrument_reading r = sized<haustra_instrument_reading>();
    REQUIRE(haustra_world_instrument(w, 0, &r) == HAUSTRA_OK);
    REQUIRE(r.grasping == 1);
    return w;
  }
  // The jaws `dx` further along the colon, from the next frame on.
  void jump(haustra_world* w, double dx) const {
    tip_[0] += dx;
    REQUIRE(haustra_world_set_instrument_pose(w, 0, tip_, kUp) == HAUSTRA_OK);
  }

 private:
  static constexpr double kUp[3] = {0.0, 0.0, 1.0};
  mutable double tip_[3] = {0.0, 0.0, 0.0};
};

// Frames run, how many ran above one substep, the most substeps and retries any took, the refused.
struct Costs {
  int slow = 0, most_substeps = 0, most_retries = 0, unstable = 0;
};

Costs step_and_count(haustra_world* w, int frames) {
  Costs c;
  for (int f = 0; f < frames; ++f) {
    const haustra_status s = haustra_world_step(w);
    REQUIRE((s == HAUSTRA_OK || s == HAUSTRA_UNSTABLE));
    haustra_profile p = sized<haustra_profile>();
    REQUIRE(haustra_world_profile(w, &p) == HAUSTRA_OK);
    c.slow += p.substeps > 1 ? 1 : 0;
    c.most_substeps = std::max(c.most_substeps, p.substeps);
    c.most_retries = std::max(c.most_retries, p.retries);
    c.unstable += s == HAUSTRA_UNSTABLE ? 1 : 0;
  }
  return c;
}

}  // namespace

TEST_CASE(
    "C API: a frame's cost is bounded by the host's limits, a frame refused by them is an event naming the limit") {
  const GraspedColon colon;
  // Frame 8: the first jump (the lagged scheme's frame is lost, Newton takes over); frame 11: the
  // second (Newton climbs to 4 substeps); then `frames` more.
  auto jumps = [&](haustra_world* w, int frames) {
    colon.jump(w, GraspedColon::kFirstJump);
    Costs c = step_and_count(w, 3);
    colon.jump(w, GraspedColon::kSecondJump);
    const Costs after = step_and_count(w, frames);
    c.slow += after.slow;
    c.most_substeps = std::max(c.most_substeps, after.most_substeps);
    c.most_retries = std::max(c.most_retries, after.most_retries);
    c.unstable += after.unstable;
    return c;
  };
  SUBCASE("the defaults: Newton with 4 substeps, and a spell of 16 frames at each rung after it") {
    haustra_world* w = colon.world(nullptr);
    const Costs c = jumps(w, 57);
    CHECK(c.unstable == 0);
    CHECK(c.most_substeps == 4);
    CHECK(c.most_retries == 2);  // Newton with 1, then 2 substeps missed the grasp at frame 11
    // Frames 11 to 43: the rung climbed 3 frames after the last, so its spell doubles from 8 to 16
    // frames at each of 4 and 2 substeps (1 + 16 + 16; 120 frames each before decision 0109).
    CHECK(c.slow == 33);
    haustra_event events[4];
    events[0].struct_size = sizeof(haustra_event);
    size_t n = 0;
    uint64_t dropped = 1;
    REQUIRE(haustra_world_take_events(w, events, 4, &n, &dropped) == HAUSTRA_OK);
    REQUIRE(n == 2);
    CHECK(dropped == 0);
    CHECK(events[0].kind == HAUSTRA_EVENT_RECOVERED);
    CHECK(events[0].frame == 8);
    CHECK(std::string(events[0].message).find("redone with Newton and 1 substep") != std::string::npos);
    CHECK(events[1].kind == HAUSTRA_EVENT_RECOVERED);
    CHECK(events[1].frame == 11);
    CHECK(events[1].substeps == 4);
    CHECK(std::string(events[1].message).find("attachment's distance from its target") != std::string::npos);
    CHECK(std::string(events[1].message).find("redone with Newton and 4 substeps") != std::string::npos);
    CHECK(std::string(haustra_stage_name(events[1].stage)) == "constraints");
    REQUIRE(haustra_world_take_events(w, events, 4, &n, nullptr) == HAUSTRA_OK);
    CHECK(n == 0);  // taken: the queue is empty
    CHECK(haustra_world_destroy(w) == HAUSTRA_OK);
  }
  SUBCASE("calm_frames = 10: the slow frames after the recovery are at most 10 per halving") {
    const haustra_frame_limits limits{sizeof(haustra_frame_limits), 64, 16, 10};
    haustra_world* w = colon.world(&limits);
    const Costs c = jumps(w, 57);
    CHECK(c.unstable == 0);
    CHECK(c.most_substeps == 4);
    CHECK(c.slow == 21);  // 11 at 4 substeps (the recovery and 10 calm), 10 at 2
    CHECK(c.slow <= 10 * 2 + 1);
    CHECK(haustra_world_destroy(w) == HAUSTRA_OK);
  }
  SUBCASE("one failure after a long calm: the settling pile's first touch costs 9 slow frames, not 120") {
    // scenes/settling-pile.toml: the 6 m small intestine let fall onto a floor without drag; its
    // first frame's line search finds no progress and the frame is redone with 2 substeps.
    haustra_world* w = nullptr;
    REQUIRE(haustra_world_create_from_scene((std::string(HAUSTRA_SOURCE_DIR) + "/scenes/settling-pile.toml").c_str(), 1,
                                            &w) == HAUSTRA_OK);
    const Costs c = step_and_count(w, 40);
    CHECK(c.unstable == 0);
    CHECK(c.most_substeps == 2);
    CHECK(c.slow == 1 + 8);  // the redone frame and its first calm spell
    CHECK(haustra_world_destroy(w) == HAUSTRA_OK);
  }
  SUBCASE("max_substeps = 8, max_retries = 1: the frame is refused when its retries run out, and says so") {
    const haustra_frame_limits limits{sizeof(haustra_frame_limits), 8, 1, 20};
    haustra_world* w = colon.world(&limits);
    const Costs c = jumps(w, 4);
    CHECK(c.most_retries == 1);
    CHECK(c.most_substeps == 2);
    // Frames 11 to 14: Newton with 2 substeps misses the grasp and no retry is left; the world keeps
    // its last good frame, so each next frame is the same refused one until the host changes course.
    CHECK(c.unstable == 4);
    haustra_event events[8];
    events[0].struct_size = sizeof(haustra_event);
    size_t n = 0;
    REQUIRE(haustra_world_take_events(w, events, 8, &n, nullptr) == HAUSTRA_OK);
    REQUIRE(n == 5);  // the recovery at frame 8, then one a refused frame
    CHECK(events[1].kind == HAUSTRA_EVENT_UNSTABLE);
    CHECK(events[1].frame == 11);
    CHECK(std::string(events[1].message)
              .find("The frame's retries ran out (1 of solver.max_retries = 1) before "
                    "Newton with 8 substeps (solver.max_substeps) was tried") != std::string::npos);
    // Given what it needs, the world steps on from its last good frame, at the rung the jump needs.
    const haustra_frame_limits enough{sizeof(haustra_frame_limits), 8, 16, 20};
    REQUIRE(haustra_world_set_frame_limits(w, &enough) == HAUSTRA_OK);
    CHECK(haustra_world_step(w) == HAUSTRA_OK);
    haustra_profile p = sized<haustra_profile>();
    REQUIRE(haustra_world_profile(w, &p) == HAUSTRA_OK);
    CHECK(p.substeps == 4);
    CHECK(haustra_world_destroy(w) == HAUSTRA_OK);
  }
  SUBCASE("max_substeps = 2: the ladder's top is lower, the event says it did not recover there") {
    const haustra_frame_limits limits{sizeof(haustra_frame_limits), 2, 16, 20};
    haustra_world* w = colon.world(&limits);
    const Costs c = jumps(w, 2);
    CHECK(c.most_substeps == 2);
    CHECK(c.unstable == 2);  // frames 11 and 12
    haustra_event events[8];
    events[0].struct_size = sizeof(haustra_event);
    size_t n = 0;
    REQUIRE(haustra_world_take_events(w, events, 8, &n, nullptr) == HAUSTRA_OK);
    REQUIRE(n == 3);
    CHECK(events[2].kind == HAUSTRA_EVENT_UNSTABLE);
    CHECK(std::string(events[2].message).find("Newton with 2 substeps (solver.max_substeps) did not recover either") !=
          std::string::npos);
    const haustra_frame_limits enough{sizeof(haustra_frame_limits), 8, 16, 20};
    REQUIRE(haustra_world_set_frame_limits(w, &enough) == HAUSTRA_OK);
    CHECK(haustra_world_step(w) == HAUSTRA_OK);
    CHECK(haustra_world_destroy(w) == HAUSTRA_OK);
  }
}

TEST_CASE(
    "C API: a failed grasp's frames cost at most the host's limits, each refused frame an event, none slow once "
    "the jaws open") {
  // Issue 36: after a grasp failed in a host's scene, frames ran at up to 32 substeps for ten
  // seconds. Here a rigid grasp (tests/scenes/c-api-colon.toml) is yanked 42 cm in one frame: no
  // rung of the robust mode holds the colon, so every frame is refused until the host opens the
  // jaws. Its cost per frame is what the limits allow: with the defaults up to 64 substeps after 6
  // retries, with the host's {8, 2, 20} at most 4 substeps after 2.
  struct Run {
    int refused = 0, most_substeps = 0, most_retries = 0, slow_after_release = 0;
    size_t unstable_events = 0;
  };
  auto yank = [](const haustra_frame_limits* limits) {
    haustra_world_def def;
    REQUIRE(haustra_world_def_default(&def) == HAUSTRA_OK);
    def.threads = 1;
    haustra_world* w = nullptr;
    REQUIRE(haustra_world_create_from_scene_def(
                (std::string(HAUSTRA_SOURCE_DIR) + "/tests/scenes/c-api-colon.toml").c_str(), &def, &w) == HAUSTRA_OK);
    if (limits != nullptr) REQUIRE(haustra_world_set_frame_limits(w, limits) == HAUSTRA_OK);
    for (int f = 0; f < 3; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
    haustra_vec3_view v{};
    REQUIRE(haustra_world_node_positions(w, &v) == HAUSTRA_OK);
    double tip[3] = {v.x[10], v.y[10], v.z[10] + 0.03};
    const double up[3] = {0.0, 0.0, 1.0};
    REQUIRE(haustra_world_set_instrument_pose(w, 0, tip, up) == HAUSTRA_OK);
    REQUIRE(haustra_world_set_instrument_grasp(w, 0, 1) == HAUSTRA_OK);
    for (int f = 0; f < 5; ++f) REQUIRE(haustra_world_step(w) == HAUSTRA_OK);
    haustra_instrument_reading r = sized<haustra_instrument_reading>();
    REQUIRE(haustra_world_instrument(w, 0, &r) == HAUSTRA_OK);
    REQUIRE(r.grasping == 1);
    tip[0] += 0.3;
    tip[2] += 0.3;
    REQUIRE(haustra_world_set_instrument_pose(w, 0, tip, up) == HAUSTRA_OK);
    Run run;
    for (int f = 0; f < 60; ++f) {
      if (f == 21) REQUIRE(haustra_world_set_instrument_grasp(w, 0, 0) == HAUSTRA_OK);
      const haustra_status s = haustra_world_step(w);
      REQUIRE((s == HAUSTRA_OK || s == HAUSTRA_UNSTABLE));
      haustra_profile p = sized<haustra_profile>();
      REQUIRE(haustra_world_profile(w, &p) == HAUSTRA_OK);
      run.refused += s == HAUSTRA_UNSTABLE ? 1 : 0;
      run.most_substeps = std::max(run.most_substeps, p.substeps);
      run.most_retries = std::max(run.most_retries, p.retries);
      if (f > 21) run.slow_after_release += p.substeps > 1 ? 1 : 0;
    }
    std::vector<haustra_event> events(64);
    events[0].struct_size = sizeof(haustra_event);
    size_t n = 0;
    REQUIRE(haustra_world_take_events(w, events.data(), events.size(), &n, nullptr) == HAUSTRA_OK);
    for (size_t e = 0; e < n; ++e) run.unstable_events += events[e].kind == HAUSTRA_EVENT_UNSTABLE ? 1 : 0;
    CHECK(haustra_world_destroy(w) == HAUSTRA_OK);
    return run;
  };
  const Run defaults = yank(nullptr);
  CHECK(defaults.refused == 21);
  CHECK(defaults.most_substeps == 64);
  CHECK(defaults.most_retries == 6);
  const haustra_frame_limits limits{sizeof(haustra_frame_limits), 8, 2, 20};
  const Run limited = yank(&limits);
  CHECK(limited.refused == 21);
  CHECK(limited.most_substeps == 4);
  CHECK(limited.most_retries == 2);
  CHECK(limited.unstable_events == 21);  // one a refused frame, in the queue for the host
  CHECK(limited.slow_after_release == 0);
  CHECK(defaults.slow_after_release == 0);
}
