#pragma once
// Broad phase over spheres (beads): every pair whose spheres, grown by a margin, overlap:
//   |c_a − c_b| ≤ r_a + r_b + margin,  a < b,
// reported in ascending (a, b) order so that results do not depend on how the work was split.
// Two methods that must agree exactly: brute force (the reference, best for tiny sets) and a
// uniform grid (cost per sphere flat in the count). The grid is
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

// Both methods write at most out.size() pairs and return how many there are; when the
// return exceeds out.size(), the caller grows `out` and calls again.
std::size_t broad_phase_brute(const SphereSet& s, double margin, std::span<SpherePair> out);

// Uniform grid. Each sphere is entered in the cell of its centre; cells are as wide as the widest
// reach (2r + margin) among the spheres, so a sphere meets only spheres centred in its own cell
// and the 26 around it. The cells' lists are bucketed by a stable counting sort (O(n),
// deterministic): by the cell's index in a dense array when that array is small next to the
// sphere count, which keeps neighbouring cells together in memory, else by a hash of the cell
// (spheres scattered over a large, mostly empty space). Spheres reaching more than 8 times the
// median's stay out of the grid and are tested against every sphere directly, so that an outlier
// does not coarsen the cells for all. Buffers are kept between builds: no allocation once warm.
class SphereGrid {
 public:
  // cell: edge length; 0 chooses the widest reach short of the outliers. Spheres reaching further
  // than the cell are tested against all others.
  void build(const SphereSet& s, double margin, double cell = 0.0);
  // Pairs (a, b) with first ≤ a < last, in ascending order. Pure: callable concurrently.
  std::size_t query(const SphereSet& s, std::size_t first, std::size_t last, std::span<SpherePair> out) const;
  [[nodiscard]] double cell_size() const { return cell_; }
  [[nodiscard]] bool dense() const { return dense_; }

 private:
  struct Entry {
    double x, y, z, radius;    // a copy of the sphere, read where the cell is
    std::uint32_t ix, iy, iz;  // the cell of the sphere's centre
    std::uint32_t sphere;
    std::uint32_t bucket;
  };
  [[nodiscard]] std::int64_t cell_of(double coordinate, int axis) const;
  [[nodiscard]] static std::uint64_t key(std::int64_t ix, std::int64_t iy, std::int64_t iz);
  [[nodiscard]] std::size_t bucket(std::int64_t ix, std::int64_t iy, std::int64_t iz) const;

  double cell_ = 1.0;
  double inverse_cell_ = 1.0;
  double margin_ = 0.0;
  double origin_[3] = {0, 0, 0};
  std::vector<Entry> unsorted_;              // in sphere order
  std::vector<Entry> entries_;               // grouped by bucket
  std::vector<std::uint32_t> bucket_start_;  // buckets + 1
  std::vector<double> radii_;                // scratch for the median
  std::vector<std::uint32_t> large_;         // spheres kept out of the grid, ascending
  std::vector<std::uint8_t> is_large_;
  std::size_t bucket_mask_ = 0;
  bool dense_ = false;                 // buckets are cells, indexed directly
  std::uint64_t dims_[3] = {1, 1, 1};  // cells per axis in dense mode
};

}  // namespace haustra::kernels
