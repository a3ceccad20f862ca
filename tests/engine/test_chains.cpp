// Chained segments (decision 0030) and segments added or removed between frames (decision 0031).
// Oracles: a chain against the single rod of the same nodes and beads, bit for bit; a world that
// gains or loses a far-away segment against a world that never had it, bit for bit.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <numbers>

#include "haustra/error.hpp"
#include "haustra/scene.hpp"
#include "haustra/world.hpp"
#include "scene_fixtures.hpp"

using namespace haustra;

namespace {

// `drop` (a rectum falling onto the floor and onto itself) as 7 chained pieces of 25 nodes with
// 9 beads each, or as the one rod of the same 169 nodes and 57 beads (every third node).
SceneDesc drop_as(bool chained) {
  SceneDesc s = test::scene_desc("drop");
  SegmentDesc& d = s.world.segments.at(0);
  if (chained) {
    d.chain_pieces = 7;
    d.nodes = 25;
    d.beads.count = 9;
  } else {
    d.nodes = 169;
    d.beads.count = 57;
  }
  return s;
}

bool same_bits(std::span<const double> a, std::span<const double> b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

bool same_nodes(const World& a, const World& b) {
  const auto pa = a.node_positions(), pb = b.node_positions();
  const auto ra = a.node_rotations(), rb = b.node_rotations();
  return same_bits(pa.x, pb.x) && same_bits(pa.y, pb.y) && same_bits(pa.z, pb.z) && same_bits(ra.w, rb.w) &&
         same_bits(ra.x, rb.x) && same_bits(a.strains().data, b.strains().data);
}

// Node positions and strains of one segment's nodes.
std::vector<double> segment_state(const World& w, std::size_t segment) {
  const Range nodes = w.segment(segment).nodes;
  std::vector<double> out;
  const auto p = w.node_positions();
  const auto q = w.strains();
  for (std::size_t k = nodes.offset; k < nodes.offset + nodes.count; ++k) {
    out.insert(out.end(), {p.x[k], p.y[k], p.z[k]});
    for (std::size_t c = 0; c < 4; ++c) out.push_back(q.at(k, c));
  }
  return out;
}

// The scene's first segment again, 3 m away: it never touches the original.
SegmentDesc far_copy(const SceneDesc& s) {
  SegmentDesc far = s.world.segments.at(0);
  far.name = "far";
  far.base_position.y() += 3.0;
  return far;
}

}  // namespace

TEST_CASE("a chain steps exactly as the single rod of its nodes: joints hold position and frame") {
  auto chain = create_world(drop_as(true));
  auto rod = create_world(drop_as(false));
  REQUIRE(chain->segment_count() == 7);
  REQUIRE(rod->segment_count() == 1);
  REQUIRE(chain->node_count() == 169);
  REQUIRE(chain->bead_count() == 57);
  CHECK(std::equal(chain->bead_nodes().begin(), chain->bead_nodes().end(), rod->bead_nodes().begin(),
                   rod->bead_nodes().end()));
  std::size_t most_touching = 0;
  for (int f = 0; f < 150; ++f) {
    chain->step();
    rod->step();
    most_touching = std::max(most_touching, chain->contacts().touching);
  }
  CHECK(same_nodes(*chain, *rod));
  CHECK(most_touching > 10);  // it landed and piled on itself: the joints went through contact

  // Pieces: names, node ranges overlapping by their joint node, beads partitioned, one chain.
  std::size_t beads = 0;
  for (std::size_t p = 0; p < 7; ++p) {
    const SegmentInfo& info = chain->segment(p);
    CHECK(info.name == "rectum-" + std::to_string(p + 1));
    CHECK(info.nodes.count == 25);
    CHECK(info.nodes.offset == 24 * p);
    CHECK(chain->chain_of(p) == 0);
    const Range b = chain->beads(p);
    CHECK(b.offset == beads);
    beads += b.count;
    if (p + 1 < 7) {
      // The next piece's base is this piece's tip, position and frame, after 150 frames of motion.
      const std::size_t tip = info.nodes.offset + info.nodes.count - 1;
      const kernels::Pose next = chain->base_pose(p + 1);
      CHECK(next.position == chain->node_positions().get(tip));
      CHECK(next.rotation.coeffs() == chain->node_rotations().get(tip).coeffs());
    }
  }
  CHECK(beads == 57);
}

TEST_CASE("each piece of a chain carries its own mesh, which follows the piece") {
  SceneDesc s = drop_as(true);
  SegmentDesc& d = s.world.segments[0];
  d.mesh.enabled = true;
  d.mesh.procedural.vertices = 1000;
  d.mesh.procedural.end_taper = 0.05;
  auto w = create_world(s);
  for (int f = 0; f < 60; ++f) w->step();
  const auto m = w->mesh_positions();
  std::size_t vertices = 0;
  double worst = 0.0;
  for (std::size_t p = 0; p < w->segment_count(); ++p) {
    const MeshInfo& mesh = w->mesh(p);
    REQUIRE(mesh.enabled);
    CHECK(mesh.vertices.offset == vertices);
    vertices += mesh.vertices.count;
    const Range nodes = w->segment(p).nodes;
    // Every vertex stays within the tube around its own piece's nodes (radius 2 cm, haustral
    // bulges and a node spacing of 1 cm: 3 cm is generous and still far below the 24 cm piece).
    for (std::size_t v = mesh.vertices.offset; v < mesh.vertices.offset + mesh.vertices.count; ++v) {
      double nearest = 1e9;
      const Eigen::Vector3d x(m.x[v], m.y[v], m.z[v]);
      for (std::size_t k = nodes.offset; k < nodes.offset + nodes.count; ++k)
        nearest = std::min(nearest, (x - w->node_positions().get(k)).norm());
      worst = std::max(worst, nearest);
    }
  }
  CHECK(vertices == w->mesh_buffer_size());
  CHECK(worst < 0.03);
  CHECK(worst > 0.015);  // the wall, not the centreline: the check measures something
}

// World::mesh_vertex_nodes (decision 0121) on procedural meshes: a chain's vertices each on a node of
// their own piece, near it (the tube's radius, 2 cm, and its bulges); a world whose first segment has
// no mesh gives the second's vertices the second's nodes (the buffers' offsets).
TEST_CASE("each mesh vertex's node is on its own piece, beside it, and on its own segment") {
  SceneDesc s = drop_as(true);
  SegmentDesc& d = s.world.segments[0];
  d.mesh.enabled = true;
  d.mesh.procedural.vertices = 1000;
  auto chain = create_world(s);
  const std::vector<std::uint32_t> node_of = chain->mesh_vertex_nodes();
  REQUIRE(node_of.size() == chain->mesh_buffer_size());
  const auto x = chain->mesh_positions();
  double farthest = 0.0;
  for (std::size_t p = 0; p < chain->segment_count(); ++p) {
    const Range nodes = chain->segment(p).nodes, vertices = chain->mesh(p).vertices;
    for (std::size_t v = vertices.offset; v < vertices.offset + vertices.count; ++v) {
      CHECK(node_of[v] >= nodes.offset);
      CHECK(node_of[v] < nodes.offset + nodes.count);
      farthest = std::max(farthest, (x.get(v) - chain->node_positions().get(node_of[v])).norm());
    }
  }
  MESSAGE("farthest vertex from its node: " << farthest * 1e3 << " mm");
  CHECK(farthest < 0.03);
  CHECK(farthest > 0.015);  // the wall, not the centreline

  SceneDesc two = drop_as(false);
  two.world.segments.push_back(far_copy(two));
  two.world.segments[1].mesh.enabled = true;
  two.world.segments[1].mesh.procedural.vertices = 1000;
  auto world = create_world(two);
  const std::vector<std::uint32_t> second = world->mesh_vertex_nodes();
  REQUIRE(second.size() == world->mesh(1).vertices.count);
  const Range nodes = world->segment(1).nodes;
  for (const std::uint32_t k : second) {
    CHECK(k >= nodes.offset);
    CHECK(k < nodes.offset + nodes.count);
  }
}

TEST_CASE("a chain with a mesh file: each piece gets the part of the surface along it and its own cage") {
  // The CT colon as one segment, then as a chain of 3 pieces of the same 163 nodes.
  SceneDesc one = test::scene_desc("anatomy-grasp");
  one.world.segments[0].nodes = 163;
  one.world.segments[0].beads.count = 54;
  one.world.segments[0].beads.radius_from_mesh = false;
  one.world.segments[0].beads.radius = 0.018;
  SceneDesc chain = one;
  chain.world.segments[0].nodes = 55;
  chain.world.segments[0].chain_pieces = 3;
  chain.world.segments[0].beads.count = 18;
  const auto whole = create_world(one);
  const auto w = create_world(chain);
  REQUIRE(w->segment_count() == 3);
  std::size_t triangles = 0;
  for (std::size_t p = 0; p < 3; ++p) {
    const MeshInfo& m = w->mesh(p);
    MESSAGE("piece " << p << ": " << m.triangles.count << " triangles, cage of " << m.cage.rings << " rings");
    CHECK(m.triangles.count > 3000);  // each a fair share of 19,838
    CHECK(m.cage.mesh_vertices_outside == 0);
    triangles += m.triangles.count;
  }
  CHECK(triangles == whole->mesh(0).triangles.count);  // every triangle in exactly one piece

  // The cut: vertices that two pieces share at rest (one point, bit for bit), found by brute force.
  std::vector<std::array<float, 3>> rest;
  const auto at_rest = w->mesh_positions();
  for (std::size_t v = 0; v < at_rest.size(); ++v) rest.push_back({at_rest.x[v], at_rest.y[v], at_rest.z[v]});
  std::map<std::array<float, 3>, std::vector<std::uint32_t>> at;
  for (std::uint32_t v = 0; v < rest.size(); ++v) at[rest[v]].push_back(v);
  std::vector<std::uint32_t> first(rest.size());
  std::vector<std::vector<std::uint32_t>> seams;
  for (const auto& [point, copies] : at) {
    for (std::uint32_t v : copies) first[v] = copies.front();
    if (copies.size() > 1) seams.push_back(copies);
  }
  MESSAGE(seams.size() << " vertices on the cuts");
  CHECK(seams.size() > 50);  // two cuts round a colon of ~9,958 vertices

  // Grasped and pulled (the scene's grasper), the pieces bend apart at their cuts.
  for (int f = 0; f < 80; ++f) w->step();
  const auto p = w->mesh_positions();
  for (std::size_t v = 0; v < p.size(); ++v) REQUIRE(std::isfinite(p.x[v] + p.y[v] + p.z[v]));
  CHECK(w->events().empty());
  double moved = 0.0;
  for (std::size_t v = 0; v < p.size(); ++v)
    moved = std::max(moved, double(std::hypot(p.x[v] - rest[v][0], p.y[v] - rest[v][1], p.z[v] - rest[v][2])));
  MESSAGE("the surface moved up to " << moved << " m");
  CHECK(moved > 0.01);
  // The cut stays closed: every copy where the others are (each piece's own cage put them up to
  // 2 mm apart before they were welded).
  for (const auto& copies : seams)
    for (std::uint32_t v : copies) {
      CHECK(p.x[v] == p.x[copies.front()]);
      CHECK(p.y[v] == p.y[copies.front()]);
      CHECK(p.z[v] == p.z[copies.front()]);
    }
  // And its normals are the whole surface's: area-weighted over every triangle round the point,
  // in double from the world's positions (the oracle), to float rounding.
  std::vector<Eigen::Vector3d> normal(p.size(), Eigen::Vector3d::Zero());
  auto point = [&](std::uint32_t v) { return Eigen::Vector3d(p.x[v], p.y[v], p.z[v]); };
  for (const auto& t : w->mesh_triangles()) {
    const Eigen::Vector3d n = (point(t[1]) - point(t[0])).cross(point(t[2]) - point(t[0]));
    for (std::uint32_t v : t) normal[first[v]] += n;
  }
  const auto nw = w->mesh_normals();
  double worst = 0.0;
  for (const auto& copies : seams)
    for (std::uint32_t v : copies)
      worst =
          std::max(worst, (Eigen::Vector3d(nw.x[v], nw.y[v], nw.z[v]) - normal[copies.front()].normalized()).norm());
  MESSAGE("seam normals within " << worst << " of the whole surface's");
  CHECK(worst < 1e-6);  // measured 9.8e-8

  // No crease where the pieces meet (issue 35): at each point, the angle between its normal and
  // the mean of its neighbours' (area-weighted, in double, over the whole surface) changes from
  // rest no more on the cuts than inside the pieces (a crease would turn the cut's alone; the
  // largest inside is where the grasp folds the CT mesh's small triangles).
  const auto triangles_all = w->mesh_triangles();
  auto normals_at = [&](auto position) {
    std::vector<Eigen::Vector3d> n(rest.size(), Eigen::Vector3d::Zero());
    for (const auto& t : triangles_all) {
      const Eigen::Vector3d c = (position(t[1]) - position(t[0])).cross(position(t[2]) - position(t[0]));
      for (std::uint32_t v : t) n[first[v]] += c;
    }
    return n;
  };
  const auto n_rest = normals_at([&](std::uint32_t v) { return Eigen::Vector3d(rest[v][0], rest[v][1], rest[v][2]); });
  const auto n_now = normals_at(point);
  std::vector<std::vector<std::uint32_t>> around(rest.size());
  for (const auto& t : triangles_all)
    for (std::size_t j = 0; j < 3; ++j) around[first[t[j]]].push_back(first[t[(j + 1) % 3]]);
  auto bend = [&](const std::vector<Eigen::Vector3d>& n, std::uint32_t v) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (std::uint32_t u : around[v]) mean += n[u].normalized();
    const Eigen::Vector3d a = n[v].normalized();
    return std::atan2(a.cross(mean).norm(), a.dot(mean)) * 180.0 / std::numbers::pi;
  };
  double seam_crease = 0.0, inside_crease = 0.0;
  for (std::uint32_t v = 0; v < rest.size(); ++v) {
    if (first[v] != v || around[v].empty()) continue;
    const double change = std::abs(bend(n_now, v) - bend(n_rest, v));
    double& worst_here = at[rest[v]].size() > 1 ? seam_crease : inside_crease;
    worst_here = std::max(worst_here, change);
  }
  MESSAGE("a point's normal against its neighbours' turned from rest by at most "
          << seam_crease << " degrees on the cuts, " << inside_crease << " inside");
  CHECK(seam_crease <= 1.1 * inside_crease);  // measured 18.1 and 18.7 degrees
}

TEST_CASE("the bowel scene: 32 chained segments in a box, touching each other, a grasper lifts a loop") {
  SceneDesc s = test::scene_desc("bowel");
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  s.world.segments[0].mesh.enabled = false;  // the meshes' cages and weights: most of the time under ASan
#endif
  auto w = create_world(s);
  REQUIRE(w->segment_count() >= 32);
  for (int f = 0; f < 45; ++f) w->step();  // the grasper closes at 0.5 s (frame 30) and lifts
  CHECK(w->events().empty());
  const InstrumentReading g = w->instrument(0);
  CHECK(g.grasping);
  CHECK(g.force.norm() > 0.05);  // it holds some of the loop's weight (~30 g)
  // Inter-segment contact: touching beads of pieces that are not neighbours along the chain.
  std::size_t between_pieces = 0;
  const auto bead_nodes = w->bead_nodes();
  auto piece_of_bead = [&](std::size_t b) {
    for (std::size_t p = 0; p < w->segment_count(); ++p)
      if (b >= w->beads(p).offset && b < w->beads(p).offset + w->beads(p).count) return p;
    return w->segment_count();
  };
  for (const Contact& c : w->contact_list()) {
    if (c.kind != ContactKind::bead || c.depth <= 0.0) continue;
    const std::size_t a = piece_of_bead(c.bead), b = piece_of_bead(c.other);
    if (a + 1 < b || b + 1 < a) ++between_pieces;
    CHECK(bead_nodes[c.bead] != bead_nodes[c.other]);
  }
  CHECK(between_pieces > 5);
  const ContactReport& r = w->contacts();
  CHECK(r.max_environment_depth_ratio < 0.15);
  CHECK(r.max_bead_overlap_ratio < 0.15);
}

TEST_CASE("chains refuse what they cannot do, by name") {
  auto refuse = [](auto&& change, const std::string& field, const std::string& words) {
    SceneDesc s = drop_as(true);
    change(s.world.segments[0]);
    try {
      create_world(s);
      FAIL("accepted");
    } catch (const Error& e) {
      CHECK(std::string(e.what()).find(field) != std::string::npos);
      CHECK(std::string(e.what()).find(words) != std::string::npos);
    }
  };
  refuse([](SegmentDesc& d) { d.chain_pieces = 0; }, "segment[0].chain.pieces", "[1, 4096]");
  refuse(
      [](SegmentDesc& d) {
        d.mesh.enabled = true;
        d.mesh.source = MeshSource::file;
        d.mesh.file = "x.obj";
      },
      "segment[0].mesh.file", "no such mesh file");
  refuse(
      [](SegmentDesc& d) {
        d.beads.count = 0;
        d.beads.nodes = {0, 5};
      },
      "segment[0].beads.nodes", "per piece");

  auto w = create_world(drop_as(true));
  const std::vector<double> strains(4 * 169, 0.0);
  CHECK_THROWS_WITH_AS(w->pose_rod(3, {}, strains), doctest::Contains("later piece of the chain 'rectum'"), Error);
  CHECK_THROWS_WITH_AS(w->remove_segment(2), doctest::Contains("removed whole, through its first segment 'rectum-1'"),
                       Error);
  w->pose_rod(0, w->base_pose(0), std::vector<double>(w->strains().data.begin(), w->strains().data.end()));
}

TEST_CASE("a segment added between frames leaves the others' motion unchanged, bit for bit, in every solver mode") {
  // Two rectums far apart (3 m), each falling on the floor: neither ever touches the other. Fast
  // mode's chord factorization carries over with the rod it belongs to (added at frame 4, between
  // two refactorizations).
  const char* mode = "newton";
  int before = 40;
  SUBCASE("Newton") {}
  SUBCASE("fast") {
    mode = "fast";
    before = 4;
  }
  SUBCASE("lagged") { mode = "lagged"; }
  SceneDesc one = test::scene_desc("drop", {std::string("solver.mode=") + mode});
  SceneDesc two = one;
  const SegmentDesc far = far_copy(one);
  two.world.segments.push_back(far);

  auto grown = create_world(one);
  auto alone = create_world(one);
  auto both = create_world(two);
  for (int f = 0; f < before; ++f) {
    grown->step();
    alone->step();
    both->step();
  }
  const std::size_t added = grown->add_segment(far);
  CHECK(added == 1);
  REQUIRE(grown->segment_count() == 2);
  CHECK(grown->frame() == static_cast<std::uint64_t>(before));
  CHECK(segment_state(*grown, 0) == segment_state(*alone, 0));
  // The newcomer starts from its rest pose, as a fresh world's would.
  auto fresh = create_world(two);
  CHECK(segment_state(*grown, 1) == segment_state(*fresh, 1));
  for (int f = 0; f < 40; ++f) {
    grown->step();
    alone->step();
    fresh->step();
  }
  CHECK(segment_state(*grown, 0) == segment_state(*alone, 0));
  // It fell as in a fresh world — where the world's robust mode is on the rung a fresh world starts
  // on: the lagged `drop` climbs to Newton in its first frames, and the rung is the world's, so a
  // rod added later steps with Newton where a fresh world's starts lagged.
  if (std::string(mode) != "lagged") CHECK(segment_state(*grown, 1) == segment_state(*fresh, 1));

  // Refused additions leave the world as it was.
  SegmentDesc bad = far;
  bad.name = "rectum";
  CHECK_THROWS_WITH_AS(grown->add_segment(bad), doctest::Contains("used twice"), Error);
  CHECK(grown->segment_count() == 2);
  grown->step();
  alone->step();
  CHECK(segment_state(*grown, 0) == segment_state(*alone, 0));
}

TEST_CASE("a segment removed between frames leaves the others stepping on, bit for bit") {
  SceneDesc one = test::scene_desc("drop");
  SceneDesc two = one;
  const SegmentDesc far = far_copy(one);
  two.world.segments.insert(two.world.segments.begin(), far);  // the far one first: removal moves the other down
  auto shrunk = create_world(two);
  auto alone = create_world(one);
  test::step_both(*shrunk, *alone, 40);
  CHECK(segment_state(*shrunk, 1) == segment_state(*alone, 0));
  shrunk->remove_segment(0);
  REQUIRE(shrunk->segment_count() == 1);
  CHECK(shrunk->segment(0).name == "rectum");
  CHECK(shrunk->node_count() == alone->node_count());
  test::step_both(*shrunk, *alone, 40);
  CHECK(same_nodes(*shrunk, *alone));
  CHECK_THROWS_AS(shrunk->remove_segment(1), Error);
  shrunk->remove_segment(0);
  CHECK(shrunk->segment_count() == 0);
  shrunk->step();  // an empty world steps
}

TEST_CASE("a grasp survives a segment added beside it, and removing the grasped segment lets it go") {
  SceneDesc s = test::scene_desc("grasp-pull");
  const SegmentDesc far = far_copy(s);
  auto changed = create_world(s);
  auto unchanged = create_world(s);
  test::step_both(*changed, *unchanged, 60);  // the jaws close at 0.6 s (frame 36) and lift
  REQUIRE(changed->instrument(0).grasping);
  changed->add_segment(far);
  CHECK(changed->instrument(0).grasping);
  CHECK(changed->instrument(0).grasped_segment == 0);
  test::step_both(*changed, *unchanged, 30);
  CHECK(segment_state(*changed, 0) == segment_state(*unchanged, 0));
  CHECK(changed->instrument(0).force == unchanged->instrument(0).force);
  // A checkpoint of the grown world restores into it, not into the world it grew from.
  const std::vector<std::byte> grown = changed->save_checkpoint();
  CHECK_THROWS_AS(unchanged->restore_checkpoint(grown), Error);
  changed->restore_checkpoint(grown);

  changed->remove_segment(0);  // the grasped one
  CHECK_FALSE(changed->instrument(0).grasping);
  CHECK(changed->segment(0).name == "far");
  for (int f = 0; f < 10; ++f) changed->step();
  CHECK(changed->events().empty());
}

TEST_CASE("a coupled grasp keeps its node when a segment before it is removed") {
  // The grasped node is a world index: removing segment 0 renumbers every later node.
  SceneDesc s = test::scene_desc("grasp-pull");
  SceneDesc with_far = s;
  with_far.world.segments.insert(with_far.world.segments.begin(), far_copy(s));
  auto changed = create_world(with_far);
  auto unchanged = create_world(s);
  test::step_both(*changed, *unchanged, 60);  // grasping from frame 36, lifting
  REQUIRE(changed->instrument(0).grasping);
  REQUIRE(changed->instrument(0).grasped_segment == 1);
  changed->remove_segment(0);  // the far one, before the grasped one
  REQUIRE(changed->instrument(0).grasping);
  CHECK(changed->instrument(0).grasped_segment == 0);
  test::step_both(*changed, *unchanged, 30);
  CHECK(segment_state(*changed, 0) == segment_state(*unchanged, 0));
  CHECK(changed->instrument(0).force == unchanged->instrument(0).force);
}

TEST_CASE("reconfigure: the same description steps on bit for bit, a new one from frame 0 is a fresh world of it") {
  SceneDesc s = test::scene_desc("grasp-pull");
  auto changed = create_world(s);
  auto unchanged = create_world(s);
  test::step_both(*changed, *unchanged, 60);  // grasping from frame 36
  changed->reconfigure(changed->desc());
  CHECK(changed->frame() == 60);
  CHECK(changed->instrument(0).grasping);
  test::step_both(*changed, *unchanged, 30);
  CHECK(segment_state(*changed, 0) == segment_state(*unchanged, 0));
  CHECK(changed->instrument(0).force == unchanged->instrument(0).force);

  // Gravity and the solver changed before the first frame: the same bits as a world built so.
  SceneDesc other = s;
  other.world.gravity = {0.0, 0.0, -4.0};
  other.world.solver.iterations = 3;
  auto reconfigured = create_world(s);
  reconfigured->reconfigure(other.world);
  auto built = create_world(other);
  test::step_both(*reconfigured, *built, 60);
  CHECK(segment_state(*reconfigured, 0) == segment_state(*built, 0));
  CHECK(reconfigured->desc().solver.iterations == 3);
}

TEST_CASE("reconfigure: new beads let a grasp go, new nodes or instruments are refused and leave the world as it was") {
  SceneDesc s = test::scene_desc("grasp-pull");
  auto w = create_world(s);
  for (int f = 0; f < 60; ++f) w->step();
  REQUIRE(w->instrument(0).grasping);
  const std::size_t beads = w->bead_count();

  WorldDesc more_nodes = w->desc();
  more_nodes.segments[0].nodes += 10;
  CHECK_THROWS_WITH_AS(w->reconfigure(more_nodes), doctest::Contains("keeps every segment's nodes: segments[0]"),
                       Error);
  WorldDesc no_instruments = w->desc();
  no_instruments.instruments.clear();
  CHECK_THROWS_WITH_AS(w->reconfigure(no_instruments), doctest::Contains("keeps the instruments"), Error);
  CHECK(w->instrument(0).grasping);

  WorldDesc fewer_beads = w->desc();
  fewer_beads.segments[0].beads.count = static_cast<int>(beads / 2);
  fewer_beads.segments[0].beads.spacing = 0.0;
  fewer_beads.segments[0].beads.nodes.clear();
  w->reconfigure(fewer_beads);
  CHECK(w->bead_count() == beads / 2);
  CHECK_FALSE(w->instrument(0).grasping);
  CHECK(w->frame() == 60);
  for (int f = 0; f < 30; ++f) w->step();  // the organ falls back without incident
  CHECK(w->events().empty());
}
