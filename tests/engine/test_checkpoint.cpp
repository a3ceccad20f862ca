// Checkpoints: save → restore → step equals uninterrupted stepping, bit for bit; a checkpoint that
// does not belong to the world is refused by name and leaves the world as it was.
#include <doctest/doctest.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>

#include "haustra/error.hpp"
#include "haustra/profile.hpp"
#include "haustra/scene.hpp"
#include "haustra/world.hpp"
#include "minimal_scene.hpp"
#include "scene_fixtures.hpp"

using namespace haustra;

namespace {

std::unique_ptr<World> scene_world(const std::string& name, std::vector<std::string> sets = {}) {
  return test::scene_world(name, 1, std::move(sets));
}

// Everything a host can read after a frame, as bits: nodes, frames, mesh, normals, instruments.
std::vector<unsigned char> outputs(const World& w) {
  std::vector<unsigned char> out;
  auto put = [&](const auto* data, std::size_t n) {
    const auto* p = reinterpret_cast<const unsigned char*>(data);
    out.insert(out.end(), p, p + n * sizeof(*data));
  };
  const auto p = w.node_positions();
  put(p.x.data(), p.x.size()), put(p.y.data(), p.y.size()), put(p.z.data(), p.z.size());
  const auto r = w.node_rotations();
  put(r.w.data(), r.w.size()), put(r.x.data(), r.x.size());
  const auto s = w.strains();
  put(s.data.data(), s.data.size());
  const auto m = w.mesh_positions();
  put(m.x.data(), m.x.size()), put(m.z.data(), m.z.size());
  const auto n = w.mesh_normals();
  put(n.y.data(), n.y.size());
  for (std::size_t i = 0; i < w.instrument_count(); ++i) {
    const InstrumentReading ir = w.instrument(i);
    put(ir.force.data(), 3), put(ir.filtered_force.data(), 3), put(ir.tip.data(), 3);
    const int flags[3] = {ir.grasping ? 1 : 0, ir.closed ? 1 : 0, ir.cutting ? 1 : 0};
    put(flags, 3);
  }
  for (std::size_t seg = 0; seg < w.segment_count(); ++seg)
    for (std::size_t a = 0; a < w.attachment_count(seg); ++a) {
      const AttachmentReading ar = w.attachment(seg, a);
      const int active = ar.active ? 1 : 0;
      put(ar.target.data(), 3), put(&active, 1), put(&ar.node, 1);
    }
  const double t = w.time();
  put(&t, 1);
  return out;
}

// Steps `before` frames, checkpoints, steps `after` more; a second world restores the checkpoint
// and steps `after`: both must agree bit for bit at every one of those frames.
void check_round_trip(const std::string& scene, int before, int after, std::vector<std::string> sets = {}) {
  auto original = scene_world(scene, sets);
  for (int f = 0; f < before; ++f) original->step();
  const std::vector<std::byte> checkpoint = original->save_checkpoint();
  auto restored = scene_world(scene, sets);
  restored->restore_checkpoint(checkpoint, scene);
  CHECK(restored->frame() == original->frame());
  CHECK(outputs(*restored) == outputs(*original));
  for (int f = 0; f < after; ++f) {
    original->step();
    restored->step();
    INFO(scene << ": frame " << original->frame());
    REQUIRE(outputs(*restored) == outputs(*original));
  }
}

}  // namespace

TEST_CASE("checkpoint, restore and step on: the same bits as never having stopped") {
  // A free rod on the floor with beads, self-contact, a grasper closing and lifting, the filter,
  // Newton with extra iterations, and a 10,000-vertex mesh; saved mid-grasp (frame 45: the jaws
  // closed at 36) and while lifting.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  // The same paths with a coarser mesh: skinning 10,000 vertices is most of the time under ASan.
  SUBCASE("demo: grasp, contacts, mesh") {
    check_round_trip("demo", 45, 30, {"segment.mesh.procedural.vertices=2000"});
  }
#else
  SUBCASE("demo: grasp, contacts, mesh") { check_round_trip("demo", 45, 30); }
#endif
  SUBCASE("grasp-pull, saved before the grasp") { check_round_trip("grasp-pull", 20, 30); }
  // The lagged scheme with the robust mode's state (its rung, calm frames) and clamped ropes.
  SUBCASE("ropes, lagged") { check_round_trip("ropes", 25, 25, {"solver.mode=lagged"}); }
  // Fast mode's chord factorization goes with the state: saved on a frame that reuses the one
  // made at frame 0 (kRefactorFrames, 8), restored, and stepped past its next refactorization (it
  // drifted 0.2 mm in 20 frames when the checkpoint left it out).
  SUBCASE("drop, fast mode") { check_round_trip("drop", 4, 20, {"solver.mode=fast"}); }
  SUBCASE("drop, Newton") { check_round_trip("drop", 4, 20, {"solver.mode=newton"}); }
  SUBCASE("drop, lagged") { check_round_trip("drop", 4, 20, {"solver.mode=lagged"}); }
}

TEST_CASE("restoring into the same world rewinds it") {
  auto w = scene_world("grasp-pull");
  for (int f = 0; f < 30; ++f) w->step();
  const std::vector<std::byte> at30 = w->save_checkpoint();
  for (int f = 0; f < 20; ++f) w->step();
  const std::vector<unsigned char> at50 = outputs(*w);
  w->restore_checkpoint(at30);
  CHECK(w->frame() == 30);
  for (int f = 0; f < 20; ++f) w->step();
  CHECK(outputs(*w) == at50);
}

TEST_CASE("a checkpoint file round-trips, and a refused one leaves the world as it was") {
  const auto dir = std::filesystem::temp_directory_path() / "haustra-checkpoint-test";
  std::filesystem::create_directories(dir);
  const std::string file = (dir / "grasp.ckpt").string();
  auto w = scene_world("grasp-pull");
  for (int f = 0; f < 40; ++f) w->step();
  w->save_checkpoint_file(file);
  CHECK_FALSE(std::filesystem::exists(file + ".partial"));
  for (int f = 0; f < 10; ++f) w->step();
  const std::vector<unsigned char> at50 = outputs(*w);
  auto copy = scene_world("grasp-pull");
  copy->restore_checkpoint_file(file);
  for (int f = 0; f < 10; ++f) copy->step();
  CHECK(outputs(*copy) == at50);

  const std::vector<std::byte> good = w->save_checkpoint();
  auto refused = [&](std::span<const std::byte> bytes, const std::string& words) {
    const std::vector<unsigned char> before = outputs(*w);
    const std::uint64_t frame = w->frame();
    try {
      w->restore_checkpoint(bytes, "bad.ckpt");
      FAIL("restore accepted a bad checkpoint: " << words);
    } catch (const Error& e) {
      CHECK(e.code() == ErrorCode::parse);
      const std::string what = e.what();
      INFO(what);
      CHECK(what.find("bad.ckpt") != std::string::npos);
      CHECK(what.find(words) != std::string::npos);
    }
    CHECK(w->frame() == frame);
    CHECK(outputs(*w) == before);
  };
  SUBCASE("another scene") { refused(scene_world("ropes")->save_checkpoint(), "saved from a world of"); }
  SUBCASE("the same sizes, another rod") {
    refused(scene_world("grasp-pull", {"segment[0].youngs_modulus=50000", "segment[0].wall_thickness=0.004"})
                ->save_checkpoint(),
            "another rod");
  }
  SUBCASE("a grasp rigid in the checkpoint, coupled in the world") {
    refused(scene_world("grasp-pull", {"instrument.coupling_stiffness=0.0"})->save_checkpoint(),
            "instrument[0].coupling_stiffness");
  }
  SUBCASE("truncated") { refused(std::span(good).first(good.size() - 9), "promises"); }
  SUBCASE("empty") { refused({}, "too short"); }
  SUBCASE("not a checkpoint") {
    std::vector<std::byte> text(200, std::byte{'x'});
    refused(text, "not a haustra checkpoint");
  }
  SUBCASE("one byte flipped") {
    std::vector<std::byte> damaged = good;
    damaged[good.size() / 2] ^= std::byte{0x40};
    refused(damaged, "checksum");
  }
  SUBCASE("a missing file is an I/O error naming it") {
    try {
      w->restore_checkpoint_file((dir / "missing.ckpt").string());
      FAIL("restored a missing file");
    } catch (const Error& e) {
      CHECK(e.code() == ErrorCode::io);
      CHECK(std::string(e.what()).find("missing.ckpt") != std::string::npos);
    }
  }
  std::filesystem::remove_all(dir);
}

namespace {

// A setter applied at frame 10, a checkpoint at frame 20, 15 frames recorded on from it. Then a
// fresh world, `change`d first, restores it; and the first world, `change`d after the save, rewinds
// to it: both must step on as the recording did, bit for bit (decision 0099).
void check_setter_kept(const std::string& scene, const std::function<void(World&)>& set,
                       const std::function<void(World&)>& change, std::vector<std::string> sets = {}) {
  auto original = scene_world(scene, sets);
  for (int f = 0; f < 10; ++f) original->step();
  set(*original);
  for (int f = 0; f < 10; ++f) original->step();
  const std::vector<std::byte> checkpoint = original->save_checkpoint();
  const WorldDesc at_save = original->desc();
  std::vector<std::vector<unsigned char>> recorded;
  for (int f = 0; f < 15; ++f) {
    original->step();
    recorded.push_back(outputs(*original));
  }
  auto fresh = scene_world(scene, sets);
  change(*fresh);
  change(*original);
  for (World* w : {fresh.get(), original.get()}) {
    w->restore_checkpoint(checkpoint, scene);
    CHECK(w->dt() == at_save.dt);
    CHECK(w->gravity() == at_save.gravity);
    CHECK(w->frame_budget() == at_save.frame_budget);
    CHECK(w->frame_limits().max_retries == at_save.solver.max_retries);
    CHECK(w->desc().segments[0].material.youngs_modulus == at_save.segments[0].material.youngs_modulus);
    for (int f = 0; f < 15; ++f) {
      w->step();
      INFO(scene << ": frame " << w->frame() << (w == fresh.get() ? ", a fresh world" : ", rewound"));
      REQUIRE(outputs(*w) == recorded[static_cast<std::size_t>(f)]);
    }
  }
}

MaterialDesc scaled(const World& w, double factor) {
  MaterialDesc m = w.desc().segments[0].material;
  m.youngs_modulus *= factor;
  m.density *= 1.0 + 0.1 * factor;
  return m;
}

}  // namespace

TEST_CASE("checkpoints keep what every setter changed, set before or after the save (decision 0099)") {
  SUBCASE("gravity") {
    check_setter_kept(
        "grasp-push",
        [](World& w) {
          w.set_gravity({0.0, -3.0, -9.0});
        },
        [](World& w) {
          w.set_gravity({1.0, 0.0, -5.0});
        });
  }
  SUBCASE("dt") {
    check_setter_kept(
        "grasp-push", [](World& w) { w.set_dt(0.002); }, [](World& w) { w.set_dt(0.0005); });
  }
  SUBCASE("a grasp's coupling") {
    check_setter_kept(
        "grasp-push", [](World& w) { w.set_instrument_coupling(0, 300.0, 1.0, 2.0); },
        [](World& w) { w.set_instrument_coupling(0, 2000.0, 3.0, 5.0); });
  }
  SUBCASE("a material: the rods rebuilt on restore, the organ mesh's binding kept") {
    check_setter_kept(
        "demo", [](World& w) { w.set_material(0, scaled(w, 3.0), 0.5); },
        [](World& w) { w.set_material(0, scaled(w, 0.5), 2.0); }, {"segment.mesh.procedural.vertices=2000"});
  }
  SUBCASE("the frame's budget and limits") {
    check_setter_kept(
        "grasp-push",
        [](World& w) {
          w.set_frame_budget(0.25);
          w.set_frame_limits({8, 3, 30});
        },
        [](World& w) {
          w.set_frame_budget(0.0);
          w.set_frame_limits({2, 0, 5});
        });
  }
  SUBCASE("a load and the grasper handed to the host") {
    check_setter_kept(
        "grasp-pull",
        [](World& w) {
          w.set_external_load(20, {0.0, 0.2, 0.0}, Eigen::Vector3d::Zero());
          w.set_instrument_grasp(0, false);
        },
        [](World& w) {
          w.set_external_load(20, {0.0, -1.0, 0.0}, {0.0, 0.0, 0.01});
          w.set_instrument_pose(0, {0.3, 0.0, 0.2}, Eigen::Vector3d::UnitZ());
        });
  }
}

TEST_CASE("checkpoints keep what the other setters changed: attachments, cutting, a posed rod (issue 36)") {
  SUBCASE("an attachment's target, its frame's target and whether it holds") {
    check_setter_kept(
        "sag",
        [](World& w) {
          w.set_attachment_target(0, 0, {0.5, 0.0, 0.02});
          w.set_attachment_target_rotation(0, 0, Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY())));
        },
        [](World& w) {
          w.set_attachment_active(0, 0, false);
          w.set_attachment_target(0, 0, {0.4, 0.0, -0.05});
        });
  }
  SUBCASE("an instrument cutting") {
    check_setter_kept(
        "grasp-push", [](World& w) { w.set_instrument_cutting(0, true); },
        [](World& w) { w.set_instrument_cutting(0, false); });
  }
  SUBCASE("a rod posed by the host") {
    auto bent = [](double by) {
      return [by](World& w) {
        const auto s = w.strains();
        std::vector<double> strains(s.data.begin(), s.data.end());
        for (std::size_t k = 0; k < strains.size(); k += 4) strains[k] += by;
        w.pose_rod(0, w.base_pose(0), strains);
      };
    };
    check_setter_kept("cantilever", bent(0.5), bent(-0.8));
  }
  SUBCASE("strains written and a load per metre (decision 0102's setters)") {
    auto written = [](double by, double per_metre) {
      return [by, per_metre](World& w) {
        const auto s = w.strains();
        std::vector<double> strains(s.data.begin(), s.data.end());
        for (std::size_t k = 1; k < strains.size(); k += 4) strains[k] += by;
        w.set_strains(strains);
        const std::size_t n = w.segment(0).nodes.count;
        std::vector<double> load(3 * n, 0.0);
        for (std::size_t k = 0; k < n; ++k) load[3 * k + 2] = per_metre;
        w.set_distributed_load(0, load, {}, false);
      };
    };
    check_setter_kept("cantilever", written(0.3, -1e-6), written(-0.4, 2e-6));
  }
}

TEST_CASE("a checkpoint of a world a host added parts to restores into one with the same parts, not into one without") {
  auto add_parts = [](World& w) {
    InstrumentDesc retractor;
    retractor.name = "retractor";
    retractor.tip = {0.1, 0.3, 0.2};
    w.add_instrument(retractor);
    w.add_obstacle(SphereObstacleDesc{"neighbour", {0.8, 0.0, -0.1}, 0.08});
    AttachmentDesc held;
    held.node = -1;
    w.add_attachment(0, held);
  };
  auto original = scene_world("grasp-push");
  for (int f = 0; f < 5; ++f) original->step();
  add_parts(*original);
  for (int f = 0; f < 5; ++f) original->step();
  const std::vector<std::byte> checkpoint = original->save_checkpoint();
  std::vector<std::vector<unsigned char>> recorded;
  for (int f = 0; f < 10; ++f) {
    original->step();
    recorded.push_back(outputs(*original));
  }
  auto same = scene_world("grasp-push");
  add_parts(*same);
  same->restore_checkpoint(checkpoint, "grasp-push with parts");
  for (int f = 0; f < 10; ++f) {
    same->step();
    REQUIRE(outputs(*same) == recorded[static_cast<std::size_t>(f)]);
  }
  auto without = scene_world("grasp-push");
  CHECK_THROWS_WITH_AS(without->restore_checkpoint(checkpoint, "grasp-push with parts"),
                       doctest::Contains("grasp-push with parts"), Error);
}

TEST_CASE("checkpoints keep connective tissue cut after the save undone, and cut before it cut") {
  const std::string text =
      std::string(test::kMinimalScene) + "[[segment.anchors]]\nstiffness = 500.0\nsupport = 200.0\n";
  auto original = create_world(parse_scene(text, std::string(HAUSTRA_SOURCE_DIR) + "/scenes/anchors.toml"));
  for (int f = 0; f < 5; ++f) original->step();
  CHECK(original->cut_tissue(original->anchor_targets()[3], 0.01) > 0);
  const std::vector<std::uint8_t> cut_before(original->anchors_intact().begin(), original->anchors_intact().end());
  for (int f = 0; f < 5; ++f) original->step();
  const std::vector<std::byte> checkpoint = original->save_checkpoint();
  for (int f = 0; f < 10; ++f) original->step();
  const std::vector<unsigned char> at20 = outputs(*original);
  CHECK(original->cut_tissue(original->anchor_targets()[8], 0.01) > 0);
  original->restore_checkpoint(checkpoint);
  CHECK(std::equal(cut_before.begin(), cut_before.end(), original->anchors_intact().begin()));
  for (int f = 0; f < 10; ++f) original->step();
  CHECK(outputs(*original) == at20);
}
