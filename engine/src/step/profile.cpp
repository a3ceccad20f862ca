// The stages' names, as profiles, events and reports print them.
#include "haustra/profile.hpp"

namespace haustra {

std::string_view stage_name(Stage s) noexcept {
  switch (s) {
    case Stage::instruments: return "instruments";
    case Stage::snapshot: return "snapshot";
    case Stage::collide: return "collide";
    case Stage::contacts: return "contacts";
    case Stage::proxy: return "proxy";
    case Stage::loads: return "loads";
    case Stage::free_base: return "free_base";
    case Stage::backward_sweep: return "backward_sweep";
    case Stage::condense: return "condense";
    case Stage::solve: return "solve";
    case Stage::line_search: return "line_search";
    case Stage::constraints: return "constraints";
    case Stage::forward_sweep: return "forward_sweep";
    case Stage::filter: return "filter";
    case Stage::contraction: return "contraction";
    case Stage::guard: return "guard";
    case Stage::report: return "report";
    case Stage::cage: return "cage";
    case Stage::skin: return "skin";
    case Stage::normals: return "normals";
    case Stage::count: break;
  }
  return "?";
}

}  // namespace haustra
