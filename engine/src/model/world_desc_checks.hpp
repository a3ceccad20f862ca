#pragma once
// check_world_desc: a world description's fields checked before anything is built.
#include "haustra/world_desc.hpp"

namespace haustra::detail {

// Throws FieldError naming the field (invalid_argument) for the first value out of its range.
void check_world_desc(const WorldDesc& desc);
// A world that would not fit is refused before anything is built (decision 0038).
void check_memory(const WorldDesc& desc);
// An instrument's fields (FieldError naming instrument[i].field); its axes normalized.
void check_instrument(InstrumentDesc& instrument, std::size_t i);

}  // namespace haustra::detail
