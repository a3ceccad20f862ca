#pragma once
// A host job system that puts two threads in lockstep inside a step (decision 0100's tests): it
// runs each batch on the stepping thread and, at the first wait of an armed step, runs `inside`
// there, tells the other thread the step is under way and waits until that thread has tried what it
// wanted. No timing: each side waits for the other's word. Usable as haustra::JobSystemDesc (C++)
// and haustra_job_system (C).
#include <doctest/doctest.h>

#include <condition_variable>
#include <cstddef>
#include <functional>
#include <mutex>
#include <vector>

class LockstepJobs {
 public:
  using Task = void (*)(void*, std::size_t, std::size_t);

  static void enqueue(void* host, Task task, void* data, std::size_t first, std::size_t last) {
    static_cast<LockstepJobs*>(host)->ranges_.push_back({task, data, first, last});
  }
  static void wait(void* host) {
    auto& self = *static_cast<LockstepJobs*>(host);
    for (const Range& r : self.ranges_) r.task(r.data, r.first, r.last);
    self.ranges_.clear();
    if (!self.armed_) return;
    self.armed_ = false;
    if (self.inside_) self.inside_();
    std::unique_lock lock(self.mutex_);
    self.inside_step_ = true;
    self.changed_.notify_all();
    self.changed_.wait(lock, [&] { return self.tried_; });
  }

  // The next step stops at its first wait for the other thread; `inside` runs there first, on the
  // stepping thread.
  void arm(std::function<void()> inside = {}) {
    armed_ = true;
    inside_ = std::move(inside);
    inside_step_ = tried_ = step_over_ = false;
  }
  // The other thread: waits until the armed step is under way, runs `attempt`, lets the step go on.
  // A step that never reached the job system ends the wait too (and fails the case).
  void while_stepping(const std::function<void()>& attempt) {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return inside_step_ || step_over_; });
    if (!inside_step_) {
      FAIL_CHECK("the step never waited for the host's jobs");
      return;
    }
    lock.unlock();
    attempt();
    lock.lock();
    tried_ = true;
    changed_.notify_all();
  }
  // The stepping thread, once its step returned.
  void stepped() {
    const std::lock_guard lock(mutex_);
    step_over_ = true;
    changed_.notify_all();
  }

 private:
  struct Range {
    Task task;
    void* data;
    std::size_t first, last;
  };
  std::vector<Range> ranges_;
  std::mutex mutex_;
  std::condition_variable changed_;
  bool armed_ = false, inside_step_ = false, tried_ = false, step_over_ = false;
  std::function<void()> inside_;
};
