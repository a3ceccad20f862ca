// Adding and removing segments between frames: the world rebuilt from its new description, every
// other segment's state carried over (decision 0031).
#include "model/state_carry_over.hpp"

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
  // A prefactor planned for a coming frame (decision 0085; settled before the rebuild) comes along.
  const Prefactor& fp = f.prefactor;
  Prefactor& tp = t.prefactor;
  if (!fp.pending || fp.record.size() != tp.record.size() || fp.pattern.size() > tp.pattern.capacity()) return;
  tp.pending = true;
  tp.ok = fp.ok;
  tp.frame = fp.frame;
  tp.replaces = fp.replaces;
  tp.dt = fp.dt;
  tp.pattern = fp.pattern;
  tp.record = fp.record;
  tp.gain = fp.gain;
  tp.base_solution = fp.base_solution;
  tp.responses = fp.responses;
}

}  // namespace

void carry_over_state(const WorldModel& from_model, const WorldState& from, const WorldModel& to_model, WorldState& to,
                      std::span<const std::size_t> rod_map, bool carry_solver) {
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
    copy_range(from.now.attachment, a.attachment_offset, to.now.attachment, b.attachment_offset, a.attachments.size());
    // What was torn or cut stays so while the tissue is described alike (else it starts whole).
    if (a.anchor_count == b.anchor_count)
      copy_range(from.now.anchor_intact, a.anchor_offset, to.now.anchor_intact, b.anchor_offset, a.anchor_count);
    if (a.bead_count == b.bead_count)  // beads re-chosen (reconfigure): they start at rest
      copy_range(from.collision.bead_motion, a.bead_offset, to.collision.bead_motion, b.bead_offset, a.bead_count);
    if (carry_solver) carry_chords(from.newton, r, to.newton, rod_map[r]);
  }
  to.collision.report = from.collision.report;
  to.robust_substeps = from.robust_substeps;
  to.robust_newton = from.robust_newton;
  to.robust_good_frames = from.robust_good_frames;
  to.frame = from.frame;
  to.time = from.time;
  to.instruments = from.instruments;
  for (InstrumentState& in : to.instruments) {
    if (!in.grasping) continue;
    const std::size_t old_rod = in.grasp_segment;
    const std::size_t new_rod = rod_map[old_rod];
    if (new_rod == kRodRemoved) {  // what it held is gone: the jaws hold nothing
      in.grasping = in.coupled = false;
      continue;
    }
    const SegmentModel& a = from_model.segments[old_rod];
    const SegmentModel& b = to_model.segments[new_rod];
    if (a.bead_count != b.bead_count) {  // the grasped bead may be gone: let go
      to.now.attachment[in.grasp_attachment - a.attachment_offset + b.attachment_offset].active = false;
      in.grasping = in.coupled = false;
      continue;
    }
    in.grasp_segment = new_rod;
    in.grasp_attachment = in.grasp_attachment - a.attachment_offset + b.attachment_offset;
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
  detail::settle_prefactors(impl_->state, impl_->scheduler);  // what is carried over is finished
  auto fresh =
      std::make_unique<Impl>(next, detail::build_world_model(next, keep_mesh_binding ? &impl_->model : nullptr));
  detail::carry_over_state(impl_->model, impl_->state, fresh->model, fresh->state, rod_map, carry_solver);
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
