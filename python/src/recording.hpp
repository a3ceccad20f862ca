#pragma once
// Recordings: step(n, record=[...]) captures chosen quantities after each frame into arrays
// allocated before the loop (frames × ...), without the GIL and without a Python loop.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <functional>
#include <string>
#include <vector>

#include "haustra/world.hpp"

namespace haustra::python {

class Recorder {
 public:
  // Refuses an unknown name (listing the known ones) and a recording larger than the memory
  // available, before anything is stepped.
  Recorder(const World& world, const std::vector<std::string>& names, long frames);

  // After frame `index` of the step (0-based): copies each quantity into its row. No GIL needed.
  void capture(const World& world, long index);
  // The arrays, cut to the frames captured.
  [[nodiscard]] pybind11::dict result(long frames_done) const;

  static std::vector<std::string> known_names();

 private:
  struct Channel {
    std::string name;
    pybind11::dtype dtype;
    std::vector<pybind11::ssize_t> shape;  // frames first
    pybind11::array array;
    char* data = nullptr;
    std::size_t row_bytes = 0;
    std::function<void(const World&, char*)> write;
  };
  std::vector<Channel> channels_;
  std::vector<double> scratch_a_, scratch_b_;  // derived readings (velocities, stresses)
};

// The dtype of a frame's profile (FrameProfile's own layout: seconds and calls by stage name, the
// counters, frame_seconds, newton) and of the contact summary (ContactReport's).
pybind11::dtype profile_dtype();
pybind11::dtype contact_summary_dtype();
// One contact's record (Contact's layout): bead, other, kind, point, normal, force, direction,
// stiffness, depth, coupled.
pybind11::dtype contact_dtype();

}  // namespace haustra::python
