// What a host adds to a world or takes out of it between frames (decision 0106): instruments,
// obstacles, a chain's attachments and its ranges of connective tissue. Each is a change of the
// description, rebuilt as adding a segment is, with every state carried over by a map of where the
// parts go (step/state_carry_over.hpp).
#include <fmt/format.h>

#include <type_traits>
#include <variant>

#include "haustra/error.hpp"
#include "haustra/mesh_io.hpp"
#include "haustra/world.hpp"
#include "step/state_carry_over.hpp"
#include "step/world_impl.hpp"

namespace haustra {
namespace {

// 0, 1, ..., n − 1 with `removed` taken out: where each old index goes.
std::vector<std::size_t> without(std::size_t n, std::size_t removed) {
  std::vector<std::size_t> map(n);
  for (std::size_t i = 0; i < n; ++i) map[i] = i < removed ? i : i == removed ? detail::kRodRemoved : i - 1;
  return map;
}

const char* kind_name(ObstacleKind kind) {
  switch (kind) {
    case ObstacleKind::plane: return "plane";
    case ObstacleKind::sphere: return "sphere";
    case ObstacleKind::capsule: return "capsule";
    case ObstacleKind::mesh: return "mesh";
  }
  return "obstacle";
}

std::size_t count_of(const EnvironmentDesc& e, ObstacleKind kind) {
  switch (kind) {
    case ObstacleKind::plane: return e.planes.size();
    case ObstacleKind::sphere: return e.spheres.size();
    case ObstacleKind::capsule: return e.capsules.size();
    case ObstacleKind::mesh: return e.meshes.size();
  }
  return 0;
}

// At most this many of each part a host may add (a scene's own may be more): every part costs a
// rebuild's share of every frame, and these are far past what a simulator holds.
constexpr std::size_t kMaxInstruments = 64;
constexpr std::size_t kMaxObstaclesOfAKind = 4096;
constexpr std::size_t kMaxAnchorRanges = 1024;

}  // namespace

std::size_t World::add_instrument(const InstrumentDesc& instrument) {
  const Use use(*this);
  WorldDesc next = impl_->desc;
  if (next.instruments.size() >= kMaxInstruments)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("add_instrument: the world has {} instruments already, the most a host may add to",
                            next.instruments.size()));
  next.instruments.push_back(instrument);
  const std::size_t index = next.instruments.size() - 1;
  rebuild(std::move(next), detail::same_rods(impl_->model), false);  // the rods' grasp slots changed
  return index;
}

void World::remove_instrument(std::size_t instrument) {
  const Use use(*this);
  impl_->check_instrument(instrument);
  WorldDesc next = impl_->desc;
  next.instruments.erase(next.instruments.begin() + static_cast<std::ptrdiff_t>(instrument));
  detail::CarryMap map = detail::same_rods(impl_->model);
  map.instruments = without(impl_->desc.instruments.size(), instrument);
  rebuild(std::move(next), map, false);
}

std::size_t World::add_obstacle(const ObstacleDesc& obstacle) {
  const Use use(*this);
  WorldDesc next = impl_->desc;
  EnvironmentDesc& e = next.environment;
  const auto kind = static_cast<ObstacleKind>(obstacle.index());
  if (count_of(e, kind) >= kMaxObstaclesOfAKind)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("add_obstacle: the world has {} {}s already, the most a host may add to", count_of(e, kind),
                            kind_name(kind)));
  std::visit(
      [&](const auto& o) {
        using T = std::decay_t<decltype(o)>;
        if constexpr (std::is_same_v<T, PlaneDesc>) e.planes.push_back(o);
        if constexpr (std::is_same_v<T, SphereObstacleDesc>) e.spheres.push_back(o);
        if constexpr (std::is_same_v<T, CapsuleObstacleDesc>) e.capsules.push_back(o);
        if constexpr (std::is_same_v<T, MeshObstacleDesc>) {
          // What a mesh file must be, a host's arrays must be too (finite, indices in range, no
          // degenerate triangle, a manifold).
          check_mesh({o.vertices, o.triangles},
                     fmt::format("environment.mesh[{}] ({})", e.meshes.size(), o.source.empty() ? o.name : o.source));
          e.meshes.push_back(o);
        }
      },
      obstacle);
  const std::size_t index = count_of(e, kind) - 1;
  rebuild(std::move(next), detail::same_rods(impl_->model), true);  // the rods are as they were
  return index;
}

void World::remove_obstacle(ObstacleKind kind, std::size_t index) {
  const Use use(*this);
  WorldDesc next = impl_->desc;
  EnvironmentDesc& e = next.environment;
  if (index >= count_of(e, kind))
    throw Error(ErrorCode::invalid_argument, fmt::format("remove_obstacle: {} index {} out of range (the world has {})",
                                                         kind_name(kind), index, count_of(e, kind)));
  const auto at = static_cast<std::ptrdiff_t>(index);
  switch (kind) {
    case ObstacleKind::plane: e.planes.erase(e.planes.begin() + at); break;
    case ObstacleKind::sphere: e.spheres.erase(e.spheres.begin() + at); break;
    case ObstacleKind::capsule: e.capsules.erase(e.capsules.begin() + at); break;
    case ObstacleKind::mesh: e.meshes.erase(e.meshes.begin() + at); break;
  }
  rebuild(std::move(next), detail::same_rods(impl_->model), true);
}

std::size_t World::obstacle_count(ObstacleKind kind) const { return count_of(impl_->desc.environment, kind); }

std::size_t World::add_attachment(std::size_t segment, const AttachmentDesc& attachment) {
  const Use use(*this);
  const std::size_t rod = impl_->piece(segment).rod;
  WorldDesc next = impl_->desc;
  next.segments[rod].attachments.push_back(attachment);
  const std::size_t index = next.segments[rod].attachments.size() - 1;
  rebuild(std::move(next), detail::same_rods(impl_->model), false);  // the rod's constraints changed
  return index;
}

void World::remove_attachment(std::size_t segment, std::size_t attachment) {
  const Use use(*this);
  const std::size_t rod = impl_->piece(segment).rod;
  const std::size_t own = impl_->desc.segments[rod].attachments.size();
  if (attachment >= own) {
    const std::size_t total = impl_->model.segments[rod].attachments.size();
    throw Error(
        ErrorCode::invalid_argument,
        attachment < total
            ? fmt::format("remove_attachment: attachment {} of segment '{}' is the grasp slot of instrument {}: "
                          "open the instrument (or remove it) instead",
                          attachment, impl_->model.pieces[segment].info.name,
                          impl_->model.segments[rod].attachments[attachment].instrument)
            : fmt::format("remove_attachment: segment '{}' has {} attachments, asked for index {}",
                          impl_->model.pieces[segment].info.name, own, attachment));
  }
  WorldDesc next = impl_->desc;
  auto& list = next.segments[rod].attachments;
  list.erase(list.begin() + static_cast<std::ptrdiff_t>(attachment));
  detail::CarryMap map = detail::same_rods(impl_->model);
  map.attachments.resize(impl_->model.segments.size());
  map.attachments[rod] = without(own, attachment);
  rebuild(std::move(next), map, false);
}

std::size_t World::add_anchors(std::size_t segment, const AnchorsDesc& anchors) {
  const Use use(*this);
  const std::size_t rod = impl_->piece(segment).rod;
  WorldDesc next = impl_->desc;
  auto& ranges = next.segments[rod].anchors;
  if (ranges.size() >= kMaxAnchorRanges)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("add_anchors: segment '{}' has {} ranges of anchors already, the most a host may add to",
                            impl_->model.pieces[segment].info.name, ranges.size()));
  ranges.push_back(anchors);
  const std::size_t index = ranges.size() - 1;
  rebuild(std::move(next), detail::same_rods(impl_->model), false);  // the rod's load stiffness changed
  return index;
}

void World::remove_anchors(std::size_t segment, std::size_t range) {
  const Use use(*this);
  const std::size_t rod = impl_->piece(segment).rod;
  const std::size_t count = impl_->desc.segments[rod].anchors.size();
  if (range >= count)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("remove_anchors: segment '{}' has {} ranges of anchors, asked for index {}",
                            impl_->model.pieces[segment].info.name, count, range));
  WorldDesc next = impl_->desc;
  auto& ranges = next.segments[rod].anchors;
  ranges.erase(ranges.begin() + static_cast<std::ptrdiff_t>(range));
  detail::CarryMap map = detail::same_rods(impl_->model);
  map.anchor_ranges.resize(impl_->model.segments.size());
  map.anchor_ranges[rod] = without(count, range);
  rebuild(std::move(next), map, false);
}

std::size_t World::anchor_range_count(std::size_t segment) const {
  return impl_->desc.segments[impl_->piece(segment).rod].anchors.size();
}

}  // namespace haustra
