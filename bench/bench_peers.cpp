// haustra_bench_peers (`make bench-peers`): one rope scenario in three engines, in one run, so speed
// is never compared without accuracy. A 1.66 m rope of 167 nodes (the paper's count), radius 2 cm,
// 0.657 kg (haustra's default wall: 1050 kg/m³ × 2π·0.02·0.003 m² per metre), held at one end 1 m
// above the floor, starting horizontal, stepped 270 frames of 1/60 s on one thread:
//   - haustra: scenes/rope.toml — the Cosserat rod (the paper's laws: viscous bending and torsion,
//     elastic stretch; Newton), pinned at node 0 (a free base in the medium's drag), with 55 beads
//     of 2 cm for the floor; and again in fast mode (its last row; how far it ends from Newton's);
//   - Bullet 3.24 (libbullet-dev): btSoftBodyHelpers::CreateRope, first node fixed, bending links,
//     10 substeps of 1/600 s per frame, collision margin 2 cm;
//   - MuJoCo 2.2 (libmujoco-dev): its rope composite, 167 capsule elements of 2 cm radius on hinge
//     pairs with the rod's bending stiffness, the first welded at the anchor, 10 steps of 1/600 s.
// Prints each one's median time per frame, its ratio to haustra's, its final stretch (polyline
// length over 1.66 m, minus 1) and its deepest floor penetration (2 cm minus the lowest centre).
// All three pin the end. They are not tuned to agree on how fast the rope swings down (haustra's
// rope is quasi-static and viscous, the others dynamic): the table measures cost and the two
// accuracy figures every rope engine must get right whatever its material.
#include <BulletSoftBody/btSoftBodyHelpers.h>
#include <BulletSoftBody/btSoftBodyRigidBodyCollisionConfiguration.h>
#include <BulletSoftBody/btSoftRigidDynamicsWorld.h>
#include <btBulletDynamicsCommon.h>
#include <fmt/format.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numbers>
#include <string>
#include <vector>

#include "haustra/scene.hpp"
#include "haustra/world.hpp"

namespace {

constexpr int kNodes = 167;
constexpr double kLength = 1.66;
constexpr double kRadius = 0.02;
constexpr double kHeight = 1.0;
constexpr int kFrames = 270;
constexpr double kFrame = 1.0 / 60.0;
constexpr int kSubsteps = 10;  // Bullet and MuJoCo: explicit-ish integrators need small steps
const double kMass = 1050.0 * 2.0 * std::numbers::pi * kRadius * 0.003 * kLength;

struct Result {
  std::string engine;
  double median_us = 0.0;
  double stretch = 0.0;
  double penetration = 0.0;
  bool finite = true;
};

// Times each frame, then measures the final polyline.
Result run(const std::string& name, const std::function<void()>& step,
           const std::function<std::vector<Eigen::Vector3d>()>& nodes) {
  std::vector<double> us;
  us.reserve(kFrames);
  for (int f = 0; f < kFrames; ++f) {
    const auto t0 = std::chrono::steady_clock::now();
    step();
    us.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
  }
  std::nth_element(us.begin(), us.begin() + kFrames / 2, us.end());
  Result r{name, us[kFrames / 2]};
  const std::vector<Eigen::Vector3d> p = nodes();
  double length = 0.0, lowest = 1e9;
  for (std::size_t i = 0; i < p.size(); ++i) {
    r.finite = r.finite && p[i].allFinite();
    lowest = std::min(lowest, p[i].z());
    if (i > 0) length += (p[i] - p[i - 1]).norm();
  }
  r.stretch = length / kLength - 1.0;
  r.penetration = std::max(0.0, kRadius - lowest);
  return r;
}

// The final node positions of a run, for comparing two of haustra's.
std::vector<Eigen::Vector3d> g_final_nodes[2];

Result run_haustra(bool fast) {
  // scenes/rope.toml (the rope pinned at one end: a free base in the medium's drag, node 0 held),
  // with the floor and the paper's 55 beads added; Newton as the scene has it, or fast mode.
  haustra::SceneDesc scene = haustra::load_scene(std::string(HAUSTRA_SOURCE_DIR) + "/scenes/rope.toml");
  haustra::WorldDesc& d = scene.world;
  d.threads = 1;
  if (fast) d.solver.mode = haustra::SolverMode::fast;
  haustra::PlaneDesc floor;
  floor.name = "floor";
  d.environment.planes.push_back(floor);
  haustra::SegmentDesc& s = d.segments.at(0);
  s.beads.enabled = true;
  s.beads.count = 55;
  s.beads.radius = kRadius;
  auto w = haustra::create_world(scene);
  return run(
      fast ? "haustra, fast mode" : "haustra", [&] { w->step(); },
      [&] {
        std::vector<Eigen::Vector3d> out;
        const auto p = w->node_positions();
        for (std::size_t k = 0; k < w->node_count(); ++k) out.emplace_back(p.x[k], p.y[k], p.z[k]);
        g_final_nodes[fast ? 1 : 0] = out;
        return out;
      });
}

Result run_bullet() {
  btSoftBodyRigidBodyCollisionConfiguration config;
  btCollisionDispatcher dispatcher(&config);
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btSoftRigidDynamicsWorld world(&dispatcher, &broadphase, &solver, &config);
  world.setGravity(btVector3(0, 0, -9.81));
  btSoftBodyWorldInfo& info = world.getWorldInfo();
  info.m_gravity = btVector3(0, 0, -9.81);
  info.m_broadphase = &broadphase;
  info.m_dispatcher = &dispatcher;
  info.m_sparsesdf.Initialize();

  btStaticPlaneShape plane(btVector3(0, 0, 1), 0);
  btRigidBody ground(btRigidBody::btRigidBodyConstructionInfo(0.0, nullptr, &plane));
  world.addRigidBody(&ground);

  // res + 2 nodes; fixeds = 1 pins the first.
  btSoftBody* rope =
      btSoftBodyHelpers::CreateRope(info, btVector3(0, 0, kHeight), btVector3(kLength, 0, kHeight), kNodes - 2, 1);
  rope->m_cfg.piterations = 10;
  rope->m_materials[0]->m_kLST = 1.0;
  rope->generateBendingConstraints(2, rope->m_materials[0]);
  rope->setTotalMass(static_cast<btScalar>(kMass));
  rope->getCollisionShape()->setMargin(static_cast<btScalar>(kRadius));
  world.addSoftBody(rope);
  Result r = run(
      "Bullet 3.24 soft-body rope", [&] { world.stepSimulation(kFrame, kSubsteps, kFrame / kSubsteps); },
      [&] {
        std::vector<Eigen::Vector3d> out;
        for (int i = 0; i < rope->m_nodes.size(); ++i) {
          const btVector3& x = rope->m_nodes[i].m_x;
          out.emplace_back(x.x(), x.y(), x.z());
        }
        return out;
      });
  world.removeSoftBody(rope);
  delete rope;
  world.removeRigidBody(&ground);
  return r;
}

// The MJCF of the rope: MuJoCo 2.2's rope composite, 167 element bodies 1 cm apart (two hinges
// between neighbours, each with the rod's bending stiffness B/h), the first welded to the world at
// the anchor (its body rB0 is the composite's root). Rope geoms collide with the floor only.
std::string mujoco_rope_xml() {
  const double h = kLength / (kNodes - 1);
  const double bending = std::numbers::pi * 33.2e3 * kRadius * kRadius * kRadius * 0.003;  // B, N·m²
  return fmt::format(
      "<mujoco><option timestep=\"{}\" gravity=\"0 0 -9.81\" solver=\"CG\" jacobian=\"sparse\"/><size nconmax=\"2000\" "
      "njmax=\"4000\"/>\n"
      "<worldbody><geom type=\"plane\" size=\"5 5 0.1\" contype=\"0\" conaffinity=\"1\"/>\n"
      "<body name=\"rB0\" pos=\"0 0 {}\">\n"
      "<composite type=\"rope\" count=\"{} 1 1\" spacing=\"{}\" offset=\"0 0 0\" prefix=\"r\">\n"
      "<joint kind=\"main\" stiffness=\"{}\" damping=\"{}\"/>\n"
      "<geom type=\"capsule\" size=\"{} {}\" mass=\"{}\" contype=\"1\" conaffinity=\"0\" condim=\"1\"/>\n"
      "</composite></body></worldbody></mujoco>\n",
      kFrame / kSubsteps, kHeight, kNodes, h, bending / h, 0.1 * bending / h, kRadius, 0.5 * h, kMass / kNodes);
}

Result run_mujoco() {
  const auto file = std::filesystem::temp_directory_path() / "haustra-peers-rope.xml";
  std::ofstream(file) << mujoco_rope_xml();
  char error[1000] = "";
  mjModel* m = mj_loadXML(file.c_str(), nullptr, error, sizeof error);
  std::filesystem::remove(file);
  if (m == nullptr) throw std::runtime_error(std::string("MuJoCo: ") + error);
  mjData* d = mj_makeData(m);
  mj_forward(m, d);
  Result r = run(
      fmt::format("MuJoCo {:.1f} rope composite", mj_version() / 100.0),
      [&] {
        for (int s = 0; s < kSubsteps; ++s) mj_step(m, d);
      },
      [&] {
        std::vector<Eigen::Vector3d> out;  // node k: element body k (body 0 is the world)
        for (int b = 1; b < m->nbody; ++b) out.emplace_back(d->xpos[3 * b], d->xpos[3 * b + 1], d->xpos[3 * b + 2]);
        return out;
      });
  mj_deleteData(d);
  mj_deleteModel(m);
  return r;
}

}  // namespace

int main() {
  try {
    std::vector<Result> results{run_haustra(false), run_bullet(), run_mujoco(), run_haustra(true)};
    fmt::print(
        "rope: {} m, {} nodes, radius {} m, {:.3f} kg, held at one end {} m above the floor, starting "
        "horizontal; {} frames of 1/60 s, one thread\n\n",
        kLength, kNodes, kRadius, kMass, kHeight, kFrames);
    fmt::print("| engine | median µs per frame | × haustra | final stretch | floor penetration | finite |\n");
    fmt::print("|---|---|---|---|---|---|\n");
    for (const Result& r : results)
      fmt::print("| {} | {:.1f} | {:.2f} | {:+.2f} % | {:.1f} mm ({:.0f} % of r) | {} |\n", r.engine, r.median_us,
                 r.median_us / results[0].median_us, 100.0 * r.stretch, 1000.0 * r.penetration,
                 100.0 * r.penetration / kRadius, r.finite ? "yes" : "NO");
    // Fast mode is another trade (docs/tradeoff.md): how far its rope ends from Newton's.
    double apart = 0.0;
    for (std::size_t k = 0; k < g_final_nodes[0].size(); ++k)
      apart = std::max(apart, (g_final_nodes[0][k] - g_final_nodes[1][k]).norm());
    fmt::print("\nBullet / haustra fast mode: {:.2f}×; fast mode's final nodes within {:.1f} mm of Newton's\n",
               results[1].median_us / results[3].median_us, 1000.0 * apart);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench-peers: %s\n", e.what());
    return 1;
  }
}
