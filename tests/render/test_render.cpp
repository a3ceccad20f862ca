// Pictures are checked against properties a correct picture has, not against a stored image that
// any change of shading would break: the subject is in frame, the floor lies below it, the colour
// overlay spans the values it should.
#include <doctest/doctest.h>

#include "haustra/render/render.hpp"
#include "haustra/scene.hpp"
#include "scene_fixtures.hpp"

using namespace haustra;

namespace {

struct Census {
  int count = 0;
  double mean_y = 0.0;
  int min_x = 1 << 30, max_x = -1, min_y = 1 << 30, max_y = -1;
};

Census census(const render::Picture& p, render::Shows what) {
  Census c;
  for (int y = 0; y < p.image.height(); ++y)
    for (int x = 0; x < p.image.width(); ++x)
      if (p.at(x, y) == what) {
        ++c.count;
        c.mean_y += y;
        c.min_x = std::min(c.min_x, x);
        c.max_x = std::max(c.max_x, x);
        c.min_y = std::min(c.min_y, y);
        c.max_y = std::max(c.max_y, y);
      }
  if (c.count > 0) c.mean_y /= c.count;
  return c;
}

}  // namespace

TEST_CASE("a rendered scene: the organ in frame, the floor below it, the strain overlay's range") {
  SceneDesc scene = test::scene_desc("demo");
  std::unique_ptr<World> w = create_world(scene);
  for (int f = 0; f < 90; ++f) w->step();  // lifted in the middle
  render::RenderOptions o;
  o.width = 240;
  o.height = 160;
  o.samples = 1;
  o.overlays.colour = render::Colouring::strain;
  const render::Picture p = render::render(*w, scene.world, o);
  const Census organ = census(p, render::Shows::organ), floor = census(p, render::Shows::floor);
  MESSAGE("organ: " << organ.count << " pixels, x " << organ.min_x << "…" << organ.max_x << ", y " << organ.min_y << "…"
                    << organ.max_y << "; floor " << floor.count << " pixels; strain " << p.colour_min << "…"
                    << p.colour_max << " 1/m");
  // In frame: a fair share of the picture, touching no border.
  CHECK(organ.count > 240 * 160 / 50);
  CHECK(organ.min_x > 0);
  CHECK(organ.max_x < 239);
  CHECK(organ.min_y > 0);
  CHECK(organ.max_y < 159);
  // The floor fills the lower part of the picture, under the organ: below its lowest pixel there is floor.
  CHECK(floor.count > 240 * 160 / 4);
  CHECK(floor.mean_y > organ.mean_y);
  CHECK(p.at(120, 159) == render::Shows::floor);
  CHECK(p.at(120, 0) == render::Shows::background);
  // The overlay spans the bending strain the rod really has: from its straight parts to the crest.
  double lo = 1e300, hi = 0.0;
  for (std::size_t k = 0; k < w->node_count(); ++k) {
    const double b = (w->strains().get(k) - w->rest_strains().get(k)).head<2>().norm();
    lo = std::min(lo, b);
    hi = std::max(hi, b);
  }
  CHECK(p.colour_min == doctest::Approx(lo).epsilon(0.02));
  CHECK(p.colour_max == doctest::Approx(hi).epsilon(0.02));
  CHECK(hi > 5.0);  // the grasped crest bends (1/m)
  // The image is not uniform: the organ is shaded.
  const render::Rgb a = p.image.at(organ.min_x, static_cast<int>(organ.mean_y)), b = p.image.at(120, 159);
  CHECK(std::abs(a.r - b.r) + std::abs(a.g - b.g) + std::abs(a.b - b.b) > 0.05f);
}
