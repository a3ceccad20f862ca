#pragma once
// The speed/accuracy study's knobs (docs/tradeoff.md), each a function that measures its settings,
// and the helpers they share. Private to studies/.
#include <Eigen/Core>
#include <filesystem>
#include <vector>

#include "haustra/studies/tradeoff_study.hpp"
#include "haustra/world.hpp"

namespace haustra::validation::tradeoff {

// m: the paper's tube and tissue, clamped level under gravity (qL³/B ≈ 12: a large, smooth
// deflection). At 0.4 m (qL³/B ≈ 100) the heavy elastica has several equilibria — N = 667 settles
// curled back, N = 2,001 never settles — so no N converges to anything there.
inline constexpr double kRodLength = 0.2;

double median(std::vector<double> v);
Eigen::Vector3d node(const World& w, std::size_t k);
std::vector<Eigen::Vector3d> nodes(const World& w);
double max_distance(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b);
// Median engine-measured frame time over `frames` further frames, µs.
double frame_cost(World& w, int frames);
// Solve each frame to convergence and let the guard allow any jump: a static reference.
void converge_each_frame(WorldDesc& d);
// The paper's tube (R = 2 cm, 3 mm wall, E = 33.2 kPa), all strains elastic, clamped level.
WorldDesc cantilever(int nodes);
// scenes/NAME.toml.
std::filesystem::path scene_file(const std::string& name);

// The model's knobs (tradeoff_model_knobs.cpp).
TradeoffKnob knob_nodes();
TradeoffKnob knob_beads();
TradeoffKnob knob_iterations();
TradeoffKnob knob_filter();
TradeoffKnob knob_exp2();
TradeoffKnob knob_rings();
// The reconstruction's (tradeoff_reconstruction_knobs.cpp).
TradeoffKnob knob_precision();
TradeoffKnob knob_integrator();
// The instruments' (tradeoff_instrument_knobs.cpp).
TradeoffKnob knob_coupling();
// Sleeping rods (tradeoff_sleep_knob.cpp).
TradeoffKnob knob_sleep();
TradeoffKnob knob_sleep_ranges();

}  // namespace haustra::validation::tradeoff
