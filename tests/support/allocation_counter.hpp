#pragma once
// Counts heap allocations while a scope is armed: operator new everywhere, and malloc and its kin
// where no sanitizer owns them (the replacements live in allocation_counter.cpp and serve the
// whole test binary).
#include <atomic>
#include <cstddef>

namespace haustra::test {

extern std::atomic<bool> g_count_allocations;
extern std::atomic<std::size_t> g_allocations;

class AllocationScope {
 public:
  AllocationScope() {
    g_allocations = 0;
    g_count_allocations = true;
  }
  ~AllocationScope() { g_count_allocations = false; }
  AllocationScope(const AllocationScope&) = delete;
  AllocationScope& operator=(const AllocationScope&) = delete;
  [[nodiscard]] std::size_t count() const { return g_allocations; }
};

}  // namespace haustra::test
