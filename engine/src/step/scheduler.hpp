#pragma once
// Runs a per-segment stage over all segments, on oneTBB inside an arena of the world's width.
// Each call writes only its segment's slice, so the result does not depend on the thread count.
#include <oneapi/tbb/info.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/partitioner.h>
#include <oneapi/tbb/task_arena.h>
#include <algorithm>
#include <array>

#include "haustra/world_desc.hpp"

#if defined(__SANITIZE_THREAD__)
#include <sanitizer/tsan_interface.h>
#endif

namespace haustra::detail {

// oneTBB orders each task after its dispatch and the caller after every task, but Debian's libtbb
// is not built with ThreadSanitizer, so that ordering is invisible to it and everything a stage
// shares looks racy. Under TSan the same ordering is stated explicitly, and only that ordering:
// each task acquires what the dispatch released and releases on an address of its own, which the
// join acquires — so two tasks of one call are never ordered with each other (one address for
// all would order a task after any that happened to end before it began, hiding their races).
// Other builds compile it away.
#if defined(__SANITIZE_THREAD__)
inline constexpr std::size_t kTaskAddresses = 4096;
inline char g_task_dispatch = 0;
inline std::array<char, kTaskAddresses> g_task_done{};
inline void task_dispatch() { __tsan_release(&g_task_dispatch); }
inline void task_begin() { __tsan_acquire(&g_task_dispatch); }
inline void task_end(std::size_t task) { __tsan_release(&g_task_done[task % kTaskAddresses]); }
inline void tasks_joined(std::size_t tasks) {
  for (std::size_t t = 0; t < std::min(tasks, kTaskAddresses); ++t) __tsan_acquire(&g_task_done[t]);
}
#else
inline void task_dispatch() {}
inline void task_begin() {}
inline void task_end(std::size_t) {}
inline void tasks_joined(std::size_t) {}
#endif

// Model building's parallel loops (cages, weights): fn(first, last) over [0, count) in blocks of
// `grain`, on the caller's arena, with the same TSan statement of oneTBB's ordering as the stages.
// Each index is computed alone, so the result does not depend on how the range was split.
template <class F>
void parallel_blocks(std::size_t count, std::size_t grain, F&& fn) {
  // One task per block, by index, like Scheduler::for_each: the body never reads oneTBB's range
  // objects, and the simple partitioner does no work balancing that TSan could not follow.
  const std::size_t blocks = (count + grain - 1) / grain;
  const auto body = [&fn, count, grain](std::size_t b) {
    task_begin();
    fn(b * grain, std::min(count, (b + 1) * grain));
    task_end(b);
  };
  task_dispatch();
  tbb::parallel_for(std::size_t{0}, blocks, body, tbb::simple_partitioner{});
  tasks_joined(blocks);
}

template <class F>
void parallel_each(std::size_t count, F&& fn) {
  parallel_blocks(count, 64, [&fn](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) fn(i);
  });
}

class Scheduler {
 public:
  explicit Scheduler(int threads, const JobSystemDesc& jobs = {})
      : threads_(jobs.enabled() ? std::max(1, jobs.workers)
                 : threads > 0  ? threads
                                : tbb::info::default_concurrency()),
        jobs_(jobs),
        arena_(jobs.enabled() ? 1 : threads_) {}

  [[nodiscard]] int threads() const { return threads_; }

  // parallel = false runs the tasks inline: for stages whose whole work costs less than handing
  // it to another thread (a few tens of µs).
  template <class F>
  void for_each(std::size_t count, F&& fn, bool parallel = true) {
    if (count <= 1 || threads_ == 1 || !parallel) {
      for (std::size_t i = 0; i < count; ++i) fn(i);
      return;
    }
    // One task per segment, by index: the body never touches oneTBB's own range objects.
    const auto body = [&fn](std::size_t i) {
      task_begin();
      fn(i);
      task_end(i);
    };
    if (jobs_.enabled()) {
      run_on_host(count, fn);
      return;
    }
    task_dispatch();
    arena_.execute([&] { tbb::parallel_for(std::size_t{0}, count, body, tbb::simple_partitioner{}); });
    tasks_joined(count);
  }

 private:
  // The indices split into at most `workers` contiguous ranges, each one task of the host's.
  template <class F>
  void run_on_host(std::size_t count, F& fn) {
    struct Batch {
      F* fn;
    } batch{&fn};
    const JobSystemDesc::Task task = [](void* data, std::size_t first, std::size_t last) {
      task_begin();
      F& f = *static_cast<Batch*>(data)->fn;
      for (std::size_t i = first; i < last; ++i) f(i);
      task_end(first);  // ranges start at distinct indices
    };
    const std::size_t ranges = std::min(count, static_cast<std::size_t>(threads_));
    task_dispatch();
    for (std::size_t r = 0; r < ranges; ++r)
      jobs_.enqueue(jobs_.host, task, &batch, r * count / ranges, (r + 1) * count / ranges);
    jobs_.wait(jobs_.host);
    tasks_joined(count);
  }

  int threads_;
  JobSystemDesc jobs_;
  tbb::task_arena arena_;
};

}  // namespace haustra::detail
