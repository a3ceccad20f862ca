// Recordings: one channel per recorded quantity, each an array of frames × its shape, filled row
// by row after every frame of step(n).
#include "recording.hpp"

#include <fmt/format.h>

#include <cstring>

#include "haustra/error.hpp"

namespace py = pybind11;

namespace haustra::python {
namespace {

// Rows of (n, 3) from a Vec3View, node by node.
template <class T>
void write_vec3(kernels::Vec3View<const T> v, char* out) {
  auto* o = reinterpret_cast<T*>(out);
  for (std::size_t k = 0; k < v.size(); ++k) {
    o[3 * k] = v.x[k];
    o[3 * k + 1] = v.y[k];
    o[3 * k + 2] = v.z[k];
  }
}

void write_vec3(const Eigen::Vector3d& v, double* out) {
  for (Eigen::Index c = 0; c < 3; ++c) out[c] = v[c];
}

}  // namespace

std::vector<std::string> Recorder::known_names() {
  return {"node_positions",
          "node_rotations",
          "strains",
          "bead_centres",
          "mesh_positions",
          "mesh_normals",
          "node_velocities",
          "angular_velocities",
          "section_moments",
          "section_forces",
          "instrument_tip",
          "instrument_force",
          "instrument_filtered_force",
          "energy",
          "profile",
          "contacts"};
}

Recorder::Recorder(const World& world, const std::vector<std::string>& names, long frames) {
  const std::size_t n = world.node_count(), b = world.bead_count(), v = world.mesh_buffer_size(),
                    ins = world.instrument_count();
  std::size_t bytes = 0;
  auto add = [&](const std::string& name, const py::dtype& dtype, std::vector<py::ssize_t> shape,
                 std::function<void(const World&, char*)> write) {
    shape.insert(shape.begin(), static_cast<py::ssize_t>(frames));
    Channel c{name, dtype, shape, {}, nullptr, 0, std::move(write)};
    std::size_t items = 1;
    for (std::size_t i = 1; i < shape.size(); ++i) items *= static_cast<std::size_t>(shape[i]);
    c.row_bytes = items * static_cast<std::size_t>(dtype.itemsize());
    bytes += c.row_bytes * static_cast<std::size_t>(frames);
    channels_.push_back(std::move(c));
  };
  // Always: which frame and when.
  add("frame", py::dtype::of<std::uint64_t>(), {}, [](const World& w, char* o) {
    const std::uint64_t f = w.frame();
    std::memcpy(o, &f, sizeof f);
  });
  add("time", py::dtype::of<double>(), {}, [](const World& w, char* o) {
    const double t = w.time();
    std::memcpy(o, &t, sizeof t);
  });
  const auto d = py::dtype::of<double>();
  const auto f32 = py::dtype::of<float>();
  const auto N = static_cast<py::ssize_t>(n), B = static_cast<py::ssize_t>(b), V = static_cast<py::ssize_t>(v),
             I = static_cast<py::ssize_t>(ins);
  scratch_a_.resize(3 * n);
  scratch_b_.resize(3 * n);
  for (const std::string& name : names) {
    if (name == "node_positions") {
      add(name, d, {N, 3}, [](const World& w, char* o) { write_vec3(w.node_positions(), o); });
    } else if (name == "node_rotations") {
      add(name, d, {N, 4}, [](const World& w, char* o) {
        const auto r = w.node_rotations();
        auto* q = reinterpret_cast<double*>(o);
        for (std::size_t k = 0; k < r.size(); ++k) {
          q[4 * k] = r.w[k];
          q[4 * k + 1] = r.x[k];
          q[4 * k + 2] = r.y[k];
          q[4 * k + 3] = r.z[k];
        }
      });
    } else if (name == "strains") {
      add(name, d, {N, 4},
          [](const World& w, char* o) { std::memcpy(o, w.strains().data.data(), w.strains().data.size_bytes()); });
    } else if (name == "bead_centres") {
      add(name, d, {B, 3}, [](const World& w, char* o) { write_vec3(w.bead_centres(), o); });
    } else if (name == "mesh_positions" || name == "mesh_normals") {
      const bool positions = name == "mesh_positions";
      add(name, f32, {V, 3},
          [positions](const World& w, char* o) { write_vec3(positions ? w.mesh_positions() : w.mesh_normals(), o); });
    } else if (name == "node_velocities" || name == "angular_velocities") {
      const bool linear = name == "node_velocities";
      add(name, d, {N, 3}, [this, linear](const World& w, char* o) {
        w.node_velocities(scratch_a_, scratch_b_);
        std::memcpy(o, (linear ? scratch_a_ : scratch_b_).data(), scratch_a_.size() * sizeof(double));
      });
    } else if (name == "section_moments" || name == "section_forces") {
      const bool moments = name == "section_moments";
      add(name, d, {N, 3}, [this, moments](const World& w, char* o) {
        w.section_stresses(scratch_a_, scratch_b_);
        std::memcpy(o, (moments ? scratch_a_ : scratch_b_).data(), scratch_a_.size() * sizeof(double));
      });
    } else if (name == "instrument_tip" || name == "instrument_force" || name == "instrument_filtered_force") {
      add(name, d, {I, 3}, [name](const World& w, char* o) {
        for (std::size_t i = 0; i < w.instrument_count(); ++i) {
          const InstrumentReading r = w.instrument(i);
          const Eigen::Vector3d& x = name == "instrument_tip"     ? r.tip
                                     : name == "instrument_force" ? r.force
                                                                  : r.filtered_force;
          write_vec3(x, reinterpret_cast<double*>(o) + 3 * i);
        }
      });
    } else if (name == "energy") {
      add(name, d, {3}, [](const World& w, char* o) {
        const Energy e = w.energy();
        const double values[3] = {e.elastic, e.gravity, e.total()};
        std::memcpy(o, values, sizeof values);
      });
    } else if (name == "profile") {
      add(name, profile_dtype(), {},
          [](const World& w, char* o) { std::memcpy(o, &w.last_profile(), sizeof(FrameProfile)); });
    } else if (name == "contacts") {
      add(name, contact_summary_dtype(), {},
          [](const World& w, char* o) { std::memcpy(o, &w.contacts(), sizeof(ContactReport)); });
    } else {
      std::string known;
      for (const std::string& k : known_names()) known += (known.empty() ? "" : ", ") + k;
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("step(record=...): unknown quantity '{}'; expected any of: {}", name, known));
    }
  }
  const std::size_t available = available_memory();
  if (available > 0 && bytes > available / 2)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("step({}, record=...): the recording would take {:.1f} MB, more than half the {:.1f} MB "
                            "this machine has available; record fewer frames or quantities (e.g. without mesh_*)",
                            frames, static_cast<double>(bytes) / 1e6, static_cast<double>(available) / 1e6));
  for (Channel& c : channels_) {  // allocated only once the whole recording is known to fit
    c.array = py::array(c.dtype, c.shape);
    c.data = static_cast<char*>(c.array.mutable_data());
  }
}

void Recorder::capture(const World& world, long index) {
  for (Channel& c : channels_) c.write(world, c.data + static_cast<std::size_t>(index) * c.row_bytes);
}

py::dict Recorder::result(long frames_done) const {
  py::dict out;
  for (const Channel& c : channels_)
    out[py::str(c.name)] = c.array[py::slice(0, static_cast<py::ssize_t>(frames_done), 1)];
  return out;
}

}  // namespace haustra::python
