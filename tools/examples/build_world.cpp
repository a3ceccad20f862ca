// A C++ host that builds a world without any scene file: a colon segment from a centreline it
// computed itself (an S-shaped loop), beads, a procedural organ mesh with its cage, a floor and a
// grasper — then steps it and reads what a renderer would. Built with the project
// (build/release/bin/haustra_example_build_world); run with no arguments.
#include <fmt/format.h>

#include <cmath>
#include <numbers>

#include "haustra/error.hpp"
#include "haustra/world.hpp"

int main() {
  using namespace haustra;
  WorldDesc desc;
  desc.dt = 1.0 / 240.0;
  desc.threads = 1;

  SegmentDesc colon;
  colon.name = "sigmoid";
  colon.nodes = 61;
  colon.cross_section.radius = 0.018;
  // The host's own centreline: an S in the horizontal plane, 3 cm above the floor.
  colon.rest.kind = RestShapeKind::centreline;
  colon.rest.centreline_source = "build_world.cpp";
  for (int i = 0; i <= 60; ++i) {
    const double s = static_cast<double>(i) / 60.0;
    colon.rest.centreline.emplace_back(0.5 * s, 0.06 * std::sin(2.0 * std::numbers::pi * s), 0.03);
  }
  colon.base = BaseMode::clamped;
  AttachmentDesc tip;
  tip.node = -1;  // both ends held
  colon.attachments.push_back(tip);
  colon.beads.enabled = true;
  colon.beads.count = 21;
  colon.mesh.enabled = true;
  colon.mesh.source = MeshSource::procedural;
  colon.mesh.procedural.vertices = 4000;
  desc.segments.push_back(colon);

  PlaneDesc floor;
  floor.name = "floor";
  desc.environment.planes.push_back(floor);
  InstrumentDesc grasper;
  grasper.name = "grasper";
  grasper.grasp_reach = 0.015;
  desc.instruments.push_back(grasper);

  try {
    auto world = World::create(desc);
    const MeshInfo& mesh = world->mesh(0);
    fmt::print("{} nodes, {} beads, {} mesh vertices in a cage of {} rings\n", world->node_count(), world->bead_count(),
               mesh.vertices.count, mesh.cage.rings);
    // Grasp the middle and lift it 4 cm over a second, then hold.
    const auto nodes = world->node_positions();
    const std::size_t middle = world->node_count() / 2;
    const Eigen::Vector3d start(nodes.x[middle], nodes.y[middle], nodes.z[middle] + 0.022);
    for (int f = 0; f < 480; ++f) {
      const double lift = 0.04 * std::min(1.0, world->time());
      world->set_instrument_pose(0, start + Eigen::Vector3d(0.0, 0.0, lift), Eigen::Vector3d::UnitZ());
      world->set_instrument_grasp(0, true);
      world->step();
    }
    const InstrumentReading r = world->instrument(0);
    const auto p = world->mesh_positions();
    float top = -1e9f;
    for (std::size_t v = 0; v < world->mesh_buffer_size(); ++v) top = std::max(top, p.z[v]);
    fmt::print(
        "after {:.1f} s: grasping node {}, force on the grasper ({:.3f}, {:.3f}, {:.3f}) N, mesh top at "
        "{:.3f} m\n",
        world->time(), r.grasped_node, r.force.x(), r.force.y(), r.force.z(), top);
    fmt::print("last frame: {:.0f} us\n", 1e6 * world->last_profile().frame_seconds);
    return r.grasping ? 0 : 1;
  } catch (const Error& e) {
    fmt::print(stderr, "{}\n", e.what());
    return 2;
  }
}
