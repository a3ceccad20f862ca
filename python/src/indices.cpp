// Index arguments checked, and counted from the end when negative (decision 0088).
#include "indices.hpp"

#include <fmt/format.h>

#include <string>

namespace haustra::python {
namespace {

// "3 instruments: 0 to 2, or -3 to -1 from the end"; "no instruments".
std::string range_of(std::size_t count, const char* what) {
  if (count == 0) return fmt::format("no {}s", what);
  if (count == 1) return fmt::format("1 {}: 0, or -1 from the end", what);
  return fmt::format("{} {}s: 0 to {}, or -{} to -1 from the end", count, what, count - 1, count);
}

std::size_t checked(const IndexArg& arg, std::size_t count, const char* call, const char* what,
                    const std::string& owner, const std::string& note = {}) {
  const auto n = static_cast<std::int64_t>(count);
  const std::int64_t index = arg.value;
  if (!arg.beyond.empty() || index < -n || index >= n)
    throw IndexOutOfRange(fmt::format("{}: {} {} is out of range ({} has {}{})", call, what,
                                      arg.beyond.empty() ? std::to_string(index) : arg.beyond, owner,
                                      range_of(count, what), note));
  return static_cast<std::size_t>(index < 0 ? index + n : index);
}

}  // namespace

std::size_t node_index(const World& world, const IndexArg& node, const char* call) {
  return checked(node, world.node_count(), call, "node", "the world");
}

std::size_t segment_index(const World& world, const IndexArg& segment, const char* call) {
  return checked(segment, world.segment_count(), call, "segment", "the world");
}

std::size_t instrument_index(const World& world, const IndexArg& instrument, const char* call) {
  return checked(instrument, world.instrument_count(), call, "instrument", "the world");
}

std::size_t attachment_index(const World& world, std::size_t segment, const IndexArg& attachment, const char* call) {
  const std::size_t count = world.attachment_count(segment), scene = world.segment_desc(segment).attachments.size();
  std::string note;
  if (count == scene + 1) note = "; the last is the instrument's grasp slot";
  if (count > scene + 1) note = fmt::format("; the last {} are grasp slots, one per instrument", count - scene);
  return checked(attachment, count, call, "attachment",
                 fmt::format("segment {} ('{}')", segment, world.segment(segment).name), note);
}

}  // namespace haustra::python
