// Adding and removing segments between frames, reconfiguring and new materials: the world rebuilt
// from its new description (the model built first), every kept segment's state carried over
// (step/state_carry_over.cpp, decision 0031).
#include <fmt/format.h>

#include "haustra/error.hpp"
#include "haustra/world.hpp"
#include "step/state_carry_over.hpp"
#include "step/world_impl.hpp"

namespace haustra {

// The new model is built first: a description it refuses leaves the world as it was.
std::unique_ptr<World::Impl> World::rebuilt(const WorldDesc& next, std::span<const std::size_t> rod_map,
                                            bool carry_solver, bool keep_mesh_binding) const {
  detail::CarryMap map;
  map.rods.assign(rod_map.begin(), rod_map.end());
  return rebuilt(next, map, carry_solver, keep_mesh_binding);
}

// The new model is built first: a description it refuses leaves the world as it was.
std::unique_ptr<World::Impl> World::rebuilt(const WorldDesc& next, const detail::CarryMap& map, bool carry_solver,
                                            bool keep_mesh_binding) const {
  auto fresh =
      std::make_unique<Impl>(next, detail::build_world_model(next, keep_mesh_binding ? &impl_->model : nullptr));
  detail::carry_over_state(impl_->model, impl_->state, fresh->model, fresh->state, map, carry_solver);
  detail::wake_all(fresh->state);  // the world changed round every rod (decision 0119)
  fresh->events = impl_->events;
  fresh->events_dropped = impl_->events_dropped;
  fresh->late_frames = impl_->late_frames;
  fresh->follow_rod();
  fresh->profile = FrameProfile{};
  return fresh;
}

void World::rebuild(WorldDesc next, std::span<const std::size_t> rod_map, bool carry_solver, bool keep_mesh_binding) {
  impl_ = rebuilt(next, rod_map, carry_solver, keep_mesh_binding);
}

// What a host adds or removes (world_edits.cpp) leaves every rod's shape and beads as they were:
// the organ meshes' cages and bindings are kept, as set_material keeps them.
void World::rebuild(WorldDesc next, const detail::CarryMap& map, bool carry_solver) {
  impl_ = rebuilt(next, map, carry_solver, true);
}

std::size_t World::add_segment(const SegmentDesc& segment) {
  const Use use(*this);
  WorldDesc next = impl_->desc;
  next.segments.push_back(segment);
  std::vector<std::size_t> rod_map(impl_->model.segments.size());
  for (std::size_t r = 0; r < rod_map.size(); ++r) rod_map[r] = r;
  const std::size_t first = impl_->model.pieces.size();
  rebuild(std::move(next), rod_map, true);
  return first;
}

void World::remove_segment(std::size_t segment) {
  const Use use(*this);
  const detail::SegmentPiece& piece = impl_->piece(segment);
  const detail::SegmentModel& rod = impl_->model.segments[piece.rod];
  if (piece.first_node != 0)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("segment '{}' is a piece of the chain '{}': a chain is removed whole, through its first "
                            "segment '{}'",
                            piece.info.name, rod.info.name, impl_->model.pieces[rod.first_piece].info.name));
  WorldDesc next = impl_->desc;
  next.segments.erase(next.segments.begin() + static_cast<std::ptrdiff_t>(piece.rod));
  std::vector<std::size_t> rod_map(impl_->model.segments.size());
  for (std::size_t r = 0; r < rod_map.size(); ++r)
    rod_map[r] = r < piece.rod ? r : r == piece.rod ? detail::kRodRemoved : r - 1;
  rebuild(std::move(next), rod_map, true);
}

void World::reconfigure(WorldDesc next) {
  const Use use(*this);
  const WorldDesc& now = impl_->desc;
  if (next.segments.size() != now.segments.size())
    throw Error(ErrorCode::invalid_argument,
                fmt::format("reconfigure keeps the segments: {} given, the world has {} (add_segment / remove_segment "
                            "change them)",
                            next.segments.size(), now.segments.size()));
  for (std::size_t s = 0; s < now.segments.size(); ++s)
    if (next.segments[s].nodes != now.segments[s].nodes ||
        next.segments[s].chain_pieces != now.segments[s].chain_pieces)
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("reconfigure keeps every segment's nodes: segments[{}] ('{}') has {} nodes in {} pieces, "
                              "the world {} in {}",
                              s, next.segments[s].name, next.segments[s].nodes, next.segments[s].chain_pieces,
                              now.segments[s].nodes, now.segments[s].chain_pieces));
  if (next.instruments.size() != now.instruments.size())
    throw Error(ErrorCode::invalid_argument,
                fmt::format("reconfigure keeps the instruments: {} given, the world has {}", next.instruments.size(),
                            now.instruments.size()));
  std::vector<std::size_t> rod_map(impl_->model.segments.size());
  for (std::size_t r = 0; r < rod_map.size(); ++r) rod_map[r] = r;
  rebuild(std::move(next), rod_map, false);
}

const WorldDesc& World::desc() const { return impl_->desc; }

const SegmentDesc& World::segment_desc(std::size_t segment) const {
  return impl_->desc.segments.at(impl_->piece(segment).rod);
}

void World::set_material(std::size_t segment, const MaterialDesc& material, double relaxation_time) {
  const Use use(*this);
  const detail::SegmentPiece& piece = impl_->piece(segment);
  if (piece.first_node != 0)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("segment '{}' is a later piece of the chain '{}': set the chain's material through its "
                            "first piece",
                            piece.info.name, impl_->model.segments[piece.rod].info.name));
  WorldDesc next = impl_->desc;
  next.segments[piece.rod].material = material;
  next.segments[piece.rod].relaxation_time = relaxation_time;
  std::vector<std::size_t> rod_map(impl_->model.segments.size());
  for (std::size_t r = 0; r < rod_map.size(); ++r) rod_map[r] = r;
  rebuild(std::move(next), rod_map, false, true);  // fast mode's factorizations were of the old material
}

}  // namespace haustra
