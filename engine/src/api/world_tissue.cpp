// World's connective tissue: its anchors, their tensions, and cutting them (decision 0095).
#include <fmt/format.h>

#include <cmath>

#include "haustra/kernels/tissue_anchor.hpp"
#include "model/field_checks.hpp"
#include "step/anchors.hpp"
#include "step/world_impl.hpp"

namespace haustra {

std::size_t World::anchor_count() const { return impl_->model.anchors.size(); }

std::span<const std::uint32_t> World::anchor_nodes() const { return impl_->model.anchors.node; }

std::span<const Eigen::Vector3d> World::anchor_targets() const { return impl_->model.anchors.target; }

std::span<const std::uint8_t> World::anchors_intact() const { return impl_->state.now.anchor_intact; }

void World::anchor_tensions(std::span<double> out) const {
  const detail::AnchorModel& an = impl_->model.anchors;
  if (out.size() != an.size())
    throw Error(
        ErrorCode::invalid_argument,
        fmt::format("World::anchor_tensions: expected {} values (one per anchor), got {}", an.size(), out.size()));
  const auto pos = impl_->state.now.position.view();
  for (std::size_t a = 0; a < an.size(); ++a)
    out[a] = impl_->state.now.anchor_intact[a] != 0
                 ? kernels::tissue_anchor_tension(pos.get(an.node[a]), an.target[a], an.stiffness[a], an.slack[a])
                 : 0.0;
}

std::size_t World::cut_tissue(const Eigen::Vector3d& centre, double radius) {
  const Use use(*this);
  if (!centre.allFinite() || centre.cwiseAbs().maxCoeff() > detail::kMaxVectorComponent)
    throw FieldError(ErrorCode::invalid_argument, "centre", "expected three finite numbers within ±1e5 (m)",
                     "World::cut_tissue: centre: expected three finite numbers within ±1e5 (m)");
  if (!(radius > 0.0) || !(radius <= detail::kMaxVectorComponent))
    throw FieldError(ErrorCode::invalid_argument, "radius",
                     fmt::format("expected a radius in (0, 1e5] m, got {}", radius),
                     fmt::format("World::cut_tissue: radius: expected a radius in (0, 1e5] m, got {}", radius));
  return impl_->cut_tissue(centre, radius);
}

std::size_t World::Impl::cut_tissue(const Eigen::Vector3d& centre, double radius) {
  torn.clear();
  detail::cut_anchors(model, state, centre, radius, torn);
  record_anchors(Event::Kind::cut, torn);
  return torn.size();
}

}  // namespace haustra
