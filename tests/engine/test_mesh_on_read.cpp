// The mesh at render rate (decision 0060) and deadline mode (decision 0061): a mesh made when read,
// in the caller's thread or a reader's, has the bits of the mesh made every frame; a reader holds
// a whole frame while the world steps on; frames over the budget are counted; a reader that skins
// on its GPU gets the rings' data the world gives (decision 0110).
#include <doctest/doctest.h>

#include <cstring>
#include <vector>

#include "haustra/frame_publisher.hpp"
#include "scene_fixtures.hpp"

namespace haustra {
namespace {

// A mesh's positions and normals as bytes, for comparing bits.
std::vector<unsigned char> mesh_bits(kernels::Vec3View<const float> p, kernels::Vec3View<const float> n) {
  std::vector<unsigned char> out;
  for (const auto v : {p.x, p.y, p.z, n.x, n.y, n.z}) {
    const auto* b = reinterpret_cast<const unsigned char*>(v.data());
    out.insert(out.end(), b, b + v.size_bytes());
  }
  return out;
}

std::vector<unsigned char> mesh_bits(const World& w) { return mesh_bits(w.mesh_positions(), w.mesh_normals()); }

std::vector<unsigned char> mesh_bits(const FramePublisher::Slot& s) {
  return mesh_bits({s.px, s.py, s.pz}, {s.nx, s.ny, s.nz});
}

std::unique_ptr<World> bowel(int threads, const char* update) {
  return test::scene_world("bowel", threads, {std::string("world.mesh_update=") + update});
}

}  // namespace

TEST_CASE("a mesh made when read has the bits of the mesh made every frame, with 1 and 2 threads") {
  // The bowel: 32 chained pieces with welded seams and normals, 64,576 vertices (skinned in
  // parallel chunks on 2 threads). The reference skins at the end of every frame on 1 thread.
  auto eager = bowel(1, "every_frame");
  REQUIRE(eager->mesh_update() == MeshUpdate::every_frame);
  std::vector<std::vector<unsigned char>> reference;
  std::vector<std::vector<Eigen::Vector3d>> reference_cage;
  for (int f = 0; f <= 12; ++f) {
    if (f > 0) eager->step();
    reference.push_back(mesh_bits(*eager));
    reference_cage.push_back(eager->cage_vertices(5));
  }
  for (const int threads : {1, 2}) {
    INFO("threads = " << threads);
    auto lazy = bowel(threads, "on_read");
    REQUIRE(lazy->mesh_update() == MeshUpdate::on_read);
    auto reader = bowel(threads, "on_read");  // its mesh only ever made by a FramePublisher's reader
    FramePublisher frames(*reader);
    CHECK(mesh_bits(frames.acquire()) == reference[0]);
    frames.release();
    for (int f = 1; f <= 12; ++f) {
      lazy->step();
      reader->step();
      frames.publish(*reader);
      if (f % 4 != 3) continue;  // read at frames 3, 7, 11: the frames between are never meshed
      CHECK(lazy->cage_vertices(5) == reference_cage[f]);
      CHECK(mesh_bits(*lazy) == reference[f]);
      CHECK(mesh_bits(*lazy) == reference[f]);
      CHECK(lazy->last_profile().calls[static_cast<std::size_t>(Stage::skin)] == 1);  // once, however often read
      const FramePublisher::Slot& s = frames.acquire();
      CHECK(s.frame == static_cast<std::uint64_t>(f));
      CHECK(mesh_bits(s) == reference[f]);
      frames.release();
    }
    CHECK(lazy->last_profile().calls[static_cast<std::size_t>(Stage::skin)] == 0);  // frame 12: not read, not skinned
  }
}

TEST_CASE("a reader acquiring mid-run holds one whole frame while the world steps on, in lockstep") {
  auto eager = bowel(2, "every_frame");
  auto w = bowel(2, "on_read");
  FramePublisher frames(*w);
  std::vector<std::vector<unsigned char>> reference{mesh_bits(*eager)};
  auto step_both = [&](int n) {
    for (int i = 0; i < n; ++i) {
      eager->step();
      reference.push_back(mesh_bits(*eager));
      w->step();
      frames.publish(*w);
    }
  };
  step_both(5);
  const FramePublisher::Slot& held = frames.acquire();
  REQUIRE(held.frame == 5);
  const std::vector<unsigned char> at_acquire = mesh_bits(held);
  CHECK(at_acquire == reference[5]);
  step_both(3);  // published while the slot is held: it is never written
  CHECK(held.frame == 5);
  CHECK(mesh_bits(held) == at_acquire);
  frames.release();
  const FramePublisher::Slot& next = frames.acquire();  // the newest frame, no older one
  CHECK(next.frame == 8);
  CHECK(mesh_bits(next) == reference[8]);
  frames.release();
  const FramePublisher::Slot& again = frames.acquire();  // nothing newer: the same frame, the same bits
  CHECK(again.frame == 8);
  CHECK(mesh_bits(again) == reference[8]);
  frames.release();
}

TEST_CASE("deadline mode: frames over world.frame_budget are counted in the profile and in late_frames") {
  // A budget no frame can meet (1 ns) and one every frame meets (an hour): the counts are exact.
  auto w = test::scene_world("demo", 1, {"world.frame_budget=1e-9"});
  CHECK(w->frame_budget() == 1e-9);
  for (int f = 0; f < 5; ++f) {
    w->step();
    CHECK(w->last_profile().late == 1);
  }
  CHECK(w->late_frames() == 5);
  w->set_frame_budget(3600.0);
  for (int f = 0; f < 3; ++f) w->step();
  CHECK(w->last_profile().late == 0);
  w->set_frame_budget(0.0);  // off
  w->step();
  CHECK(w->last_profile().late == 0);
  CHECK(w->late_frames() == 5);
  CHECK_THROWS_WITH_AS(w->set_frame_budget(-1.0), doctest::Contains("frame_budget"), Error);
  CHECK_THROWS_WITH_AS(test::scene_world("demo", 1, {"world.frame_budget=-0.001"}),
                       doctest::Contains("world.frame_budget"), Error);
  CHECK_THROWS_WITH_AS(test::scene_world("demo", 1, {"world.mesh_update=sometimes"}),
                       doctest::Contains("world.mesh_update"), Error);
}

TEST_CASE(
    "a reader that skins on its GPU gets the rings' data World::gpu_ring_frame gives, the same bits on 1 and 2 "
    "threads") {
  // Decision 0110: the reader's acquire makes the rings alone, from the poses the stepping thread
  // published; the world's own call makes them from its own rings.
  std::vector<std::vector<float>> one;
  for (const int threads : {1, 2}) {
    auto w = test::scene_world("demo", threads, {"segment.mesh.procedural.vertices=2000"});
    FramePublisher frames(*w);
    frames.skin_on_gpu(true);
    std::vector<float> own(kGpuRingDataFloats * w->ring_count());
    for (int f = 0; f < 12; ++f) {
      w->step();
      frames.publish(*w);
      const FramePublisher::Slot& s = frames.acquire();
      CHECK_FALSE(s.mesh_made);  // nothing skinned on the CPU
      w->gpu_ring_frame(own);
      CHECK(s.gpu_rings == own);
      frames.release();
      if (threads == 1)
        one.push_back(own);
      else
        CHECK(own == one[static_cast<std::size_t>(f)]);
    }
  }
}

}  // namespace haustra
