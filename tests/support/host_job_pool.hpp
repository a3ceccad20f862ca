#pragma once
// A host's job system as a game engine might have one: a few worker threads taking ranges from a
// queue, and a wait that returns when the queue is empty and every worker idle. Used through
// haustra::JobSystemDesc (C++) and haustra_job_system (C) in the tests.
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <mutex>
#include <thread>
#include <vector>

class HostJobPool {
 public:
  using Task = void (*)(void*, std::size_t, std::size_t);

  explicit HostJobPool(int workers) {
    for (int i = 0; i < workers; ++i) threads_.emplace_back([this] { work(); });
  }
  ~HostJobPool() {
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : threads_) t.join();
  }
  HostJobPool(const HostJobPool&) = delete;
  HostJobPool& operator=(const HostJobPool&) = delete;

  static void enqueue(void* pool, Task task, void* data, std::size_t first, std::size_t last) {
    auto* self = static_cast<HostJobPool*>(pool);
    {
      std::lock_guard lock(self->mutex_);
      self->queue_.push_back({task, data, first, last});
      self->enqueued_ += 1;
    }
    self->wake_.notify_one();
  }
  static void wait(void* pool) {
    auto* self = static_cast<HostJobPool*>(pool);
    std::unique_lock lock(self->mutex_);
    self->done_.wait(lock, [self] { return self->finished_ == self->enqueued_; });
  }
  [[nodiscard]] std::size_t tasks_run() const {
    std::lock_guard lock(mutex_);
    return finished_;
  }

 private:
  struct Job {
    Task task;
    void* data;
    std::size_t first, last;
  };
  void work() {
    std::unique_lock lock(mutex_);
    for (;;) {
      wake_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      if (queue_.empty()) return;
      const Job job = queue_.front();
      queue_.pop_front();
      lock.unlock();
      job.task(job.data, job.first, job.last);
      lock.lock();
      finished_ += 1;
      if (finished_ == enqueued_) done_.notify_all();
    }
  }

  mutable std::mutex mutex_;
  std::condition_variable wake_, done_;
  std::deque<Job> queue_;
  std::size_t enqueued_ = 0, finished_ = 0;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};
