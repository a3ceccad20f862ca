// The broad phase over beads: a uniform grid of spheres and the pairs whose grown spheres overlap.
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

namespace {

constexpr int kKeyBits = 21;  // per axis: 2M cells
constexpr std::int64_t kMaxCell = (std::int64_t{1} << kKeyBits) - 1;
// A sphere whose reach (2r + margin) is more than this many times the median's stays out of the
// grid: one outlier must not coarsen the cells for everybody.
constexpr double kLargeReach = 8.0;
// Cells are this much wider than the widest reach in them, so that two spheres within reach
// always have centres in the same or adjacent cells despite rounding.
constexpr double kCellSlack = 1e-9;
// A dense array of cells is used when it has at most this many cells, or this many per sphere.
constexpr std::size_t kMaxDenseCells = std::size_t{1} << 16;
constexpr std::size_t kDenseCellsPerSphere = 8;

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

std::size_t SphereGrid::bucket(std::int64_t ix, std::int64_t iy, std::int64_t iz) const {
  // Dense: the cell's own index, z fastest, so neighbouring cells are neighbours in memory.
  if (dense_)
    return static_cast<std::size_t>((static_cast<std::uint64_t>(ix) * dims_[1] + static_cast<std::uint64_t>(iy)) *
                                        dims_[2] +
                                    static_cast<std::uint64_t>(iz));
  return static_cast<std::size_t>(mix(key(ix, iy, iz))) & bucket_mask_;
}

namespace {

// The box around the spheres' centres.
void centre_bounds(const SphereSet& s, double (&lo)[3], double (&hi)[3]) {
  for (int d = 0; d < 3; ++d) {
    lo[d] = std::numeric_limits<double>::max();
    hi[d] = std::numeric_limits<double>::lowest();
  }
  for (std::size_t i = 0; i < s.size(); ++i) {
    const double c[3] = {s.x[i], s.y[i], s.z[i]};
    for (int d = 0; d < 3; ++d) {
      lo[d] = std::min(lo[d], c[d]);
      hi[d] = std::max(hi[d], c[d]);
    }
  }
}

}  // namespace

std::int64_t SphereGrid::cell_of(double coordinate, int axis) const {
  return std::clamp(static_cast<std::int64_t>(std::floor((coordinate - origin_[axis]) * inverse_cell_)),
                    std::int64_t{0}, kMaxCell);
}

void SphereGrid::build(const SphereSet& s, double margin, double cell) {
  const std::size_t n = s.size();
  margin_ = margin;
  // The most buckets either way (dense: the cells allowed; hashed: twice the spheres, rounded up to
  // a power of two), reserved once: a scene that spreads out later must not allocate in a step.
  bucket_start_.reserve(std::max(kMaxDenseCells, kDenseCellsPerSphere * n) + 4 * n + 1);
  unsorted_.clear();
  large_.clear();
  is_large_.assign(n, 0);
  if (n == 0) {
    entries_.clear();
    bucket_start_.assign(2, 0);
    bucket_mask_ = 0;
    dense_ = false;
    return;
  }
  double lo[3], hi[3];
  centre_bounds(s, lo, hi);
  auto reach = [&](std::size_t i) { return 2.0 * s.radius[i] + margin; };
  if (cell <= 0.0) {
    // The widest reach short of the outliers: any two such spheres in reach sit in adjacent cells.
    radii_.assign(s.radius.begin(), s.radius.end());
    std::nth_element(radii_.begin(), radii_.begin() + static_cast<std::ptrdiff_t>(n / 2), radii_.end());
    const double limit = kLargeReach * (2.0 * radii_[n / 2] + margin);
    cell = 0.0;
    for (std::size_t i = 0; i < n; ++i)
      if (reach(i) <= limit) cell = std::max(cell, reach(i));
  }
  // Keep the grid within the key's range: a scene far larger than its beads gets coarser cells.
  double extent = 0.0;
  for (int d = 0; d < 3; ++d) extent = std::max(extent, hi[d] - lo[d]);
  cell_ = std::max({cell * (1.0 + kCellSlack), extent / static_cast<double>(kMaxCell - 3), 1e-12});
  inverse_cell_ = 1.0 / cell_;
  for (int d = 0; d < 3; ++d) origin_[d] = lo[d] - cell_;  // a cell of slack below the lowest centre
  // A sphere that reaches further than a cell is tested against every other directly.
  for (std::size_t i = 0; i < n; ++i) {
    if (reach(i) * (1.0 + kCellSlack) > cell_) {
      large_.push_back(static_cast<std::uint32_t>(i));
      is_large_[i] = 1;
      continue;
    }
    unsorted_.push_back({s.x[i], s.y[i], s.z[i], s.radius[i], static_cast<std::uint32_t>(cell_of(s.x[i], 0)),
                         static_cast<std::uint32_t>(cell_of(s.y[i], 1)), static_cast<std::uint32_t>(cell_of(s.z[i], 2)),
                         static_cast<std::uint32_t>(i), 0});
  }
  // Bucket with a stable counting sort (a cell's spheres stay in index order): by cell when a
  // dense array of cells is small next to the spheres, which keeps neighbouring cells together in
  // memory; by a hash of the cell otherwise (beads scattered over a large, mostly empty space).
  double cells = 1.0;  // in double: a sparse scene's product overflows any integer
  for (int d = 0; d < 3; ++d) {
    dims_[d] = static_cast<std::uint64_t>(cell_of(hi[d], d)) + 2;  // and a cell of slack above
    cells *= static_cast<double>(dims_[d]);
  }
  dense_ = cells <= static_cast<double>(std::max(kMaxDenseCells, kDenseCellsPerSphere * n));
  std::size_t buckets = 1;
  if (dense_) {
    buckets = static_cast<std::size_t>(cells);
  } else {
    while (buckets < 2 * unsorted_.size()) buckets <<= 1;
  }
  bucket_mask_ = buckets - 1;
  bucket_start_.assign(buckets + 1, 0);
  for (Entry& e : unsorted_) {
    e.bucket = static_cast<std::uint32_t>(bucket(e.ix, e.iy, e.iz));
    ++bucket_start_[e.bucket + 1];
  }
  for (std::size_t b = 0; b < buckets; ++b) bucket_start_[b + 1] += bucket_start_[b];
  entries_.resize(unsorted_.size());
  for (const Entry& e : unsorted_) entries_[bucket_start_[e.bucket]++] = e;
  for (std::size_t b = buckets; b > 0; --b) bucket_start_[b] = bucket_start_[b - 1];
  bucket_start_[0] = 0;
}

std::size_t SphereGrid::query(const SphereSet& s, std::size_t first, std::size_t last,
                              std::span<SpherePair> out) const {
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
    // Large spheres after a, then the spheres centred in a's cell and the 26 around it: within
    // reach of a, a sphere no wider than a cell is centred no more than a cell away.
    for (auto it = std::upper_bound(large_.begin(), large_.end(), static_cast<std::uint32_t>(a)); it != large_.end();
         ++it)
      emit(a, *it);
    const std::int64_t cx = cell_of(s.x[a], 0), cy = cell_of(s.y[a], 1), cz = cell_of(s.z[a], 2);
    // The entries of buckets [b0, b1) that are cells (ix, iy, iz0..iz1) and spheres after a. A
    // dense grid's buckets are its cells; a hashed one's may be shared between cells.
    auto test = [&](std::size_t b0, std::size_t b1, std::int64_t ix, std::int64_t iy, std::int64_t iz0,
                    std::int64_t iz1) {
      for (std::size_t e = bucket_start_[b0]; e < bucket_start_[b1]; ++e) {
        const Entry& entry = entries_[e];
        if (entry.sphere <= a) continue;
        if (!dense_ && (entry.ix != ix || entry.iy != iy || entry.iz < iz0 || entry.iz > iz1)) continue;
        // spheres_near on the copy: the same operations, so the same answer bit for bit.
        const double dx = s.x[a] - entry.x, dy = s.y[a] - entry.y, dz = s.z[a] - entry.z;
        const double within = s.radius[a] + entry.radius + margin_;
        if (dx * dx + dy * dy + dz * dz > within * within) continue;
        if (count < out.size()) out[count] = {static_cast<std::uint32_t>(a), entry.sphere};
        ++count;
      }
    };
    for (std::int64_t ix = std::max<std::int64_t>(cx - 1, 0); ix <= cx + 1; ++ix)
      for (std::int64_t iy = std::max<std::int64_t>(cy - 1, 0); iy <= cy + 1; ++iy) {
        const std::int64_t iz0 = std::max<std::int64_t>(cz - 1, 0), iz1 = cz + 1;
        if (dense_) {  // a row of cells along z is a run of buckets: one range, not three
          const std::size_t b0 = bucket(ix, iy, iz0);
          test(b0, b0 + static_cast<std::size_t>(iz1 - iz0) + 1, ix, iy, iz0, iz1);
          continue;
        }
        for (std::int64_t iz = iz0; iz <= iz1; ++iz) {
          const std::size_t bk = bucket(ix, iy, iz);
          test(bk, bk + 1, ix, iy, iz, iz);
        }
      }
    if (count <= out.size())
      std::sort(out.begin() + static_cast<std::ptrdiff_t>(begin), out.begin() + static_cast<std::ptrdiff_t>(count),
                [](const SpherePair& p, const SpherePair& q) { return p.b < q.b; });
  }
  return count;
}

}  // namespace haustra::kernels
