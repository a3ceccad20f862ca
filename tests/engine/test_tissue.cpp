// Connective tissue (decision 0095): a rod on anchors sags as a beam on an elastic foundation,
// each anchor carries what its closed form says, anchors tear at their strength and are cut in a
// sphere, with events, and both survive checkpoints.
#include <doctest/doctest.h>

#include <cmath>
#include <complex>
#include <numbers>
#include <string>

#include "haustra/error.hpp"
#include "haustra/world.hpp"
#include "measured.hpp"

using namespace haustra;

namespace {

constexpr double kLength = 0.5, kFoundation = 5000.0;  // m; N/m²

// A straight rod along x at 0.1 m height, elastic in every component, on uniform anchors.
WorldDesc rod_on_tissue(int nodes, BaseMode base) {
  WorldDesc w;
  w.threads = 1;
  SegmentDesc s;
  s.name = "bowel";
  s.nodes = nodes;
  s.rest.length = kLength;
  s.base_position = Eigen::Vector3d(0.0, 0.0, 0.1);
  s.base = base;
  s.drag = base == BaseMode::free ? std::optional<double>(1.0) : std::nullopt;
  s.law = {StrainLaw::elastic, StrainLaw::elastic, StrainLaw::elastic, StrainLaw::elastic};
  AnchorsDesc a;
  a.name = "mesentery";
  a.stiffness = kFoundation;
  a.strength = 0.0;  // never tears here
  s.anchors.push_back(a);
  w.segments.push_back(s);
  return w;
}

// Weight per length of the rod, N/m.
double weight_per_length(const World& w) { return w.segment(0).linear_density * 9.81; }

double sag(const World& w, std::size_t k) { return 0.1 - w.node_positions().get(k).z(); }

}  // namespace

TEST_CASE("tissue: a free rod on uniform anchors sinks by q / k everywhere, each anchor carrying its share") {
  auto w = World::create(rod_on_tissue(101, BaseMode::free));
  for (int f = 0; f < 120; ++f) w->step();
  const double q = weight_per_length(*w), expected = q / kFoundation;
  std::vector<double> tension(w->anchor_count());
  w->anchor_tensions(tension);
  double worst_sag = 0.0, worst_tension = 0.0;
  const auto h = w->section_lengths();
  for (std::size_t k = 0; k < w->node_count(); ++k) {
    worst_sag = std::max(worst_sag, std::abs(sag(*w, k) - expected) / expected);
    const double share = 0.5 * ((k > 0 ? h[k - 1] : 0.0) + (k + 1 < w->node_count() ? h[k] : 0.0));
    worst_tension = std::max(worst_tension, std::abs(tension[k] - q * share) / (q * share));
  }
  MESSAGE("uniform sag " << expected * 1e3 << " mm; relative errors: sag " << worst_sag << ", tension "
                         << worst_tension);
  REQUIRE(w->anchor_count() == w->node_count());
  // Uniform load on a uniform foundation needs no bending: exact to rounding (measured 1.0e-14).
  test::measured("tissue: free rod's sag against q/k (relative)", worst_sag, 1e-13);
  test::measured("tissue: anchor tension against its weight share (relative)", worst_tension, 1e-13);
}

TEST_CASE("tissue: a clamped rod on anchors sags as a beam on a two-parameter (Pasternak) foundation") {
  auto w = World::create(rod_on_tissue(201, BaseMode::clamped));
  for (int f = 0; f < 120; ++f) w->step();
  const double q = weight_per_length(*w), far = q / kFoundation, bending = w->segment(0).bending_stiffness;
  // The anchors hold the frame too, k R² per length against turning: against the slope, a
  // foundation's shear term. B w'''' − k R² w'' + k w = q, clamped at x = 0: w = q/k (1 − e^{−ax}
  // (cos bx + (a/b) sin bx)), a ± ib the root of B s⁴ − k R² s² + k = 0 with positive real part.
  const double shear = kFoundation * 0.02 * 0.02;
  const std::complex<double> p(0.5 * shear / bending,
                               0.5 * std::sqrt(4.0 * kFoundation / bending - std::pow(shear / bending, 2)));
  const std::complex<double> s = std::sqrt(p);
  const double a = s.real(), b = s.imag();
  REQUIRE(a * kLength > 10.0);  // the free end is far from the clamp: the semi-infinite solution
  double worst = 0.0;
  for (std::size_t k = 0; k < w->node_count(); ++k) {
    const double x = w->node_positions().get(k).x();
    const double expected = far * (1.0 - std::exp(-a * x) * (std::cos(b * x) + a / b * std::sin(b * x)));
    worst = std::max(worst, std::abs(sag(*w, k) - expected) / far);
  }
  MESSAGE("a = " << a << ", b = " << b << " /m, far sag " << far * 1e3 << " mm, worst error " << worst << " of it");
  test::measured("tissue: clamped rod against the two-parameter foundation's closed form (of q/k)", worst, 5e-3);
}

TEST_CASE("tissue: an anchor tears at its strength, with an event, and frees its node") {
  WorldDesc d = rod_on_tissue(51, BaseMode::clamped);
  d.gravity.setZero();
  AnchorsDesc& a = d.segments[0].anchors[0];
  a.from = a.to = 0.5;  // one anchor, on the middle node (1 cm of rod: 50 N/m)
  a.strength = 100.0;   // N/m: it holds 1 N
  auto w = World::create(d);
  REQUIRE(w->anchor_count() == 1);
  const std::size_t node = w->anchor_nodes()[0];
  const double holds = 100.0 * w->section_lengths()[node];
  std::vector<double> tension(1);
  double last = 0.0;
  int torn_at = -1;
  for (int f = 1; f <= 400 && torn_at < 0; ++f) {
    w->set_external_load(node, Eigen::Vector3d(0.0, 0.0, 0.004 * f), Eigen::Vector3d::Zero());  // 4 mN a frame
    w->step();
    for (const Event& e : w->events())
      if (e.kind == Event::Kind::torn) torn_at = f;
    if (torn_at < 0) {
      w->anchor_tensions(tension);
      last = tension[0];
    }
  }
  REQUIRE(torn_at > 0);
  MESSAGE("torn at frame " << torn_at << ": tension the frame before " << last << " N, strength " << holds << " N");
  CHECK(last <= holds);
  CHECK(last >= 0.99 * holds);  // the pull grows by well under 1 % a frame there
  CHECK(w->anchors_intact()[0] == 0);
  const Event& e = w->events().back();
  CHECK(e.segment == 0);
  CHECK(e.node == node);
  CHECK(std::string(e.message()).find("1 anchor of 'mesentery'") != std::string::npos);
  CHECK(std::string(e.message()).find("tore") != std::string::npos);
  // Freed: the load now bends the elastic rod alone, which carries less than the anchor did.
  const double before = w->node_positions().get(node).z();
  w->step();
  CHECK(w->node_positions().get(node).z() > before + 1e-3);
  w->anchor_tensions(tension);
  CHECK(tension[0] == 0.0);
}

TEST_CASE("tissue: a cut frees the organ in a sphere and holds it elsewhere, and checkpoints keep what was cut") {
  WorldDesc d = rod_on_tissue(101, BaseMode::free);
  d.segments[0].law = {StrainLaw::viscous, StrainLaw::viscous, StrainLaw::viscous, StrainLaw::elastic};
  auto w = World::create(d);
  for (int f = 0; f < 30; ++f) w->step();
  const std::size_t middle = 50;
  const double settled = sag(*w, middle);
  // 3.1 cm from the middle node, and the tissue holds the wall 2 cm round each node: the anchors of
  // the nodes within 5 cm of the middle, 2 × 5 cm / 5 mm + 1.
  const std::size_t cut = w->cut_tissue(w->node_positions().get(middle), 0.031);
  CHECK(cut == 21);
  REQUIRE(!w->events().empty());
  CHECK(w->events().back().kind == Event::Kind::cut);
  CHECK(std::string(w->events().back().message()).find("21 anchors of 'mesentery'") != std::string::npos);
  CHECK(w->cut_tissue(w->node_positions().get(middle), 0.031) == 0);  // nothing left there to cut
  const std::vector<std::byte> saved = w->save_checkpoint();
  for (int f = 0; f < 60; ++f) w->step();
  // Freed in the middle, it hangs between the parts still held; the ends stay where they were.
  MESSAGE("middle sank " << (sag(*w, middle) - settled) * 1e3 << " mm; the end " << sag(*w, 0) * 1e3 << " mm");
  CHECK(sag(*w, middle) - settled > 3.0 * settled);  // measured 3.9 mm more, 5 times
  CHECK(sag(*w, 0) < 1.5 * settled);
  CHECK(sag(*w, 100) < 1.5 * settled);
  // The same continuation from the checkpoint, in a world built afresh: bit for bit.
  auto again = World::create(d);
  again->restore_checkpoint(saved);
  CHECK(std::vector<std::uint8_t>(again->anchors_intact().begin(), again->anchors_intact().end()) ==
        std::vector<std::uint8_t>(w->anchors_intact().begin(), w->anchors_intact().end()));
  for (int f = 0; f < 60; ++f) again->step();
  for (std::size_t k = 0; k < w->node_count(); ++k) CHECK(again->node_positions().get(k) == w->node_positions().get(k));
}

TEST_CASE("tissue: ranges, roots and values a scene cannot hold are refused by field") {
  auto refuses = [](auto change, const std::string& field) {
    WorldDesc d = rod_on_tissue(11, BaseMode::clamped);
    change(d.segments[0].anchors[0]);
    try {
      (void)World::create(d);
      FAIL("accepted a bad " << field);
    } catch (const FieldError& e) {
      CHECK(e.field() == field);
    }
  };
  refuses([](AnchorsDesc& a) { a.to = 1.5; }, "segment[0].anchors[0].to");
  refuses([](AnchorsDesc& a) { a.from = 0.6, a.to = 0.4; }, "segment[0].anchors[0].to");
  refuses([](AnchorsDesc& a) { a.stiffness = -1.0; }, "segment[0].anchors[0].stiffness");
  refuses([](AnchorsDesc& a) { a.damping = std::nan(""); }, "segment[0].anchors[0].damping");
  refuses([](AnchorsDesc& a) { a.stiffness = a.damping = 0.0; }, "segment[0].anchors[0].stiffness");
  refuses([](AnchorsDesc& a) { a.target = AnchorTarget::root; }, "segment[0].anchors[0].root");
  refuses([](AnchorsDesc& a) { a.from = a.to = 0.53; }, "segment[0].anchors[0]");  // between two nodes
  // A root line: each anchor a tether of its rest distance plus the slack, so the rod stays put.
  WorldDesc d = rod_on_tissue(11, BaseMode::clamped);
  d.gravity.setZero();
  d.segments[0].anchors[0].target = AnchorTarget::root;
  d.segments[0].anchors[0].root = {Eigen::Vector3d(0.0, 0.0, -0.1), Eigen::Vector3d(0.5, 0.0, -0.1)};
  auto w = World::create(d);
  CHECK((w->anchor_targets()[3] - Eigen::Vector3d(0.15, 0.0, -0.1)).norm() < 1e-12);
  std::vector<double> tension(w->anchor_count());
  w->step();
  w->anchor_tensions(tension);
  for (const double t : tension) CHECK(t == 0.0);
}
