#pragma once
// World::Impl: a world's model, state, scheduler, profile and events — what the API's accessors
// (world.cpp), the frame pipeline (frame.cpp), checkpoints and rebuilding share.
#include <fmt/format.h>

#include <utility>
#include <vector>

#include "haustra/error.hpp"
#include "haustra/world.hpp"
#include "model/world_model.hpp"
#include "step/rod_stages.hpp"
#include "step/scheduler.hpp"
#include "step/world_state.hpp"

namespace haustra {

struct World::Impl {
  WorldDesc desc;  // what the model was built from: adding or removing a segment rebuilds it
  detail::WorldModel model;
  detail::WorldState state;
  detail::Scheduler scheduler;
  FrameProfile profile;
  std::vector<Event> events;
  std::vector<detail::GuardResult> guard;
  // A rung of the robust mode's ladder: how a frame is attempted.
  struct Rung {
    int substeps;
    bool newton;
  };
  Rung base{1, false};  // what the scene asked for; the rung it runs now is in the state
  bool any_free_base = false;
  bool any_constraints = false;

  Impl(WorldDesc d, detail::WorldModel m);

  // frame.cpp: one frame with the robust mode's ladder, one attempt at it, the meshes after it.
  void step();
  std::size_t run_frame(int n, bool newton, bool chord);
  void follow_rod();

  // The API's segment (a piece of a chain, or the whole rod) that holds node `node` of rod `rod`,
  // and the node's index in it; a joint node counts as the later piece's base.
  [[nodiscard]] std::pair<std::size_t, std::size_t> piece_of(std::size_t rod, std::size_t node) const;

  // The API's segment `segment` (a piece of the model), or an error naming the range.
  [[nodiscard]] const detail::SegmentPiece& piece(std::size_t segment) const {
    if (segment >= model.pieces.size())
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("segment index {} out of range (the world has {})", segment, model.pieces.size()));
    return model.pieces[segment];
  }

  [[nodiscard]] const detail::SegmentMesh& mesh_of(std::size_t segment) const {
    (void)piece(segment);  // the range check
    return model.meshes_of[segment];
  }

  void check_instrument(std::size_t i) const {
    if (i >= model.instruments.size())
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("instrument index {} out of range (the world has {})", i, model.instruments.size()));
  }

  // Attachments belong to rods: every piece of a chain addresses its chain's attachments.
  [[nodiscard]] std::size_t attachment_index(std::size_t segment, std::size_t attachment) const {
    const auto& seg = model.segments[piece(segment).rod];
    if (attachment >= seg.attachments.size())
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("segment '{}' has {} attachments, asked for index {}", model.pieces[segment].info.name,
                              seg.attachments.size(), attachment));
    return seg.attachment_offset + attachment;
  }

 private:
  // A stage timed into the profile: per segment over the scheduler when fn takes a segment
  // index, else world-wide (fn spreads its own work).
  template <class F>
  void stage(Stage stage, F&& fn);
  template <class It>
  It describe(It out, std::size_t max, std::size_t s, const detail::GuardResult& g, int n) const;
  [[nodiscard]] Event make_event(Event::Kind kind, std::size_t s, const detail::GuardResult& g, int n) const;
  void record(const Event& e);
  [[nodiscard]] bool can_escalate(const Rung& r) const;
  [[nodiscard]] Rung escalate(const Rung& r) const;
};

}  // namespace haustra
