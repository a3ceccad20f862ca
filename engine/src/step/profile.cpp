// The stages' names, as profiles, events and reports print them.
#include "haustra/profile.hpp"

namespace haustra {

std::string_view stage_name(Stage s) noexcept {
  switch (s) {
#define HAUSTRA_STAGE_NAME(name, meaning) \
  case Stage::name: return #name;
    HAUSTRA_STAGES(HAUSTRA_STAGE_NAME)
#undef HAUSTRA_STAGE_NAME
    case Stage::count: break;
  }
  return "?";
}

}  // namespace haustra
