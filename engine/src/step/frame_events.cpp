// The events a frame records (unstable, recovered) and their text, written without allocating
// into the event's fixed buffer: which frame, segment, node, quantity and stage, and what to change.
#include <fmt/format.h>

#include "step/sleep.hpp"
#include "step/world_impl.hpp"

namespace haustra {

using detail::GuardResult;

namespace {

constexpr std::size_t kMaxEvents = 1024;

// Appends to an event's text, never past its end.
template <class... Args>
char* append(Event& e, char* it, fmt::format_string<Args...> format, Args&&... args) {
  const std::size_t cap = e.text.size() - 1;
  const auto left = cap - static_cast<std::size_t>(it - e.text.data());
  return fmt::format_to_n(it, left, format, std::forward<Args>(args)...).out;
}

void terminate_text(Event& e, char* it) { *std::min(it, e.text.data() + e.text.size() - 1) = '\0'; }

}  // namespace

// Writes "frame F: segment 'S' (i), node K: <what failed> after stage 'X' with N substeps".
char* World::Impl::describe(Event& e, char* it, std::size_t s, const GuardResult& g, int n) const {
  const auto [piece, node] = piece_of(s, g.node);
  const auto name = std::string_view(model.pieces[piece].info.name);
  if (g.limit > 0.0)
    return append(e, it,
                  "frame {}: segment '{}' ({}), node {}: {} {:.4g} exceeds the limit {:.4g} after stage '{}' with {} "
                  "substep{}",
                  state.frame, name, piece, node, g.quantity, g.value, g.limit, stage_name(g.stage), n,
                  n == 1 ? "" : "s");
  return append(e, it, "frame {}: segment '{}' ({}), node {}: {} after stage '{}' with {} substep{}", state.frame, name,
                piece, node, g.quantity, stage_name(g.stage), n, n == 1 ? "" : "s");
}

Event World::Impl::make_event(Event::Kind kind, std::size_t s, const GuardResult& g, int n) const {
  Event e;
  e.kind = kind;
  e.frame = state.frame;
  std::tie(e.segment, e.node) = piece_of(s, g.node);
  e.stage = g.stage;
  e.substeps = n;
  return e;
}

Event World::Impl::unstable_event(std::size_t failed, const GuardResult& g, const Rung& rung) const {
  Event e = make_event(Event::Kind::unstable, failed, g, rung.substeps);
  char* it = append(e, e.text.data(), "unstable at ");
  it = describe(e, it, failed, g, rung.substeps);
  // Which limit ended the frame's ladder (decision 0100): the policy, its retries, or its top rung.
  if (model.solver.on_instability != InstabilityPolicy::recover)
    it = append(e, it, ". solver.on_instability is \"stop\". ");
  else if (can_escalate(rung))
    it = append(e, it,
                ". The frame's retries ran out ({} of solver.max_retries = {}) before Newton with {} substeps "
                "(solver.max_substeps) was tried. ",
                profile.retries, model.solver.max_retries, model.solver.max_substeps);
  else
    it = append(e, it, ". Newton with {} substep{} (solver.max_substeps) did not recover either. ", rung.substeps,
                rung.substeps == 1 ? "" : "s");
  it = append(e, it,
              "Lower the time step, raise solver.max_substeps or solver.iterations, or soften the loads. The world "
              "keeps its last good frame.");
  terminate_text(e, it);
  return e;
}

Event World::Impl::recovered_event(const Failure& first, const Rung& rung) const {
  Event e = make_event(Event::Kind::recovered, first.segment, first.guard, rung.substeps);
  char* it = append(e, e.text.data(), "recovered: ");
  it = describe(e, it, first.segment, first.guard, first.rung.substeps);
  it = append(e, it, "; the frame was redone with {}{} substep{}", rung.newton ? "Newton and " : "", rung.substeps,
              rung.substeps == 1 ? "" : "s");
  terminate_text(e, it);
  return e;
}

Event World::Impl::slipped_event(std::size_t instrument) const {
  const detail::InstrumentState& s = state.instruments[instrument];
  const detail::InstrumentModel& d = model.instruments[instrument];
  Event e;
  e.kind = Event::Kind::slipped;
  e.frame = state.frame;
  const std::size_t node = model.beads.node[s.grasp_bead] - model.segments[s.grasp_segment].node_offset;
  std::tie(e.segment, e.node) = piece_of(s.grasp_segment, node);
  e.stage = Stage::report;
  const auto name = std::string_view(model.pieces[e.segment].info.name);
  char* it = append(e, e.text.data(),
                    "frame {}: instrument '{}' ({}) lost its grasp on segment '{}' ({}), node {}: ", state.frame,
                    d.name, instrument, name, e.segment, e.node);
  if (s.slip_strain > 0.0)
    it = append(e, it,
                "the organ it pulled stretched to {:.3g}, past the strain its wall takes ({:.3g}): torn out of "
                "its jaws",
                s.slip_strain, model.segments[s.grasp_segment].failure_strain);
  else
    it = append(e, it, "pulled with {:.3g} N, more than its holding force {:.3g} N", s.slip_pull, d.holding_force);
  it = append(e, it, "; close it again to grasp anew");
  terminate_text(e, it);
  return e;
}

// One event per range of anchors: anchors [first, first + count) of one range, torn or cut this frame.
Event World::Impl::anchors_event(Event::Kind kind, std::size_t first, std::size_t count, double largest) const {
  const detail::AnchorRange& range = model.anchor_ranges[model.anchors.range[first]];
  const std::size_t rod = range.rod;
  Event e;
  e.kind = kind;
  e.frame = state.frame;
  e.stage = Stage::report;
  const std::size_t rod_node = model.anchors.node[first] - model.segments[rod].node_offset;
  std::tie(e.segment, e.node) = piece_of(rod, rod_node);
  const std::size_t last_node = model.anchors.node[first + count - 1] - model.segments[rod].node_offset;
  const auto name = std::string_view(model.pieces[e.segment].info.name);
  char* it = append(e, e.text.data(), "frame {}: {} anchor{} of '{}' on segment '{}' ({}), node{} {}", state.frame,
                    count, count == 1 ? "" : "s", range.name, name, e.segment, count == 1 ? "" : "s", e.node);
  if (count > 1) it = append(e, it, " to {}", e.node + (last_node - rod_node));
  if (kind == Event::Kind::torn)
    it = append(e, it, ", tore: pulled with up to {:.3g} N, past {:.3g} N the tissue holds", largest,
                model.anchors.strength[first]);
  else
    it = append(e, it, ", cut");
  it = append(e, it, "; the organ is free there");
  terminate_text(e, it);
  return e;
}

// Anchors listed in anchor order (a range's are contiguous): one event per run of one range.
void World::Impl::record_anchors(Event::Kind kind, std::span<const detail::TornAnchor> anchors) {
  detail::wake_torn(model, state, anchors);  // a sleeping rod whose tissue gave way moves again
  std::size_t i = 0;
  while (i < anchors.size()) {
    const std::uint32_t range = model.anchors.range[anchors[i].anchor];
    std::size_t j = i;
    double largest = 0.0;
    while (j < anchors.size() && model.anchors.range[anchors[j].anchor] == range)
      largest = std::max(largest, anchors[j++].tension);
    record(anchors_event(kind, anchors[i].anchor, anchors[j - 1].anchor - anchors[i].anchor + 1, largest));
    i = j;
  }
}

void World::Impl::record(const Event& e) {
  if (events.size() < kMaxEvents)
    events.push_back(e);  // capacity reserved at creation
  else
    events_dropped += 1;
}

void World::Impl::reserve_events() { events.reserve(kMaxEvents); }

}  // namespace haustra
