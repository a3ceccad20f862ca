// pickle, copy.copy and copy.deepcopy of a World: its origin (the scene's text, where its paths
// resolve, the overrides), the run-time parameters in force, and a checkpoint. The copy continues
// bit for bit as the original would. Asset files (meshes) must be at the same paths where it is
// unpickled, as for the scene itself.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <fmt/format.h>

#include "haustra/error.hpp"
#include "world_bindings.hpp"

namespace py = pybind11;

namespace haustra::python {
namespace {

constexpr int kPickleVersion = 1;

py::tuple state_of(PyWorld& w) {
  const WorldOrigin& o = w.origin();
  if (o.rebuilt)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("World '{}' cannot be pickled or copied: segments were added or removed, so its scene "
                            "no longer describes it",
                            w.name()));
  auto world = w.locked();
  const std::vector<std::byte> checkpoint = world->save_checkpoint();
  const WorldDesc& desc = world->desc();
  py::list couplings;
  for (const InstrumentDesc& i : desc.instruments)
    couplings.append(py::make_tuple(i.coupling_stiffness, i.coupling_damping, i.force_limit));
  py::list materials;  // per chain (description segment), as set_material may have changed them
  for (const SegmentDesc& s : desc.segments)
    materials.append(
        py::make_tuple(s.material.youngs_modulus, s.material.poisson_ratio, s.material.density, s.relaxation_time));
  return py::make_tuple(kPickleVersion, o.text, o.file.string(), o.overrides, o.from_dict,
                        py::bytes(reinterpret_cast<const char*>(checkpoint.data()), checkpoint.size()),
                        py::make_tuple(desc.gravity.x(), desc.gravity.y(), desc.gravity.z()), desc.dt, couplings,
                        materials);
}

PyWorld* world_of_state(const py::tuple& state) {
  if (state.size() != 10 || state[0].cast<int>() != kPickleVersion)
    throw Error(ErrorCode::parse,
                fmt::format("a pickled World of another version (expected version {})", kPickleVersion));
  WorldOrigin o;
  o.text = state[1].cast<std::string>();
  o.file = state[2].cast<std::string>();
  o.overrides = state[3].cast<std::vector<std::string>>();
  o.from_dict = state[4].cast<bool>();
  auto* w = build_world(std::move(o));
  try {
    auto world = w->locked();
    const auto g = state[6].cast<std::array<double, 3>>();
    world->set_gravity({g[0], g[1], g[2]});
    world->set_dt(state[7].cast<double>());
    const auto couplings = state[8].cast<std::vector<std::array<double, 3>>>();
    for (std::size_t i = 0; i < couplings.size(); ++i)
      world->set_instrument_coupling(i, couplings[i][0], couplings[i][1], couplings[i][2]);
    const auto materials = state[9].cast<std::vector<std::array<double, 4>>>();
    for (std::size_t s = 0, chain = 0; s < world->segment_count() && chain < materials.size(); ++s) {
      if (world->chain_of(s) != s) continue;  // a chain's later pieces: set through its first
      const std::array<double, 4>& m = materials[chain++];
      MaterialDesc material = world->segment_desc(s).material;
      if (material.youngs_modulus == m[0] && material.poisson_ratio == m[1] && material.density == m[2] &&
          world->segment_desc(s).relaxation_time == m[3])
        continue;  // as the scene has it: no rebuild
      material.youngs_modulus = m[0];
      material.poisson_ratio = m[1];
      material.density = m[2];
      world->set_material(s, material, m[3]);
    }
    const std::string bytes = state[5].cast<std::string>();
    world->restore_checkpoint(std::span(reinterpret_cast<const std::byte*>(bytes.data()), bytes.size()),
                              "pickled World");
  } catch (...) {
    delete w;
    throw;
  }
  return w;
}

}  // namespace

void bind_pickling(WorldClass& c) { c.def(py::pickle(&state_of, &world_of_state)); }

}  // namespace haustra::python
