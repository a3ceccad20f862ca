// Four rods of one node count condensed at once, one rod per lane of a 4-double vector
// (rod_condensed.hpp: rod_condense_lanes): condensed_rows.hpp's sweep instantiated with T = L, its
// numbers gathered from the four rods and its gains and bases given back to each.
#include <array>

#include "condensed_rows.hpp"
#include "haustra/kernels/rod_condensed.hpp"

namespace haustra::kernels {

void rod_condense_lanes(const std::array<const RodLinearization*, kCondensedLanes>& rods,
                        const std::array<StrainView<const double>, kCondensedLanes>& residuals,
                        const std::array<CondensedSystem, kCondensedLanes>& systems,
                        std::array<CondenseReport, kCondensedLanes>& reports) {
  using condensed::L;
  static_assert(condensed::Rods<L>::kLanes == kCondensedLanes);
  const std::size_t last = rods[0]->poses.node_count() - 1;
  L scratch[30 * condensed::kZ];  // the sweep's rows, four rods to a value
  condensed::sweep<L, condensed::kZ>({rods, residuals}, {}, systems, {0, last, false, {}}, scratch, reports);
}

}  // namespace haustra::kernels
