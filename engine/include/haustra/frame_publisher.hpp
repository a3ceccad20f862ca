#pragma once
// The last completed frame, for a reader on another thread (a renderer, a viewer's window): the
// stepping thread publishes after each step, the reader acquires the newest frame without ever
// making the stepping thread wait (docs/decisions/0029-double-buffered-output.md). The C API's
// double-buffered worlds and `haustra view` both read frames through this.
#include <array>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <vector>

#include "haustra/profile.hpp"
#include "haustra/world.hpp"

namespace haustra {

// What a frame holds beyond positions, for readers that draw overlays and plots (opt-in: the
// copies cost the stepping thread a few microseconds per frame).
struct FrameDetails {
  std::vector<double> strain, rest_strain;  // 4 per node (κ1 κ2 τ ε)
  std::vector<Contact> contacts;
  std::vector<InstrumentReading> instruments;
  std::vector<std::vector<Eigen::Vector3d>> cages;  // per segment: cage vertices (when wanted)
  std::vector<std::uint8_t> anchors_intact;         // per anchor of connective tissue: 1 while it holds
  FrameProfile profile;
};

class FramePublisher {
 public:
  struct Slot {
    std::uint64_t frame = 0;
    double time = 0.0;
    std::vector<double> x, y, z;                // nodes
    std::vector<float> px, py, pz, nx, ny, nz;  // mesh positions and normals
    // Worlds whose mesh follows on read (decision 0060): the stepping thread publishes the frame's
    // ring poses, and acquire() makes the mesh from them in the reader's thread.
    std::vector<kernels::RingPose> rings;
    std::vector<float> ring_delta;  // the reader's scratch
    bool mesh_pending = false;
    // Whether px..nz hold this frame's mesh: not for a reader that skins on its GPU (skin_on_gpu),
    // whose acquire makes the frame's ring data alone (gpu_rings: kGpuRingFloats a ring; decision 0110).
    bool mesh_made = false;
    std::vector<float> gpu_rings;
    bool gpu_pending = false;
    FrameDetails details;  // filled when the publisher wants details
  };

  // details: also copy FrameDetails every frame; cages: and the cage vertices.
  explicit FramePublisher(const World& world, bool details = false, bool cages = false);

  void publish(const World& world);  // the stepping thread, after each step

  // The world changed its sizes (segments added or removed, a rebuild): `change` makes the change
  // and returns the world, under the lock, so no reader takes a slot meanwhile. `wait_for_reader`:
  // wait until the reader releases its slot; otherwise a held slot refuses the change
  // (Error{invalid_argument}), as the C API documents.
  template <class Change>
  void resize(Change&& change, bool wait_for_reader = false) {
    std::unique_lock lock(mutex_);
    if (wait_for_reader) released_.wait(lock, [&] { return !held_; });
    refuse_if_held();
    const World& w = change();
    world_ = &w;
    for (Slot& s : slots_) size_slot(s, w);
    fill(slots_[ready_], w);
    fresh_ = true;
  }

  // Whether cages are copied (a reader's toggle; takes effect from the next publish).
  void want_cages(bool on);
  // The reader skins on its GPU (decision 0110): acquire makes the frame's ring data for the shader
  // (Slot::gpu_rings, O(rings)) instead of skinning and the normals (O(vertices)). A reader's
  // toggle, from its next acquire.
  void skin_on_gpu(bool on);
  [[nodiscard]] bool skins_on_gpu() const { return gpu_; }

  // The reading thread; one slot at a time. For a world whose mesh follows on read, the slot's
  // mesh is made here, in the reader's thread, before it is returned.
  const Slot& acquire();
  void release();

 private:
  void size_slot(Slot& s, const World& w) const;
  void fill(Slot& s, const World& w) const;
  void refuse_if_held() const;

  std::array<Slot, 3> slots_;
  const World* world_;  // whose model a reader's mesh is made with (changed only under the lock)
  std::mutex mutex_;
  std::condition_variable released_;
  int back_ = 0, ready_ = 1, reading_ = 2;
  bool fresh_ = false, held_ = false;
  bool details_ = false;
  std::atomic<bool> cages_{false};  // set by the reader, read by the stepping thread
  std::atomic<bool> gpu_{false};    // set and read by the reader
};

}  // namespace haustra
