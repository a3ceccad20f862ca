#pragma once
// Runs a per-segment stage over all segments, on oneTBB inside an arena of the world's width.
// Each call writes only its segment's slice, so the result does not depend on the thread count.
#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/info.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/partitioner.h>
#include <oneapi/tbb/task_arena.h>

namespace haustra::detail {

class Scheduler {
 public:
  explicit Scheduler(int threads)
      : threads_(threads > 0 ? threads : tbb::info::default_concurrency()), arena_(threads_) {}

  [[nodiscard]] int threads() const { return threads_; }

  template <class F>
  void for_each(std::size_t count, F&& fn) {
    if (count <= 1 || threads_ == 1) {
      for (std::size_t i = 0; i < count; ++i) fn(i);
      return;
    }
    arena_.execute([&] {
      tbb::parallel_for(
          tbb::blocked_range<std::size_t>(0, count, 1),
          [&](const tbb::blocked_range<std::size_t>& r) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) fn(i);
          },
          tbb::simple_partitioner{});
    });
  }

 private:
  int threads_;
  tbb::task_arena arena_;
};

}  // namespace haustra::detail
