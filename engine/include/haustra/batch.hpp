#pragma once
// Many independent worlds stepped in one call (decision 0103): a thread pool of the batch's own width
// takes the worlds one at a time, each stepped through all its frames by one task. A world's frames
// are the same bits as stepping it alone (a world's step does not depend on the thread it runs on, or
// on its neighbours: worlds share nothing), so a batch of any width gives what a loop gives.
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <span>

#include "haustra/world.hpp"

namespace haustra {

class Batch {
 public:
  // threads: the pool's width (0: the machine's cores). Worlds built with world.threads = 1 suit a
  // batch: its threads are spread over worlds, not within one.
  explicit Batch(int threads = 0);
  ~Batch();
  Batch(const Batch&) = delete;
  Batch& operator=(const Batch&) = delete;

  [[nodiscard]] int threads() const;

  // What became of one world: the frames it completed, and the error that stopped it (none: null).
  struct Outcome {
    std::uint64_t frames = 0;
    std::exception_ptr error;
  };

  // Between frames, on the thread stepping world `world`, after its frame `frame` (0-based) is done:
  // a host's recording, say. It may run on any of the pool's threads, for several worlds at once,
  // each world's calls in order.
  using AfterFrame = std::function<void(std::size_t world, std::uint64_t frame)>;
  // Asked before each frame: false stops every world at its last whole frame (a host's Ctrl-C).
  using KeepGoing = std::function<bool()>;

  // Steps every world `frames` frames. A world whose frame throws (an instability, say) stops at its
  // last good frame with the error in its outcome; the others go on. No world may appear twice, and
  // no world may be used elsewhere while the call runs.
  void step(std::span<World* const> worlds, std::uint64_t frames, std::span<Outcome> outcomes,
            const AfterFrame& after_frame = {}, const KeepGoing& keep_going = {});

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace haustra
