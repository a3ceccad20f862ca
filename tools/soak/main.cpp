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
#include <fmt/format.h>
#include <malloc.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
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

// Bytes the allocator has handed out and not taken back (glibc; 0 under a sanitizer's allocator).
std::size_t heap_in_use() { return mallinfo2().uordblks; }

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
  double energy_factor = 4.0;        // every frame within [low / factor, high * factor]
  double energy_drift = 0.25;        // end mean against start mean
  std::size_t heap_slack = 64 << 10; // bytes the heap may grow after warm-up (stdio buffers and the like)
};

int soak(const Options& o) {
  SceneDesc scene = load_scene(o.scene);
  scene.world.threads = o.threads;
  InstrumentDesc grasper;
  grasper.name = "soak-grasper";
  grasper.grasp_reach = 0.015;
  grasper.tip = Grasper{}.park;
  scene.world.instruments.push_back(grasper);
  auto w = create_world(scene);
  const std::size_t target = w->segment(0).nodes.offset + w->segment(0).nodes.count / 2;
  Grasper g;

  std::ofstream csv;
  if (!o.out.empty()) {
    std::filesystem::create_directories(std::filesystem::absolute(o.out).parent_path());
    csv.open(o.out);
    if (!csv) throw Error(ErrorCode::io, fmt::format("{}: cannot write the samples", o.out));
    csv << "frame,resident_kib,heap_bytes,elastic_J,gravity_J,total_J,energy_low_J,energy_high_J,"
           "max_bead_overlap_ratio,max_environment_depth_ratio,grasps,mean_frame_us\n";
  }
  const std::uint64_t warmup = o.warmup_cycles * kCycle;
  double low = std::numeric_limits<double>::infinity(), high = -low;  // warm-up energy band
  std::size_t heap_at_warmup = 0;
  long resident_at_warmup = 0;
  std::uint64_t grasps = 0;
  bool was_grasping = false;
  std::vector<double> sampled;  // energy at the samples after warm-up, for the drift check
  sampled.reserve(static_cast<std::size_t>(o.frames / o.sample) + 2);
  auto window_start = std::chrono::steady_clock::now();
  for (std::uint64_t f = 0; f < o.frames; ++f) {
    drive(*w, g, f, target);
    w->step();
    if (!state_finite(*w)) {
      fmt::print(stderr, "soak: frame {}: a node or mesh position is not finite\n", f);
      return kExitBroken;
    }
    const bool grasping = w->instrument(0).grasping;
    grasps += (grasping && !was_grasping) ? 1 : 0;
    was_grasping = grasping;
    const double e = w->energy().total();
    if (f >= kCycle && f < warmup) {  // the first cycle is the release from hanging: not the steady cycle
      low = std::min(low, e);
      high = std::max(high, e);
    }
    if (f + 1 == warmup) {
      heap_at_warmup = heap_in_use();
      resident_at_warmup = resident_kib();
    }
    const double floor_energy = low / o.energy_factor, ceiling_energy = high * o.energy_factor;
    if (f >= warmup && (e < floor_energy || e > ceiling_energy)) {
      fmt::print(stderr, "soak: frame {}: energy {:.6g} J left [{:.6g}, {:.6g}] J ({} times the warm-up's [{:.6g}, "
                         "{:.6g}] J)\n", f, e, floor_energy, ceiling_energy, o.energy_factor, low, high);
      return kExitBroken;
    }
    if ((f + 1) % o.sample == 0 || f + 1 == o.frames) {
      const auto now = std::chrono::steady_clock::now();
      const double mean_us = std::chrono::duration<double, std::micro>(now - window_start).count() /
                             static_cast<double>((f % o.sample) + 1);
      window_start = now;
      const std::size_t heap = heap_in_use();
      const long resident = resident_kib();
      const Energy en = w->energy();
      const ContactReport& c = w->contacts();
      if (csv.is_open())
        csv << fmt::format("{},{},{},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.6g},{:.6g},{},{:.2f}\n", f + 1, resident, heap,
                           en.elastic, en.gravity, en.total(), floor_energy, ceiling_energy, c.max_bead_overlap_ratio,
                           c.max_environment_depth_ratio, grasps, mean_us);
      if (f >= warmup) sampled.push_back(en.total());
      if (f >= warmup && heap > heap_at_warmup + o.heap_slack) {
        fmt::print(stderr, "soak: frame {}: the heap grew from {} to {} bytes after warm-up\n", f + 1, heap_at_warmup, heap);
        return kExitBroken;
      }
      fmt::print("frame {:>8}  resident {:>7} KiB  heap {:>10} B  energy {:+.5f} J  grasps {:>5}  {:7.1f} µs/frame\n",
                 f + 1, resident, heap, en.total(), grasps, mean_us);
      std::fflush(stdout);
    }
  }
  const long resident_growth = resident_kib() - resident_at_warmup;
  // Drift: the last tenth of the samples against the first tenth after warm-up.
  if (sampled.size() >= 20) {
    const std::size_t tenth = sampled.size() / 10;
    double start = 0.0, end = 0.0;
    for (std::size_t i = 0; i < tenth; ++i) {
      start += sampled[i] / static_cast<double>(tenth);
      end += sampled[sampled.size() - tenth + i] / static_cast<double>(tenth);
    }
    fmt::print("energy drift: mean {:.5f} J over the first tenth of the samples, {:.5f} J over the last ({:+.1f} %)\n",
               start, end, 100.0 * (end / start - 1.0));
    if (std::abs(end / start - 1.0) > o.energy_drift) {
      fmt::print(stderr, "soak: the mean energy drifted by more than {:.0f} %\n", 100.0 * o.energy_drift);
      return kExitBroken;
    }
  }
  fmt::print("soak passed: {} frames, {} grasp-and-release cycles, {} grasps taken; energy within [{:.5f}, {:.5f}] J; "
             "heap {:+} bytes and resident memory {:+} KiB since warm-up\n",
             o.frames, o.frames / kCycle, grasps, low, high, static_cast<long long>(heap_in_use()) - static_cast<long long>(heap_at_warmup),
             resident_growth);
  // Every cycle should take its grasp: a soak that never lifts the rod tests less than it says.
  if (o.frames >= 2 * kCycle && grasps < o.frames / kCycle * 9 / 10) {
    fmt::print(stderr, "soak: only {} grasps in {} cycles: the grasper missed the rod\n", grasps, o.frames / kCycle);
    return kExitBroken;
  }
  return 0;
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
  CLI11_PARSE(app, argc, argv);
  try {
    return soak(o);
  } catch (const Error& e) {
    fmt::print(stderr, "soak: {}\n", e.what());
    return e.code() == ErrorCode::unstable ? kExitUnstable : kExitBadInput;
  }
}
