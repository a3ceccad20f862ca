// Adding and removing segments between frames: the world rebuilt from its new description, every
// other segment's state carried over (decision 0031).
#include "step/state_carry_over.hpp"

#include <algorithm>

#include "step/newton_stages.hpp"
#include "step/world_impl.hpp"

namespace haustra::detail {
namespace {

template <class From, class To>  // vectors or spans
void copy_range(const From& from, std::size_t from_offset, To&& to, std::size_t to_offset, std::size_t count) {
  std::copy_n(from.begin() + static_cast<std::ptrdiff_t>(from_offset), count,
              to.begin() + static_cast<std::ptrdiff_t>(to_offset));
}

void copy_vec3(const Vec3Buffer& from, std::size_t fo, Vec3Buffer& to, std::size_t tofs, std::size_t n) {
  copy_range(from.x, fo, to.x, tofs, n);
  copy_range(from.y, fo, to.y, tofs, n);
  copy_range(from.z, fo, to.z, tofs, n);
}

void copy_rotation(const RotationBuffer& from, std::size_t fo, RotationBuffer& to, std::size_t tofs, std::size_t n) {
  copy_range(from.w, fo, to.w, tofs, n);
  copy_range(from.x, fo, to.x, tofs, n);
  copy_range(from.y, fo, to.y, tofs, n);
  copy_range(from.z, fo, to.z, tofs, n);
}

// Fast mode's chord state of a rod that stays as it was (decision 0037): the same factorization
// serves on, as it would have without the change around it.
void carry_chords(const std::vector<NewtonWorkspace>& from, std::size_t a, std::vector<NewtonWorkspace>& to,
                  std::size_t b) {
  if (a >= from.size() || b >= to.size()) return;
  const NewtonWorkspace& f = from[a];
  NewtonWorkspace& t = to[b];
  if (f.record.size() != t.record.size() || f.gain.size() != t.gain.size() || f.record.empty() ||
      f.responses.size() != t.responses.size() || f.chord_pattern.size() > t.chord_pattern.capacity())
    return;
  t.chord_ready = f.chord_ready;
  t.chord_frame = f.chord_frame;
  t.chord_dt = f.chord_dt;
  t.chord_pattern = f.chord_pattern;
  t.record = f.record;
  t.gain = f.gain;
  t.base_solution = f.base_solution;
  t.responses = f.responses;
}

}  // namespace

CarryMap same_rods(const WorldModel& model) {
  CarryMap map;
  map.rods.resize(model.segments.size());
  for (std::size_t r = 0; r < map.rods.size(); ++r) map.rods[r] = r;
  return map;
}

namespace {

std::size_t mapped(const std::vector<std::size_t>& map, std::size_t i) { return map.empty() ? i : map[i]; }

// A rod's slot in `rod` for an old slot of `from_rod`: its own attachments through the map, a grasp
// slot through its instrument's new index; kRodRemoved when it has none.
std::size_t slot_in(const SegmentModel& from_rod, std::size_t k, const SegmentModel& rod, const CarryMap& map,
                    std::size_t old_rod) {
  const AttachmentModel& a = from_rod.attachments[k];
  if (!a.grasp_slot) {
    const std::size_t to = old_rod < map.attachments.size() ? mapped(map.attachments[old_rod], k) : k;
    return to < rod.attachments.size() && !rod.attachments[to].grasp_slot ? to : kRodRemoved;
  }
  const std::size_t instrument = mapped(map.instruments, a.instrument);
  if (instrument == kRodRemoved) return kRodRemoved;
  for (std::size_t j = 0; j < rod.attachments.size(); ++j)
    if (rod.attachments[j].grasp_slot && rod.attachments[j].instrument == instrument) return j;
  return kRodRemoved;
}

// A rod's ranges of anchors, in order: (first, count) into the model's anchors.
std::vector<std::pair<std::size_t, std::size_t>> ranges_of(const WorldModel& m, std::size_t rod) {
  std::vector<std::pair<std::size_t, std::size_t>> out;
  for (const AnchorRange& r : m.anchor_ranges)
    if (r.rod == rod) out.emplace_back(r.first, r.count);
  return out;
}

// What was torn or cut stays so, range by range, while a range is described alike (else it
// starts whole).
void carry_anchors(const WorldModel& from_model, const WorldState& from, const WorldModel& to_model, WorldState& to,
                   const CarryMap& map, std::size_t old_rod, std::size_t new_rod) {
  const auto old_ranges = ranges_of(from_model, old_rod);
  const auto new_ranges = ranges_of(to_model, new_rod);
  const bool identity = old_rod >= map.anchor_ranges.size() || map.anchor_ranges[old_rod].empty();
  for (std::size_t i = 0; i < old_ranges.size(); ++i) {
    const std::size_t j = identity ? i : map.anchor_ranges[old_rod][i];
    if (j >= new_ranges.size() || old_ranges[i].second != new_ranges[j].second) continue;
    copy_range(from.now.anchor_intact, old_ranges[i].first, to.now.anchor_intact, new_ranges[j].first,
               old_ranges[i].second);
  }
}

}  // namespace

void carry_over_state(const WorldModel& from_model, const WorldState& from, const WorldModel& to_model, WorldState& to,
                      std::span<const std::size_t> rod_map, bool carry_solver) {
  CarryMap map;
  map.rods.assign(rod_map.begin(), rod_map.end());
  carry_over_state(from_model, from, to_model, to, map, carry_solver);
}

void carry_over_state(const WorldModel& from_model, const WorldState& from, const WorldModel& to_model, WorldState& to,
                      const CarryMap& map, bool carry_solver) {
  const std::vector<std::size_t>& rod_map = map.rods;
  for (std::size_t r = 0; r < rod_map.size(); ++r) {
    if (rod_map[r] == kRodRemoved) continue;
    const SegmentModel& a = from_model.segments[r];
    const SegmentModel& b = to_model.segments[rod_map[r]];
    const std::size_t n = a.node_count, fo = a.node_offset, tofs = b.node_offset;
    copy_range(from.now.strain, 4 * fo, to.now.strain, 4 * tofs, 4 * n);
    copy_range(from.strain_before_update, 4 * fo, to.strain_before_update, 4 * tofs, 4 * n);
    copy_vec3(from.now.position, fo, to.now.position, tofs, n);
    copy_rotation(from.now.rotation, fo, to.now.rotation, tofs, n);
    copy_vec3(from.now.mid_position, fo, to.now.mid_position, tofs, n);
    copy_rotation(from.now.mid_rotation, fo, to.now.mid_rotation, tofs, n);
    copy_vec3(from.external_force, fo, to.external_force, tofs, n);
    copy_vec3(from.external_moment, fo, to.external_moment, tofs, n);
    to.now.base[rod_map[r]] = from.now.base[r];
    to.base_twist[rod_map[r]] = from.base_twist[r];
    to.base_resistance[rod_map[r]] = from.base_resistance[r];
    for (std::size_t k = 0; k < a.attachments.size(); ++k)
      if (const std::size_t j = slot_in(a, k, b, map, r); j != kRodRemoved)
        to.now.attachment[b.attachment_offset + j] = from.now.attachment[a.attachment_offset + k];
    carry_anchors(from_model, from, to_model, to, map, r, rod_map[r]);
    if (a.bead_count == b.bead_count)  // beads re-chosen (reconfigure): they start at rest
      copy_range(from.collision.bead_motion, a.bead_offset, to.collision.bead_motion, b.bead_offset, a.bead_count);
    if (carry_solver) carry_chords(from.newton, r, to.newton, rod_map[r]);
  }
  to.collision.report = from.collision.report;
  to.robust_substeps = from.robust_substeps;
  to.robust_newton = from.robust_newton;
  to.robust_good_frames = from.robust_good_frames;
  to.robust_calm_spell = from.robust_calm_spell;
  to.frame = from.frame;
  to.time = from.time;
  for (std::size_t i = 0; i < from.instruments.size(); ++i) {
    const std::size_t j = mapped(map.instruments, i);
    if (j == kRodRemoved || j >= to.instruments.size()) continue;
    InstrumentState& in = to.instruments[j];
    in = from.instruments[i];
    if (!in.grasping) continue;
    const std::size_t old_rod = in.grasp_segment;
    const std::size_t new_rod = rod_map[old_rod];
    if (new_rod == kRodRemoved) {  // what it held is gone: the jaws hold nothing
      in.grasping = in.coupled = false;
      continue;
    }
    const SegmentModel& a = from_model.segments[old_rod];
    const SegmentModel& b = to_model.segments[new_rod];
    const std::size_t slot = slot_in(a, in.grasp_attachment - a.attachment_offset, b, map, old_rod);
    if (a.bead_count != b.bead_count || slot == kRodRemoved) {  // the grasped bead may be gone: let go
      if (slot != kRodRemoved) to.now.attachment[b.attachment_offset + slot].active = false;
      in.grasping = in.coupled = false;
      continue;
    }
    in.grasp_segment = new_rod;
    in.grasp_attachment = b.attachment_offset + slot;
    in.grasp_bead = static_cast<std::uint32_t>(in.grasp_bead - a.bead_offset + b.bead_offset);
    in.grasp_node = static_cast<std::uint32_t>(in.grasp_node - a.node_offset + b.node_offset);  // coupled grasps
  }
  to.frame_start.copy_from(to.now);
}

}  // namespace haustra::detail

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
