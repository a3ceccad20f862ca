#pragma once
// One piece of work a Scheduler (step/scheduler.hpp) hands to another thread; state-owned, so it
// lives beside the memory it writes.
#include <atomic>

namespace haustra::detail {

// Work handed to another thread while the stepping thread goes on (fast mode's prefactor, decision
// 0085), joined later by Scheduler::join. What it computes never depends on where it ran: it reads
// and writes only memory of its own. A copy is an idle job (a state copied for a checkpoint's check
// copies no work in flight; the owner joins before anything copies, moves or frees that memory).
class BackgroundJob {
 public:
  using Run = void (*)(void* data);
  BackgroundJob() = default;
  BackgroundJob(const BackgroundJob&) {}
  BackgroundJob& operator=(const BackgroundJob&) { return *this; }
  ~BackgroundJob() = default;
  [[nodiscard]] bool launched() const { return launched_; }

 private:
  friend class Scheduler;
  enum : int { kQueued, kTaken, kDone };
  // A worker's task: takes the job unless the stepping thread already has, then returns its claim.
  static void task(BackgroundJob& job) {
    int expected = kQueued;
    if (job.stage_.compare_exchange_strong(expected, kTaken, std::memory_order_acq_rel)) {
      job.run_(job.data_);
      job.stage_.store(kDone, std::memory_order_release);
    }
    job.outstanding_.fetch_sub(1, std::memory_order_release);  // the job may be gone after this
  }
  Run run_ = nullptr;
  void* data_ = nullptr;
  bool launched_ = false;
  std::atomic<int> stage_{kDone};
  std::atomic<int> outstanding_{0};  // tasks handed to a worker or the host that have not returned
};

}  // namespace haustra::detail
