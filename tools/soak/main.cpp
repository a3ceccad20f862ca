// haustra_soak: a long run that must stay healthy. Steps a scene (by default `drop`, the rectum on
// the floor) while a host-driven grasper repeats a grasp-and-release cycle on it — approach the
// middle bead, close, lift, hold, open, back off, let it settle — and checks every frame that the
// state is finite and the energy is bounded, at every sample that the heap has not grown since
// warm-up, and at the end that the energy has not drifted. Writes the samples as CSV (for
// docs/reliability.md) and exits non-zero naming the first broken check.
//
// Energy: the pile on the floor is chaotic, so a cycle's energy varies — the grasper takes the pile
// differently each time. Two earlier runs, whose grasper backed off diagonally and could sweep its
// shaft through a lifted loop, reached 1.35 and 2.4 times the warm-up's largest value once in
// 500,000–800,000 frames. What an instability or an energy pump does is multiply it by far more,
// or make it creep. So every frame must lie within [¼, 4] times the warm-up's extremes (cycles 2
// to 4; the first is the fall from hanging), and the mean over the last tenth of the samples within
// ±25 % of the mean over the first tenth after warm-up.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#include <cstddef>
// GCC ships the sanitizer runtimes but not their headers: the one entry point, declared here.
extern "C" std::size_t __sanitizer_get_current_allocated_bytes();
#endif
#include <fmt/format.h>
#include <malloc.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <vector>

#include "haustra/error.hpp"
#include "haustra/scene.hpp"
#include "haustra/world.hpp"

namespace {

using namespace haustra;

constexpr int kExitBroken = 1;
constexpr int kExitBadInput = 2;
constexpr int kExitUnstable = 3;

// The grasp-and-release cycle, in frames of 1/60 s: 5 s.
constexpr std::uint64_t kCycle = 300;
constexpr std::size_t kLeastSamples = 20;  // after the warm-up: a tenth of them is two
constexpr std::uint64_t kApproachEnd = 60, kCloseAt = 60, kLiftEnd = 120, kOpenAt = 180, kRetreatEnd = 210;
constexpr double kLift = 0.15;  // m

// Resident memory, KiB (Linux /proc).
long resident_kib() {
  long pages_total = 0, pages_resident = 0;
  if (FILE* f = std::fopen("/proc/self/statm", "r")) {
    if (std::fscanf(f, "%ld %ld", &pages_total, &pages_resident) != 2) pages_resident = 0;
    std::fclose(f);
  }
  return pages_resident * (sysconf(_SC_PAGESIZE) / 1024);
}

// Bytes the allocator has handed out and not taken back: glibc's count, or the sanitizer's
// allocator's where one replaces glibc's (mallinfo2 reads 0 there).
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
std::size_t heap_in_use() { return __sanitizer_get_current_allocated_bytes(); }
#else
std::size_t heap_in_use() { return mallinfo2().uordblks; }
#endif

struct Grasper {
  Eigen::Vector3d park{0.0, 0.0, 0.6};             // where it waits, high above the rod
  Eigen::Vector3d previous_park = park;            // where it waited last cycle
  Eigen::Vector3d grip = Eigen::Vector3d::Zero();  // where the grasp is taken, this cycle
  Eigen::Vector3d tip = park;
};

// The host's side of one frame: where the grasper goes and whether it is closed. It moves only
// vertically near the rod — across at parking height, straight down, up, and straight back up —
// so its shaft does not sweep through the pile.
void drive(World& w, Grasper& g, std::uint64_t frame, std::size_t target_node) {
  const std::uint64_t t = frame % kCycle;
  const auto lerp = [](const Eigen::Vector3d& a, const Eigen::Vector3d& b, double s) {
    s = std::clamp(s, 0.0, 1.0);
    s = s * s * (3.0 - 2.0 * s);  // smooth start and stop
    return ((1.0 - s) * a + s * b).eval();
  };
  if (t == 0) {
    const auto p = w.node_positions();
    const double r = w.bead_radii()[w.bead_count() / 2];
    g.previous_park = g.park;
    g.grip = Eigen::Vector3d(p.x[target_node], p.y[target_node], p.z[target_node] + r + 0.004);
    g.park = Eigen::Vector3d(g.grip.x(), g.grip.y(), 0.6);
  }
  const Eigen::Vector3d above = g.grip + Eigen::Vector3d(0.0, 0.0, kLift);
  constexpr std::uint64_t kAcrossEnd = kApproachEnd / 2;
  if (t < kAcrossEnd) {
    g.tip = lerp(g.previous_park, g.park, static_cast<double>(t) / kAcrossEnd);
  } else if (t < kApproachEnd) {
    g.tip = lerp(g.park, g.grip, static_cast<double>(t - kAcrossEnd) / static_cast<double>(kApproachEnd - kAcrossEnd));
  } else if (t < kLiftEnd) {
    g.tip = lerp(g.grip, above, static_cast<double>(t - kApproachEnd) / static_cast<double>(kLiftEnd - kApproachEnd));
  } else if (t < kOpenAt) {
    g.tip = above;
  } else if (t < kRetreatEnd) {
    g.tip = lerp(above, g.park, static_cast<double>(t - kOpenAt) / static_cast<double>(kRetreatEnd - kOpenAt));
  } else {
    g.tip = g.park;
  }
  w.set_instrument_pose(0, g.tip, Eigen::Vector3d::UnitZ());
  w.set_instrument_grasp(0, t >= kCloseAt && t < kOpenAt);
}

bool state_finite(const World& w) {
  const auto p = w.node_positions();
  for (std::size_t k = 0; k < w.node_count(); ++k)
    if (!std::isfinite(p.x[k]) || !std::isfinite(p.y[k]) || !std::isfinite(p.z[k])) return false;
  const auto m = w.mesh_positions();
  for (std::size_t v = 0; v < w.mesh_buffer_size(); ++v)
    if (!std::isfinite(m.x[v]) || !std::isfinite(m.y[v]) || !std::isfinite(m.z[v])) return false;
  return true;
}

struct Options {
  std::string scene = HAUSTRA_DEFAULT_SCENE;
  std::uint64_t frames = 1'000'000;
  std::uint64_t sample = 1000;
  std::uint64_t warmup_cycles = 4;
  int threads = 1;
  std::string out;
  std::uint64_t checkpoint_every = 0;  // frames between checkpoints (0: none)
  std::string checkpoint_dir;          // where: soak-<frame>.ckpt and its .host sidecar, the last two kept
  std::string resume;                  // a checkpoint to start from (its .host sidecar beside it)
  std::size_t trace = 600;             // frames of per-frame detail kept, written out when a check breaks
  double energy_factor = 4.0;          // every frame within [low / factor, high * factor]
  double energy_drift = 0.25;          // end mean against start mean
  std::size_t heap_slack = 64 << 10;   // bytes the heap may grow after warm-up (stdio buffers and the like)
};

// One frame's detail, kept for the last `trace` frames and written out when a check breaks: which
// part of the energy moved, what touched, whether the robust mode stepped in.
struct TraceRow {
  std::uint64_t frame = 0;
  double elastic = 0.0, gravity = 0.0;
  std::size_t touching = 0;
  double bead_overlap = 0.0, floor_depth = 0.0;
  int substeps = 1, retries = 0;
  bool grasping = false;
  Eigen::Vector3d tip = Eigen::Vector3d::Zero();
  double lowest = 0.0, highest = 0.0, max_axial = 0.0;
  std::size_t max_axial_node = 0;
};

TraceRow trace_row(const World& w, std::uint64_t f, const Grasper& g) {
  TraceRow r;
  r.frame = f;
  const Energy e = w.energy();
  r.elastic = e.elastic;
  r.gravity = e.gravity;
  r.touching = w.contacts().touching;
  r.bead_overlap = w.contacts().max_bead_overlap_ratio;
  r.floor_depth = w.contacts().max_environment_depth_ratio;
  r.substeps = w.last_profile().substeps;
  r.retries = w.last_profile().retries;
  r.grasping = w.instrument(0).grasping;
  r.tip = g.tip;
  const auto p = w.node_positions();
  r.lowest = std::numeric_limits<double>::infinity();
  r.highest = -r.lowest;
  for (std::size_t k = 0; k < w.node_count(); ++k) {
    r.lowest = std::min(r.lowest, p.z[k]);
    r.highest = std::max(r.highest, p.z[k]);
  }
  const auto q = w.strains();
  const auto q0 = w.rest_strains();
  for (std::size_t k = 0; k < w.node_count(); ++k) {
    const double d = std::abs(q.data[4 * k + 3] - q0.data[4 * k + 3]);
    if (d > r.max_axial) r.max_axial = d, r.max_axial_node = k;
  }
  return r;
}

void write_trace(const std::string& path, const std::vector<TraceRow>& ring, std::uint64_t last_frame) {
  std::ofstream out(path);
  out << "frame,elastic_J,gravity_J,total_J,touching,max_bead_overlap_ratio,max_environment_depth_ratio,substeps,"
         "retries,grasping,tip_x,tip_y,tip_z,lowest_node_z,highest_node_z,max_axial_strain_change,at_node\n";
  const std::size_t n = ring.size();
  for (std::uint64_t f = last_frame + 1 >= n ? last_frame + 1 - n : 0; f <= last_frame; ++f) {
    const TraceRow& r = ring[f % n];
    if (r.frame != f) continue;
    out << fmt::format(
        "{},{:.9g},{:.9g},{:.9g},{},{:.6g},{:.6g},{},{},{},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g},{}\n", r.frame,
        r.elastic, r.gravity, r.elastic + r.gravity, r.touching, r.bead_overlap, r.floor_depth, r.substeps, r.retries,
        r.grasping ? 1 : 0, r.tip.x(), r.tip.y(), r.tip.z(), r.lowest, r.highest, r.max_axial, r.max_axial_node);
  }
}

// The host's own state beside a checkpoint of the world: the grasper and the soak's bookkeeping.
struct HostState {
  Grasper grasper;
  double low = 0.0, high = 0.0;
  std::uint64_t grasps = 0;
  bool was_grasping = false;
};

void save_host(const std::string& path, const HostState& h) {
  std::ofstream out(path);
  out.precision(17);
  for (const Eigen::Vector3d* v : {&h.grasper.park, &h.grasper.previous_park, &h.grasper.grip, &h.grasper.tip})
    out << v->x() << ' ' << v->y() << ' ' << v->z() << '\n';
  out << h.low << ' ' << h.high << ' ' << h.grasps << ' ' << (h.was_grasping ? 1 : 0) << '\n';
}

HostState load_host(const std::string& path) {
  std::ifstream in(path);
  HostState h;
  int was = 0;
  for (Eigen::Vector3d* v : {&h.grasper.park, &h.grasper.previous_park, &h.grasper.grip, &h.grasper.tip})
    in >> v->x() >> v->y() >> v->z();
  in >> h.low >> h.high >> h.grasps >> was;
  if (!in) throw Error(ErrorCode::parse, fmt::format("{}: expected the soak's host state beside the checkpoint", path));
  h.was_grasping = was != 0;
  return h;
}

// The world the soak steps: the scene with the host's grasper added.
std::unique_ptr<World> soak_world(const Options& o) {
  SceneDesc scene = load_scene(o.scene);
  scene.world.threads = o.threads;
  InstrumentDesc grasper;
  grasper.name = "soak-grasper";
  grasper.grasp_reach = 0.015;
  grasper.tip = Grasper{}.park;
  scene.world.instruments.push_back(grasper);
  return create_world(scene);
}

// What the checks compare against: the warm-up's energy band and heap, the samples after it.
struct Tally {
  HostState host;  // the energy band is host.low .. host.high
  std::size_t heap_at_warmup = 0;
  long resident_at_warmup = 0;
  std::vector<double> sampled;  // energy at the samples after warm-up, for the drift check
};

// Every `checkpoint_every` frames: the world and the host's state, the last two kept.
void checkpoint_if_due(const Options& o, const World& w, const Tally& t, std::uint64_t f, std::uint64_t first_frame,
                       std::vector<std::string>& kept) {
  if (o.checkpoint_every == 0 || o.checkpoint_dir.empty() || f == first_frame || f % o.checkpoint_every != 0) return;
  const std::string path = fmt::format("{}/soak-{:07}.ckpt", o.checkpoint_dir, f);
  w.save_checkpoint_file(path);
  save_host(path + ".host", t.host);
  kept.push_back(path);
  if (kept.size() > 2) {
    std::filesystem::remove(kept.front());
    std::filesystem::remove(kept.front() + ".host");
    kept.erase(kept.begin());
  }
}

std::ofstream open_samples(const Options& o) {
  std::ofstream csv;
  if (o.out.empty()) return csv;
  std::filesystem::create_directories(std::filesystem::absolute(o.out).parent_path());
  csv.open(o.out);
  if (!csv) throw Error(ErrorCode::io, fmt::format("{}: cannot write the samples", o.out));
  csv << "frame,resident_kib,heap_bytes,elastic_J,gravity_J,total_J,energy_low_J,energy_high_J,"
         "max_bead_overlap_ratio,max_environment_depth_ratio,grasps,mean_frame_us\n";
  return csv;
}

// One sample: a CSV row and a line on stdout; false when the heap grew after warm-up.
bool take_sample(const Options& o, const World& w, Tally& t, std::uint64_t f, double mean_us, std::ofstream& csv) {
  const std::uint64_t warmup = o.warmup_cycles * kCycle;
  const std::size_t heap = heap_in_use();
  const long resident = resident_kib();
  const Energy en = w.energy();
  const ContactReport& c = w.contacts();
  if (csv.is_open())
    csv << fmt::format("{},{},{},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.6g},{:.6g},{},{:.2f}\n", f + 1, resident, heap,
                       en.elastic, en.gravity, en.total(), t.host.low / o.energy_factor, t.host.high * o.energy_factor,
                       c.max_bead_overlap_ratio, c.max_environment_depth_ratio, t.host.grasps, mean_us);
  if (f >= warmup) t.sampled.push_back(en.total());
  if (f >= warmup && heap > t.heap_at_warmup + o.heap_slack) {
    fmt::print(stderr, "soak: frame {}: the heap grew from {} to {} bytes after warm-up\n", f + 1, t.heap_at_warmup,
               heap);
    return false;
  }
  fmt::print("frame {:>8}  resident {:>7} KiB  heap {:>10} B  energy {:+.5f} J  grasps {:>5}  {:7.1f} µs/frame\n",
             f + 1, resident, heap, en.total(), t.host.grasps, mean_us);
  std::fflush(stdout);
  return true;
}

// Drift: the mean of the last tenth of the samples against the first tenth after warm-up.
bool drift_within(const Options& o, const std::vector<double>& sampled) {
  const std::size_t tenth = sampled.size() / 10;
  double start = 0.0, end = 0.0;
  for (std::size_t i = 0; i < tenth; ++i) {
    start += sampled[i] / static_cast<double>(tenth);
    end += sampled[sampled.size() - tenth + i] / static_cast<double>(tenth);
  }
  fmt::print("energy drift: mean {:.5f} J over the first tenth of the samples, {:.5f} J over the last ({:+.1f} %)\n",
             start, end, 100.0 * (end / start - 1.0));
  if (std::abs(end / start - 1.0) <= o.energy_drift) return true;
  fmt::print(stderr, "soak: the mean energy drifted by more than {:.0f} %\n", 100.0 * o.energy_drift);
  return false;
}

// The checks at the end of the run: enough samples, no drift, a grasp taken in every cycle.
int final_checks(const Options& o, const Tally& t, std::uint64_t first_frame) {
  const std::uint64_t warmup = o.warmup_cycles * kCycle;
  const long resident_growth = resident_kib() - t.resident_at_warmup;
  // A check with nothing to check is a soak that says more than it did: the energy band, the heap
  // and the drift need samples after the warm-up (the drift a tenth at each end, two at least).
  if (t.sampled.size() < kLeastSamples) {
    fmt::print(stderr,
               "soak: {} samples after the warm-up (frames {} to {}, one every {}): the energy, heap and drift checks "
               "need at least {}; run more frames (--frames), sample more often (--sample) or warm up for fewer "
               "cycles (--warmup-cycles)\n",
               t.sampled.size(), std::max(warmup, first_frame), o.frames, o.sample, kLeastSamples);
    return kExitBroken;
  }
  if (!drift_within(o, t.sampled)) return kExitBroken;
  fmt::print(
      "soak passed: {} frames, {} grasp-and-release cycles, {} grasps taken; energy within [{:.5f}, {:.5f}] J; "
      "heap {:+} bytes and resident memory {:+} KiB since warm-up\n",
      o.frames, o.frames / kCycle, t.host.grasps, t.host.low, t.host.high,
      static_cast<long long>(heap_in_use()) - static_cast<long long>(t.heap_at_warmup), resident_growth);
  // Every cycle should take its grasp: a soak that never lifts the rod tests less than it says.
  if (o.frames >= 2 * kCycle && t.host.grasps < o.frames / kCycle * 9 / 10) {
    fmt::print(stderr, "soak: only {} grasps in {} cycles: the grasper missed the rod\n", t.host.grasps,
               o.frames / kCycle);
    return kExitBroken;
  }
  return 0;
}

int soak(const Options& o) {
  auto w = soak_world(o);
  const std::size_t target = w->segment(0).nodes.offset + w->segment(0).nodes.count / 2;
  Tally t;
  t.host.low = std::numeric_limits<double>::infinity(), t.host.high = -t.host.low;  // the warm-up fills the band
  std::uint64_t first_frame = 0;
  if (!o.resume.empty()) {
    w->restore_checkpoint_file(o.resume);
    t.host = load_host(o.resume + ".host");
    first_frame = w->frame();
    t.heap_at_warmup = heap_in_use();  // a resumed run measures the heap from its own start
    t.resident_at_warmup = resident_kib();
    fmt::print("resumed from {} at frame {}\n", o.resume, first_frame);
  }
  Grasper& g = t.host.grasper;
  std::vector<TraceRow> ring(std::max<std::size_t>(o.trace, 1));
  std::vector<std::string> checkpoints;
  if (!o.checkpoint_dir.empty()) std::filesystem::create_directories(o.checkpoint_dir);
  const std::string trace_path = (o.out.empty() ? std::string("soak") : o.out) + ".trace.csv";
  std::ofstream csv = open_samples(o);
  const std::uint64_t warmup = o.warmup_cycles * kCycle;
  t.sampled.reserve(static_cast<std::size_t>(o.frames / o.sample) + 2);
  auto window_start = std::chrono::steady_clock::now();
  for (std::uint64_t f = first_frame; f < o.frames; ++f) {
    checkpoint_if_due(o, *w, t, f, first_frame, checkpoints);
    drive(*w, g, f, target);
    w->step();
    if (!state_finite(*w)) {
      write_trace(trace_path, ring, f - 1);
      fmt::print(stderr, "soak: frame {}: a node or mesh position is not finite\n", f);
      return kExitBroken;
    }
    const bool grasping = w->instrument(0).grasping;
    t.host.grasps += (grasping && !t.host.was_grasping) ? 1 : 0;
    t.host.was_grasping = grasping;
    if (o.trace > 0) ring[f % ring.size()] = trace_row(*w, f, g);
    const double e = w->energy().total();
    if (f >= kCycle && f < warmup) {  // the first cycle is the release from hanging: not the steady cycle
      t.host.low = std::min(t.host.low, e);
      t.host.high = std::max(t.host.high, e);
    }
    if (f + 1 == warmup) {
      t.heap_at_warmup = heap_in_use();
      t.resident_at_warmup = resident_kib();
    }
    const double floor_energy = t.host.low / o.energy_factor, ceiling_energy = t.host.high * o.energy_factor;
    if (f >= warmup && (e < floor_energy || e > ceiling_energy)) {
      fmt::print(stderr,
                 "soak: frame {}: energy {:.6g} J left [{:.6g}, {:.6g}] J ({} times the warm-up's [{:.6g}, "
                 "{:.6g}] J)\n",
                 f, e, floor_energy, ceiling_energy, o.energy_factor, t.host.low, t.host.high);
      if (o.trace > 0) {
        write_trace(trace_path, ring, f);
        fmt::print(stderr, "soak: the last {} frames in {}\n", o.trace, trace_path);
      }
      return kExitBroken;
    }
    if ((f + 1) % o.sample == 0 || f + 1 == o.frames) {
      const auto now = std::chrono::steady_clock::now();
      const double mean_us = std::chrono::duration<double, std::micro>(now - window_start).count() /
                             static_cast<double>((f % o.sample) + 1);
      window_start = now;
      if (!take_sample(o, *w, t, f, mean_us, csv)) return kExitBroken;
    }
  }
  return final_checks(o, t, first_frame);
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"haustra_soak: a long grasp-and-release run that checks finite state, memory and energy"};
  app.add_option("--scene", o.scene, "scene file")->capture_default_str();
  app.add_option("--frames", o.frames, "frames to step")->capture_default_str();
  app.add_option("--sample", o.sample, "frames between samples")->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--warmup-cycles", o.warmup_cycles, "grasp cycles of 300 frames before the checks start")
      ->capture_default_str();
  app.add_option("--threads", o.threads, "worker threads")->capture_default_str();
  app.add_option("--out", o.out, "CSV of the samples");
  app.add_option("--checkpoint-every", o.checkpoint_every, "frames between checkpoints (needs --checkpoint-dir)");
  app.add_option("--checkpoint-dir", o.checkpoint_dir, "directory for checkpoints; the last two are kept");
  app.add_option("--resume", o.resume, "start from this checkpoint (and its .host file)");
  app.add_option("--trace", o.trace, "frames of per-frame detail written to <out>.trace.csv when a check breaks")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  try {
    return soak(o);
  } catch (const Error& e) {
    fmt::print(stderr, "soak: {}\n", e.what());
    return e.code() == ErrorCode::unstable ? kExitUnstable : kExitBadInput;
  }
}
