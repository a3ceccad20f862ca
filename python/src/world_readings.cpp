// haustra.World's small readings: counts, time, the segments' table, the last frame's profile,
// events, energy, the contact summary and instruments — fresh Python objects (copies).
#include <pybind11/pybind11.h>

#include "haustra/world.hpp"
#include "indices.hpp"
#include "typed.hpp"
#include "world_bindings.hpp"
#include "world_reading.hpp"

namespace py = pybind11;

namespace haustra::python {
namespace {

void bind_counts(WorldClass& c) {
  c.def_property_readonly("name", &PyWorld::name, "The scene's name.");
  c.def_property_readonly("scene_frames", &PyWorld::scene_frames,
                          "The scene's length (scene.frames): what `haustra run` runs.");
  c.def_property_readonly(
      "frame", [](PyWorld& w) { return w.locked()->frame(); }, "Frames stepped so far.");
  c.def_property_readonly(
      "time", [](PyWorld& w) { return w.locked()->time(); }, "s, simulated.");
  c.def_property_readonly(
      "threads", [](PyWorld& w) { return w.locked()->threads(); }, "Threads a step runs on.");
  c.def_property_readonly(
      "node_count", [](PyWorld& w) { return w.locked()->node_count(); }, "Nodes of all segments.");
  c.def_property_readonly(
      "segment_count", [](PyWorld& w) { return w.locked()->segment_count(); }, "Segments (a chain's pieces each).");
  c.def_property_readonly(
      "bead_count", [](PyWorld& w) { return w.locked()->bead_count(); }, "Beads of all segments.");
  c.def_property_readonly(
      "late_frames", [](PyWorld& w) { return w.locked()->late_frames(); },
      "Frames over frame_budget since the world was created.");
  c.def_property_readonly(
      "instrument_count", [](PyWorld& w) { return w.locked()->instrument_count(); }, "Instruments.");
}

}  // namespace

void bind_world_readings(WorldClass& c) {
  bind_counts(c);
  c.def_property_readonly(
      "segments", [](PyWorld& w) { return segments_list(w.locked().world); },
      "One dict per segment (haustra.types.Segment): name, node range, chain, length, stiffnesses, bead and mesh "
      "ranges.");
  c.def_property_readonly(
      "profile", [](PyWorld& w) { return profile_dict(w.locked()->last_profile()); },
      "The last frame's per-stage profile (haustra.types.Profile): seconds and calls per stage, frame_seconds, "
      "the counters. step(n, record=['profile']) keeps every frame's.");
  c.def_property_readonly(
      "events", [](PyWorld& w) { return events_list(w.locked()->events()); },
      "Robust-mode recoveries, instabilities and slips so far, oldest first (haustra.types.Event).");
  c.def_property_readonly(
      "energy",
      [](PyWorld& w) {
        const Energy e = w.locked()->energy();
        EnergyDict d;
        d["elastic"] = e.elastic;
        d["gravity"] = e.gravity;
        d["tissue"] = e.tissue;
        d["total"] = e.total();
        return d;
      },
      "J: elastic, gravity, tissue (what the anchors' springs store) and total (haustra.types.Energy).");
  c.def_property_readonly(
      "contacts", [](PyWorld& w) { return contacts_dict(w.locked()->contacts()); },
      "The last frame's contact summary (haustra.types.ContactSummary); contact_records has each contact.");
  c.def(
      "instrument",
      [](PyWorld& w, IndexArg i) {
        auto world = w.locked();
        return instrument_dict(world->instrument(instrument_index(world.world, i, "instrument")));
      },
      py::arg("instrument") = 0,
      "The instrument after the last frame (haustra.types.Instrument): pose, grasp (and whether it slipped), force "
      "on it (raw and filtered).");
}

}  // namespace haustra::python
