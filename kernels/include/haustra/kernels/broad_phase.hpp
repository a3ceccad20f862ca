#pragma once
// Broad phase over spheres (beads): every pair whose spheres, grown by a margin, overlap:
//   |c_a − c_b| ≤ r_a + r_b + margin,  a < b,
// reported in ascending (a, b) order so that results do not depend on how the work was split.
// Three methods that must agree exactly: brute force (the reference, best for tiny sets), a
// sort-and-sweep along x, and a uniform grid (cost per sphere flat in the count). The grid is
// built once and queried over ranges of spheres, so a caller can spread the queries over threads.
#include <cstdint>
#include <span>
#include <vector>

namespace haustra::kernels {

struct SpherePair {
  std::uint32_t a = 0;
  std::uint32_t b = 0;
  friend bool operator==(const SpherePair&, const SpherePair&) = default;
};

struct SphereSet {
  std::span<const double> x, y, z, radius;
  [[nodiscard]] std::size_t size() const { return x.size(); }
};

// Exact test shared by every method.
[[nodiscard]] inline bool spheres_near(const SphereSet& s, std::size_t a, std::size_t b, double margin) {
  const double dx = s.x[a] - s.x[b], dy = s.y[a] - s.y[b], dz = s.z[a] - s.z[b];
  const double reach = s.radius[a] + s.radius[b] + margin;
  return dx * dx + dy * dy + dz * dz <= reach * reach;
}

// The three methods write at most out.size() pairs and return how many there are; when the
// return exceeds out.size(), the caller grows `out` and calls again.
std::size_t broad_phase_brute(const SphereSet& s, double margin, std::span<SpherePair> out);

// Sort-and-sweep along x. order: scratch of s.size().
std::size_t broad_phase_sweep(const SphereSet& s, double margin, std::span<std::uint32_t> order,
                              std::span<SpherePair> out);

// Uniform grid as a spatial hash. Each sphere is entered in every cell its margin-grown box
// touches; cells are found through a hash of their integer coordinates, bucketed by a stable
// counting sort (O(n), deterministic). A pair is reported only from the first cell both boxes
// share, so no pair comes twice. Spheres much larger than a cell (a box over more than 8 cells
// along an axis) stay out of the grid and are tested against every sphere directly. Buffers are
// kept between builds: no allocation once warm.
class SphereGrid {
 public:
  // cell: edge length; 0 chooses twice the median radius plus the margin.
  void build(const SphereSet& s, double margin, double cell = 0.0);
  // Pairs (a, b) with first ≤ a < last, in ascending order. Pure: callable concurrently.
  std::size_t query(const SphereSet& s, std::size_t first, std::size_t last, std::span<SpherePair> out) const;
  [[nodiscard]] double cell_size() const { return cell_; }

 private:
  struct Entry {
    std::uint64_t key;
    std::uint32_t sphere;
  };
  struct CellBox {
    std::int64_t lo[3], hi[3];
  };
  [[nodiscard]] CellBox box_of(const SphereSet& s, std::size_t i) const;
  [[nodiscard]] static std::uint64_t key(std::int64_t ix, std::int64_t iy, std::int64_t iz);
  [[nodiscard]] std::size_t bucket(std::uint64_t key) const;

  double cell_ = 1.0;
  double margin_ = 0.0;
  double origin_[3] = {0, 0, 0};
  std::vector<Entry> unsorted_;                // in sphere order
  std::vector<Entry> entries_;                 // grouped by bucket
  std::vector<std::uint32_t> bucket_start_;    // buckets + 1
  std::vector<double> radii_;                  // scratch for the median
  std::vector<std::uint32_t> large_;           // spheres kept out of the grid, ascending
  std::vector<std::uint8_t> is_large_;
  std::size_t bucket_mask_ = 0;
};

}  // namespace haustra::kernels
