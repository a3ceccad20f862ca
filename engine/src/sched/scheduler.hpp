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
// The join's addresses belong to the call (on its stack), so calls running at once — two worlds,
// or a task that dispatches — never order each other's tasks. The dispatch's is one for all: a
// task must acquire before it reads anything of its call, even the pointers its body captured
// (their writes are the dispatching thread's), so begin() reads nothing of the call. Other builds
// compile it away.
#if defined(__SANITIZE_THREAD__)
inline char g_task_dispatch = 0;

class TaskOrder {
 public:
  void dispatched() { __tsan_release(&g_task_dispatch); }
  static void begin() { __tsan_acquire(&g_task_dispatch); }
  void end(std::size_t task) { __tsan_release(&done_[task % kAddresses]); }
  void joined(std::size_t tasks) {
    for (std::size_t t = 0; t < std::min(tasks, kAddresses); ++t) __tsan_acquire(&done_[t]);
  }

 private:
  static constexpr std::size_t kAddresses = 4096;
  std::array<char, kAddresses> done_{};
};
#else
struct TaskOrder {
  void dispatched() {}
  static void begin() {}
  void end(std::size_t) {}
  void joined(std::size_t) {}
};
#endif

// Model building's parallel loops (cages, weights): fn(first, last) over [0, count) in blocks of
// `grain`, on the caller's arena, with the same TSan statement of oneTBB's ordering as the stages.
// Each index is computed alone, so the result does not depend on how the range was split.
template <class F>
void parallel_blocks(std::size_t count, std::size_t grain, F&& fn) {
  // One task per block, by index, like Scheduler::for_each: the body never reads oneTBB's range
  // objects, and the simple partitioner does no work balancing that TSan could not follow.
  const std::size_t blocks = (count + grain - 1) / grain;
  TaskOrder order;
  const auto body = [&fn, &order, count, grain](std::size_t b) {
    TaskOrder::begin();
    fn(b * grain, std::min(count, (b + 1) * grain));
    order.end(b);
  };
  order.dispatched();
  tbb::parallel_for(std::size_t{0}, blocks, body, tbb::simple_partitioner{});
  order.joined(blocks);
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
    if (jobs_.enabled()) {
      run_on_host(count, fn);
      return;
    }
    // One task per segment, by index: the body never touches oneTBB's own range objects.
    TaskOrder order;
    const auto body = [&fn, &order](std::size_t i) {
      TaskOrder::begin();
      fn(i);
      order.end(i);
    };
    order.dispatched();
    arena_.execute([&] { tbb::parallel_for(std::size_t{0}, count, body, tbb::simple_partitioner{}); });
    order.joined(count);
  }

 private:
  // The indices split into at most `workers` contiguous ranges, each one task of the host's.
  template <class F>
  void run_on_host(std::size_t count, F& fn) {
    struct Batch {
      F* fn;
      TaskOrder order;
    } batch{&fn, {}};
    const JobSystemDesc::Task task = [](void* data, std::size_t first, std::size_t last) {
      TaskOrder::begin();
      Batch& b = *static_cast<Batch*>(data);
      for (std::size_t i = first; i < last; ++i) (*b.fn)(i);
      b.order.end(first);  // ranges start at distinct indices
    };
    const std::size_t ranges = std::min(count, static_cast<std::size_t>(threads_));
    batch.order.dispatched();
    for (std::size_t r = 0; r < ranges; ++r)
      jobs_.enqueue(jobs_.host, task, &batch, r * count / ranges, (r + 1) * count / ranges);
    jobs_.wait(jobs_.host);
    batch.order.joined(count);
  }

  int threads_;
  JobSystemDesc jobs_;
  tbb::task_arena arena_;
};

}  // namespace haustra::detail
