// The skin's stretch measure (decision 0121) against the analytic case: a straight tube whose rod is
// stretched uniformly by λ, carried by rigid cross-sections, stretches each edge by exactly the rod's
// stretch in the edge's own direction, √(1 + (λ² − 1) cos²θ): every ratio is 1, the largest edge λ.
#include <doctest/doctest.h>

#include <vector>

#include "haustra/studies/skin_stretch.hpp"
#include "scene_fixtures.hpp"

using namespace haustra;

TEST_CASE("skin stretch: a straight tube stretched uniformly along its rod measures 1, its longest edge the stretch") {
  SceneDesc s = test::scene_desc("cantilever");
  SegmentDesc& d = s.world.segments.at(0);
  d.cross_section.radius = 0.02;
  d.cross_section.wall_thickness = 0.003;
  d.beads.enabled = true;
  d.beads.count = 11;
  d.mesh.enabled = true;
  d.mesh.procedural.vertices = 2000;
  auto world = create_world(s);
  studies::SkinStretch skin(*world);
  REQUIRE(!skin.empty());
  skin.measure(*world, true);
  CHECK(skin.worst == doctest::Approx(1.0).epsilon(1e-5));  // at rest: float positions
  constexpr double kStretch = 1.2;
  std::vector<double> strain(world->strains().data.begin(), world->strains().data.end());
  for (std::size_t k = 0; k < strain.size() / 4; ++k) strain[4 * k + 3] = kStretch - 1.0;
  world->set_strains(strain);
  skin.measure(*world, false);
  MESSAGE("stretched by " << kStretch << ": worst over the rod's stretch " << skin.worst << ", own " << skin.worst_raw);
  CHECK(skin.worst == doctest::Approx(1.0).epsilon(1e-4));
  CHECK(skin.worst_raw > 1.15);  // the edges along the tube
  CHECK(skin.worst_raw <= kStretch * (1.0 + 1e-4));
  CHECK(skin.edges_past == 0);
}
