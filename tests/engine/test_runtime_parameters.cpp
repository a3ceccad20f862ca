// Run-time parameters (decision 0082): gravity, dt and a grasp's coupling changed between frames
// step as a world built with them; a material change keeps the mesh binding and steps as a rebuild.
#include <doctest/doctest.h>

#include "haustra/error.hpp"
#include "scene_fixtures.hpp"

namespace haustra {
namespace {

std::vector<float> mesh_positions(const World& w) {
  const auto m = w.mesh_positions();
  std::vector<float> out(m.x.begin(), m.x.end());
  out.insert(out.end(), m.y.begin(), m.y.end());
  out.insert(out.end(), m.z.begin(), m.z.end());
  return out;
}

TEST_CASE("run-time gravity, dt and coupling step as a world built with them") {
  auto changed = test::scene_world("grasp-push");
  auto built =
      test::scene_world("grasp-push", 1,
                        {"world.dt=0.01", "world.gravity=[0.0, -2.0, -9.0]", "instrument.coupling_stiffness=300.0",
                         "instrument.coupling_damping=1.0", "instrument.force_limit=2.0"});
  changed->set_dt(0.01);
  changed->set_gravity({0.0, -2.0, -9.0});
  changed->set_instrument_coupling(0, 300.0, 1.0, 2.0);
  test::step_both(*changed, *built, 80);
  CHECK(test::positions(*changed) == test::positions(*built));
  CHECK(changed->instrument(0).force == built->instrument(0).force);
  CHECK(changed->desc().dt == 0.01);

  CHECK_THROWS_WITH_AS(changed->set_dt(0.0), doctest::Contains("world.dt"), FieldError);
  CHECK_THROWS_WITH_AS(changed->set_instrument_coupling(0, 0.0, 1.0, 2.0), doctest::Contains("only through a rebuild"),
                       FieldError);
  CHECK(changed->dt() == 0.01);  // a refused value leaves the world as it was
}

TEST_CASE("a material change keeps the mesh binding and steps as a full rebuild would") {
  // The demo with a 2,000-vertex organ: three builds of its binding (two worlds and the rebuild).
  auto kept = test::scene_world("demo", 1, {"segment.mesh.procedural.vertices=2000"});
  auto rebuilt = test::scene_world("demo", 1, {"segment.mesh.procedural.vertices=2000"});
  test::step_both(*kept, *rebuilt, 20);
  MaterialDesc stiffer = kept->desc().segments[0].material;
  stiffer.youngs_modulus *= 3.0;
  stiffer.density *= 1.1;
  kept->set_material(0, stiffer, 0.5);
  WorldDesc next = rebuilt->desc();
  next.segments[0].material = stiffer;
  next.segments[0].relaxation_time = 0.5;
  rebuilt->reconfigure(next);
  test::step_both(*kept, *rebuilt, 30);
  CHECK(test::positions(*kept) == test::positions(*rebuilt));
  CHECK(mesh_positions(*kept) == mesh_positions(*rebuilt));
  CHECK(kept->desc().segments[0].material.youngs_modulus == stiffer.youngs_modulus);
  CHECK(kept->segment(0).bending_stiffness == rebuilt->segment(0).bending_stiffness);

  MaterialDesc negative = stiffer;
  negative.youngs_modulus = -1.0;
  CHECK_THROWS_WITH_AS(kept->set_material(0, negative, 0.5), doctest::Contains("youngs_modulus"), Error);
}

}  // namespace
}  // namespace haustra
