// World::Impl's construction (the state sized once from the model, the meshes at rest) and where
// a rod's node lives among the API's segments.
#include "step/world_impl.hpp"
#include "step/collision.hpp"
#include "step/instruments.hpp"
#include "step/newton_stages.hpp"

namespace haustra {

World::Impl::Impl(WorldDesc d, detail::WorldModel m)
    : desc(std::move(d)), model(std::move(m)), scheduler(desc.threads, desc.jobs) {
  detail::init_world_state(model, state);
  detail::init_collision_state(model, state);
  detail::init_instruments(model, state);
  guard.resize(model.segments.size());
  reserve_events();
  slipped.reserve(model.instruments.size());
  torn.reserve(model.anchors.size());
  base = {model.solver.substeps, model.solver.mode != SolverMode::lagged};
  state.robust_substeps = base.substeps;
  state.robust_newton = base.newton;
  state.robust_good_frames = model.solver.calm_frames;  // calm since ever: a first failure's spell is short
  state.robust_calm_spell = detail::first_calm_spell(model.solver.calm_frames);
  for (const auto& s : model.segments) {
    any_free_base |= s.base_mode == BaseMode::free;
    any_constraints |= s.constraint_rows > 0;
  }
  for (const detail::InstrumentModel& instrument : model.instruments) any_proxy |= detail::is_proxy(instrument);
  follow_rod();  // the meshes at rest, before the first step
}

// The API's segment (a piece of a chain, or the whole rod) that holds node `node` of rod `rod`,
// and the node's index in it; a joint node counts as the later piece's base.
std::pair<std::size_t, std::size_t> World::Impl::piece_of(std::size_t rod, std::size_t node) const {
  const detail::SegmentModel& seg = model.segments[rod];
  std::size_t p = seg.first_piece + seg.piece_count - 1;
  while (p > seg.first_piece && model.pieces[p].first_node > node) --p;
  return {p, node - model.pieces[p].first_node};
}

}  // namespace haustra
