// Batch: many worlds stepped on a pool of the batch's own width (decision 0103).
#include "haustra/batch.hpp"

#include <fmt/format.h>
#include <oneapi/tbb/info.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/partitioner.h>
#include <oneapi/tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <vector>

#include "haustra/error.hpp"
#include "sched/scheduler.hpp"

namespace haustra {

struct Batch::Impl {
  int threads;
  tbb::task_arena arena;
  explicit Impl(int t) : threads(t > 0 ? t : tbb::info::default_concurrency()), arena(threads) {}
};

Batch::Batch(int threads) {
  if (threads < 0 || threads > 1024)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("Batch: threads = {}: expected 0 (every core) to 1024", threads));
  impl_ = std::make_unique<Impl>(threads);
}

Batch::~Batch() = default;

int Batch::threads() const { return impl_->threads; }

void Batch::step(std::span<World* const> worlds, std::uint64_t frames, std::span<Outcome> outcomes,
                 const AfterFrame& after_frame, const KeepGoing& keep_going) {
  if (outcomes.size() != worlds.size())
    throw Error(
        ErrorCode::invalid_argument,
        fmt::format("Batch::step: {} outcomes for {} worlds: expected one per world", outcomes.size(), worlds.size()));
  std::vector<const World*> sorted(worlds.begin(), worlds.end());
  std::sort(sorted.begin(), sorted.end());
  if (std::find(sorted.begin(), sorted.end(), nullptr) != sorted.end())
    throw Error(ErrorCode::invalid_argument, "Batch::step: a world is null");
  if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end())
    throw Error(ErrorCode::invalid_argument,
                "Batch::step: a world appears twice (two threads would step it at once): list each world once");
  for (Outcome& o : outcomes) o = Outcome{};
  std::atomic<bool> stop{false};
  // One task per world, by index, through all its frames: no barrier between frames, and each world's
  // frames in order on one thread at a time (the same bits as stepping it alone).
  detail::TaskOrder order;
  const auto body = [&](std::size_t i) {
    detail::TaskOrder::begin();
    Outcome& out = outcomes[i];
    for (; out.frames < frames; ++out.frames) {
      if (stop.load(std::memory_order_relaxed)) break;
      if (keep_going && !keep_going()) {
        stop.store(true, std::memory_order_relaxed);
        break;
      }
      try {
        worlds[i]->step();
      } catch (...) {
        out.error = std::current_exception();
        break;
      }
      if (after_frame) after_frame(i, out.frames);
    }
    order.end(i);
  };
  order.dispatched();
  if (impl_->threads == 1 || worlds.size() <= 1) {
    for (std::size_t i = 0; i < worlds.size(); ++i) body(i);
  } else {
    impl_->arena.execute([&] {
      tbb::this_task_arena::isolate(
          [&] { tbb::parallel_for(std::size_t{0}, worlds.size(), body, tbb::simple_partitioner{}); });
    });
  }
  order.joined(worlds.size());
}

}  // namespace haustra
