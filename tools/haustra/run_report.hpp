#pragma once
// What `haustra run` measures while it steps a world, and how it reports it: the per-stage timing
// table on the terminal, summary.json and the CSV files in --out.
#include <array>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "haustra/mesh_animation.hpp"
#include "haustra/mesh_io.hpp"
#include "haustra/profile.hpp"
#include "haustra/scene.hpp"
#include "haustra/studies/skin_stretch.hpp"
#include "haustra/world.hpp"

namespace haustra::cli {

class RunRecord {
 public:
  void add(const FrameProfile& p, const World& world);
  [[nodiscard]] std::size_t frames() const { return frame_seconds_.size(); }
  void print_stage_table(std::FILE* out) const;
  // The deepest penetrations and where they happened; each instrument's last force.
  void print_contacts(std::FILE* out, const World& world) const;
  // The organ meshes' skin stretch over the rod's own (decision 0121): watch_skin before the first
  // step, measure_skin after each (it reads the mesh every kSkinEvery frames and at the last).
  static constexpr int kSkinEvery = 15;
  void watch_skin(const World& world);
  void measure_skin(const World& world, int frame, bool last);
  void print_skin(std::FILE* out) const;
  void write_summary(const std::filesystem::path& file, const SceneDesc& scene, const World& world,
                     int requested_frames, const std::string& status, const std::string& error) const;
  void write_frames_csv(const std::filesystem::path& file) const;

 private:
  struct StageStats {
    double median_us = 0, mean_us = 0, p99_us = 0, total_ms = 0, calls_per_frame = 0;
    bool ran = false;
  };
  [[nodiscard]] StageStats stats(std::size_t stage) const;

  std::vector<std::vector<float>> stage_seconds_{kStageCount};
  std::vector<std::uint32_t> stage_calls_ = std::vector<std::uint32_t>(kStageCount, 0);
  std::vector<float> frame_seconds_;
  std::vector<int> substeps_, retries_;
  std::vector<char> newton_;
  // Each profile counter (report_fields.h) summed and at its largest over the frames.
#define HAUSTRA_COUNT_FIELD(type, name, initial, meaning) +1
  static constexpr std::size_t kCounters = 0 HAUSTRA_PROFILE_COUNTERS(HAUSTRA_COUNT_FIELD);
#undef HAUSTRA_COUNT_FIELD
  std::array<long long, kCounters> counter_total_{};
  std::array<int, kCounters> counter_max_{};
  std::vector<ContactReport> contacts_;
  std::vector<Energy> energy_;
  std::vector<std::vector<InstrumentReading>> instruments_;
  bool has_beads_ = false;
  std::optional<studies::SkinStretch> skin_;
  int skin_measures_ = 0;
};

void write_nodes_csv(const std::filesystem::path& file, const World& world);

// Writes the world's organ meshes (all segments in one file) as a numbered sequence of files and
// collects them into one animated glTF.
class MeshRecorder {
 public:
  MeshRecorder(const World& world, std::filesystem::path dir, std::string format);
  void record(const World& world);
  void finish(const std::filesystem::path& glb);
  [[nodiscard]] std::size_t frames() const { return animation_.frames(); }

 private:
  std::filesystem::path dir_;
  std::string format_;
  std::vector<std::uint32_t> used_;  // world vertex index of each written vertex
  TriangleMesh mesh_;                // triangles over the written vertices
  MeshAnimation animation_;
};

// The centreline (every node) and the beads of chosen frames, as two CSV files in a directory.
class TrackRecorder {
 public:
  explicit TrackRecorder(const std::filesystem::path& dir);
  void record(const World& world);

 private:
  std::ofstream centreline_, beads_;
};

// The organ mesh of a segment: the cage the builder made and how the mesh was bound to it.
void print_mesh_info(std::FILE* out, const World& world, std::size_t segment);

}  // namespace haustra::cli
