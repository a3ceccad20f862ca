// A rebuilt world's state: every kept rod's carried over from the old one (decision 0031). The
// World's calls that rebuild it from a new description are in api/world_rebuild.cpp.
#include "step/state_carry_over.hpp"

#include <algorithm>

namespace haustra::detail {
namespace {

template <class From, class To>  // vectors or spans
void copy_range(const From& from, std::size_t from_offset, To&& to, std::size_t to_offset, std::size_t count) {
  std::copy_n(from.begin() + static_cast<std::ptrdiff_t>(from_offset), count,
              to.begin() + static_cast<std::ptrdiff_t>(to_offset));
}

void copy_range(const Vec3Buffer& from, std::size_t fo, Vec3Buffer& to, std::size_t tofs, std::size_t n) {
  copy_range(from.x, fo, to.x, tofs, n);
  copy_range(from.y, fo, to.y, tofs, n);
  copy_range(from.z, fo, to.z, tofs, n);
}

void copy_range(const RotationBuffer& from, std::size_t fo, RotationBuffer& to, std::size_t tofs, std::size_t n) {
  copy_range(from.w, fo, to.w, tofs, n);
  copy_range(from.x, fo, to.x, tofs, n);
  copy_range(from.y, fo, to.y, tofs, n);
  copy_range(from.z, fo, to.z, tofs, n);
}

// One kept buffer of a rod (state/world_state.hpp's lists): its nodes' entries, or its own entry.
// Attachment slots and anchors move by their own maps (carry_over_state).
template <Per per, std::size_t width, class Buffer>
void carry_buffer(const Buffer& from, Buffer& to, const SegmentModel& a, std::size_t r, const SegmentModel& b,
                  std::size_t new_r) {
  if constexpr (per == Per::node)
    copy_range(from, width * a.node_offset, to, width * b.node_offset, width * a.node_count);
  else if constexpr (per == Per::segment)
    copy_range(from, width * r, to, width * new_r, width);
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
  // Not one made around a sleeping range (decision 0127): a rebuild wakes every range, and that
  // factorization holds no gains over its range (nor are its base side's columns carried).
  t.chord_ready = f.chord_ready && f.chord_from == 0 && f.chord_first == 0;
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
#define HAUSTRA_CARRY_KEPT(owner, type, name, per, width, role) \
  if constexpr (Role::role == Role::kept)                       \
    carry_buffer<Per::per, width>(from.owner name, to.owner name, a, r, b, rod_map[r]);
#define HAUSTRA_CARRY_NOW(type, name, per, width, initial, role, meaning) \
  HAUSTRA_CARRY_KEPT(now., type, name, per, width, role)
#define HAUSTRA_CARRY_FRAME(type, name, per, width, initial, role, meaning) \
  HAUSTRA_CARRY_KEPT(, type, name, per, width, role)
    HAUSTRA_PERSISTENT_STATE(HAUSTRA_CARRY_NOW)
    HAUSTRA_FRAME_STATE(HAUSTRA_CARRY_FRAME)
#undef HAUSTRA_CARRY_FRAME
#undef HAUSTRA_CARRY_NOW
#undef HAUSTRA_CARRY_KEPT
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
