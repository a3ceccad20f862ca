#include "haustra/kernels/broad_phase.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace haustra::kernels {

std::size_t broad_phase_brute(const SphereSet& s, double margin, std::span<SpherePair> out) {
  std::size_t count = 0;
  const std::size_t n = s.size();
  for (std::size_t a = 0; a < n; ++a)
    for (std::size_t b = a + 1; b < n; ++b)
      if (spheres_near(s, a, b, margin)) {
        if (count < out.size()) out[count] = {static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(b)};
        ++count;
      }
  return count;
}

std::size_t broad_phase_sweep(const SphereSet& s, double margin, std::span<std::uint32_t> order,
                              std::span<SpherePair> out) {
  const std::size_t n = s.size();
  for (std::size_t i = 0; i < n; ++i) order[i] = static_cast<std::uint32_t>(i);
  // Ties broken by index: the same order on every run.
  std::sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(n), [&](std::uint32_t a, std::uint32_t b) {
    const double la = s.x[a] - s.radius[a], lb = s.x[b] - s.radius[b];
    return la < lb || (la == lb && a < b);
  });
  std::size_t count = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t a = order[i];
    const double hi = s.x[a] + s.radius[a] + margin;
    for (std::size_t j = i + 1; j < n; ++j) {
      const std::uint32_t b = order[j];
      if (s.x[b] - s.radius[b] > hi) break;
      if (spheres_near(s, a, b, margin)) {
        if (count < out.size()) out[count] = {std::min(a, b), std::max(a, b)};
        ++count;
      }
    }
  }
  if (count <= out.size())
    std::sort(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(count),
              [](const SpherePair& p, const SpherePair& q) { return p.a < q.a || (p.a == q.a && p.b < q.b); });
  return count;
}

namespace {

constexpr int kKeyBits = 21;  // per axis: 2M cells
constexpr std::int64_t kMaxCell = (std::int64_t{1} << kKeyBits) - 1;
constexpr std::int64_t kLargeCells = 8;      // a box over more cells than this per axis is "large"
constexpr double kBoundaryGrowth = 1e-9;     // of a cell: boxes that touch share a cell despite rounding

std::uint64_t mix(std::uint64_t x) {  // splitmix64 finalizer
  x ^= x >> 30;
  x *= 0xbf58476d1ce4e5b9ULL;
  x ^= x >> 27;
  x *= 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

}  // namespace

std::uint64_t SphereGrid::key(std::int64_t ix, std::int64_t iy, std::int64_t iz) {
  return (static_cast<std::uint64_t>(ix) << (2 * kKeyBits)) | (static_cast<std::uint64_t>(iy) << kKeyBits) |
         static_cast<std::uint64_t>(iz);
}

std::size_t SphereGrid::bucket(std::uint64_t k) const { return static_cast<std::size_t>(mix(k)) & bucket_mask_; }

SphereGrid::CellBox SphereGrid::box_of(const SphereSet& s, std::size_t i) const {
  const double grow = s.radius[i] + 0.5 * margin_ + kBoundaryGrowth * cell_;
  const double c[3] = {s.x[i], s.y[i], s.z[i]};
  CellBox b{};
  for (int d = 0; d < 3; ++d) {
    b.lo[d] = std::clamp(static_cast<std::int64_t>(std::floor((c[d] - grow - origin_[d]) / cell_)), std::int64_t{0}, kMaxCell);
    b.hi[d] = std::clamp(static_cast<std::int64_t>(std::floor((c[d] + grow - origin_[d]) / cell_)), std::int64_t{0}, kMaxCell);
  }
  return b;
}

void SphereGrid::build(const SphereSet& s, double margin, double cell) {
  const std::size_t n = s.size();
  margin_ = margin;
  unsorted_.clear();
  if (n == 0) {
    entries_.clear();
    bucket_start_.assign(2, 0);
    bucket_mask_ = 0;
    return;
  }
  double lo[3] = {std::numeric_limits<double>::max(), std::numeric_limits<double>::max(),
                  std::numeric_limits<double>::max()};
  double hi[3] = {std::numeric_limits<double>::lowest(), std::numeric_limits<double>::lowest(),
                  std::numeric_limits<double>::lowest()};
  for (std::size_t i = 0; i < n; ++i) {
    const double c[3] = {s.x[i], s.y[i], s.z[i]};
    const double g = s.radius[i] + 0.5 * margin;
    for (int d = 0; d < 3; ++d) {
      lo[d] = std::min(lo[d], c[d] - g);
      hi[d] = std::max(hi[d], c[d] + g);
    }
  }
  if (cell <= 0.0) {
    radii_.assign(s.radius.begin(), s.radius.end());
    std::nth_element(radii_.begin(), radii_.begin() + static_cast<std::ptrdiff_t>(n / 2), radii_.end());
    cell = 2.0 * radii_[n / 2] + margin;
  }
  // Keep the grid within the key's range: a scene far larger than its beads gets coarser cells.
  double extent = 0.0;
  for (int d = 0; d < 3; ++d) extent = std::max(extent, hi[d] - lo[d]);
  cell_ = std::max({cell, extent / static_cast<double>(kMaxCell - 1), 1e-12});
  for (int d = 0; d < 3; ++d) origin_[d] = lo[d] - cell_;  // a cell of slack below the lowest box
  large_.clear();
  is_large_.assign(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const CellBox b = box_of(s, i);
    if (b.hi[0] - b.lo[0] >= kLargeCells || b.hi[1] - b.lo[1] >= kLargeCells || b.hi[2] - b.lo[2] >= kLargeCells) {
      large_.push_back(static_cast<std::uint32_t>(i));
      is_large_[i] = 1;
      continue;
    }
    for (std::int64_t ix = b.lo[0]; ix <= b.hi[0]; ++ix)
      for (std::int64_t iy = b.lo[1]; iy <= b.hi[1]; ++iy)
        for (std::int64_t iz = b.lo[2]; iz <= b.hi[2]; ++iz) unsorted_.push_back({key(ix, iy, iz), static_cast<std::uint32_t>(i)});
  }
  // Bucket by hash with a stable counting sort: entries of one cell stay in sphere order.
  std::size_t buckets = 1;
  while (buckets < 2 * unsorted_.size()) buckets <<= 1;
  bucket_mask_ = buckets - 1;
  bucket_start_.assign(buckets + 1, 0);
  for (const Entry& e : unsorted_) ++bucket_start_[bucket(e.key) + 1];
  for (std::size_t b = 0; b < buckets; ++b) bucket_start_[b + 1] += bucket_start_[b];
  entries_.resize(unsorted_.size());
  for (const Entry& e : unsorted_) {
    const std::size_t b = bucket(e.key);
    entries_[bucket_start_[b]++] = e;
  }
  for (std::size_t b = buckets; b > 0; --b) bucket_start_[b] = bucket_start_[b - 1];
  bucket_start_[0] = 0;
}

std::size_t SphereGrid::query(const SphereSet& s, std::size_t first, std::size_t last, std::span<SpherePair> out) const {
  std::size_t count = 0;
  auto emit = [&](std::size_t a, std::uint32_t b) {
    if (!spheres_near(s, a, b, margin_)) return;
    if (count < out.size()) out[count] = {static_cast<std::uint32_t>(a), b};
    ++count;
  };
  for (std::size_t a = first; a < last; ++a) {
    const std::size_t begin = count;
    if (is_large_[a] != 0) {
      // A large sphere meets everything after it directly.
      for (std::size_t b = a + 1; b < s.size(); ++b) emit(a, static_cast<std::uint32_t>(b));
      continue;
    }
    // Large spheres after a, then the grid's neighbours.
    for (auto it = std::upper_bound(large_.begin(), large_.end(), static_cast<std::uint32_t>(a)); it != large_.end(); ++it)
      emit(a, *it);
    const CellBox ba = box_of(s, a);
    for (std::int64_t ix = ba.lo[0]; ix <= ba.hi[0]; ++ix)
      for (std::int64_t iy = ba.lo[1]; iy <= ba.hi[1]; ++iy)
        for (std::int64_t iz = ba.lo[2]; iz <= ba.hi[2]; ++iz) {
          const std::uint64_t k = key(ix, iy, iz);
          const std::size_t bk = bucket(k);
          for (std::size_t e = bucket_start_[bk]; e < bucket_start_[bk + 1]; ++e) {
            if (entries_[e].key != k) continue;
            const std::uint32_t b = entries_[e].sphere;
            if (b <= a) continue;
            // Report from the first cell both boxes share only.
            const CellBox bb = box_of(s, b);
            if (std::max(ba.lo[0], bb.lo[0]) != ix || std::max(ba.lo[1], bb.lo[1]) != iy ||
                std::max(ba.lo[2], bb.lo[2]) != iz)
              continue;
            emit(a, b);
          }
        }
    if (count <= out.size())
      std::sort(out.begin() + static_cast<std::ptrdiff_t>(begin), out.begin() + static_cast<std::ptrdiff_t>(count),
                [](const SpherePair& p, const SpherePair& q) { return p.b < q.b; });
  }
  return count;
}

}  // namespace haustra::kernels
