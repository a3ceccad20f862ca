#pragma once
// Runs a per-segment stage over all segments, on oneTBB inside an arena of the world's width.
// Each call writes only its segment's slice, so the result does not depend on the thread count.
#include <oneapi/tbb/info.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/partitioner.h>
#include <oneapi/tbb/task_arena.h>
#include <algorithm>
#include <array>
#include <thread>

#include "haustra/world_desc.hpp"
#include "step/background_job.hpp"

#if defined(__SANITIZE_THREAD__)
#include <sanitizer/tsan_interface.h>
// In libtsan, not in GCC 12's header.
extern "C" void __tsan_ignore_thread_begin();
extern "C" void __tsan_ignore_thread_end();
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
  // oneTBB's enqueue builds its task object (vtable, allocator, the closure's copy) in header code
  // after dispatched() has released, and a worker already awake may run it before this thread
  // releases again. Those writes are ordered by oneTBB's queue, which TSan cannot see, so they are
  // left unrecorded — only while an Unseen lives, only on the enqueuing thread (ended even if the
  // enqueue throws).
  struct Unseen {
    Unseen() { __tsan_ignore_thread_begin(); }
    ~Unseen() { __tsan_ignore_thread_end(); }
    Unseen(const Unseen&) = delete;
    Unseen& operator=(const Unseen&) = delete;
  };

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
  struct Unseen {};
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
    // Isolated: a thread waiting for this loop's tasks never takes a background job meanwhile.
    arena_.execute([&] {
      tbb::this_task_arena::isolate(
          [&] { tbb::parallel_for(std::size_t{0}, count, body, tbb::simple_partitioner{}); });
    });
    order.joined(count);
  }

  // `run(data)` on another thread while the caller goes on; join() waits for it. One thread: run
  // at once, inline, at the same point. oneTBB: enqueued in the stages' arena, where its worker
  // takes it between the stages' loops (it may take ~1 ms to come: hence fast mode's two frames of
  // lead); if none has by the join, the caller runs it itself there. A host's jobs: one range of the host's; its next
  // wait — a stage's or the join's — returns only once it has run (the host's wait covers every
  // range enqueued since the last one).
  void launch(BackgroundJob& job, BackgroundJob::Run run, void* data) {
    settle(job);
    job.run_ = run;
    job.data_ = data;
    job.launched_ = true;
    if (threads_ == 1) {
      run(data);
      job.stage_.store(BackgroundJob::kDone, std::memory_order_relaxed);
      return;
    }
    job.stage_.store(BackgroundJob::kQueued, std::memory_order_relaxed);
    job.outstanding_.store(1, std::memory_order_relaxed);
    TaskOrder order;
    order.dispatched();
    if (jobs_.enabled()) {
      const JobSystemDesc::Task task = [](void* job_data, std::size_t, std::size_t) {
        TaskOrder::begin();
        BackgroundJob::task(*static_cast<BackgroundJob*>(job_data));
      };
      jobs_.enqueue(jobs_.host, task, &job, 0, 1);
      return;
    }
    BackgroundJob* const pointer = &job;
    [[maybe_unused]] const TaskOrder::Unseen unseen;
    arena_.enqueue([pointer] {
      TaskOrder::begin();
      BackgroundJob::task(*pointer);
    });
  }

  // Waits until a launched job has run (or runs it here, on oneTBB, if no worker has taken it).
  void join(BackgroundJob& job) {
    if (!job.launched_) return;
    job.launched_ = false;
    if (jobs_.enabled()) {
      if (job.stage_.load(std::memory_order_acquire) != BackgroundJob::kDone) jobs_.wait(jobs_.host);
      while (job.stage_.load(std::memory_order_acquire) != BackgroundJob::kDone) std::this_thread::yield();
      return;
    }
    int expected = BackgroundJob::kQueued;
    if (job.stage_.compare_exchange_strong(expected, BackgroundJob::kTaken, std::memory_order_acq_rel)) {
      job.run_(job.data_);
      job.stage_.store(BackgroundJob::kDone, std::memory_order_relaxed);
      return;
    }
    while (job.stage_.load(std::memory_order_acquire) != BackgroundJob::kDone) std::this_thread::yield();
  }

  // Joined, and no worker's task holds it any more: its memory may be reused, copied or freed.
  void settle(BackgroundJob& job) {
    join(job);
    while (job.outstanding_.load(std::memory_order_acquire) != 0) std::this_thread::yield();
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
