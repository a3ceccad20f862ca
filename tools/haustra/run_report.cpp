// What `haustra run` reports: the stage table, summary.json and the CSV files.
#include "run_report.hpp"

#include "haustra/error.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

namespace haustra::cli {
namespace {

double quantile(std::vector<float> v, double q) {
  if (v.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5);
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

const char* solver_name(SolverMode m) { return solver_mode_name(m); }

// Each segment's counts, stiffnesses, rest-shape fit and final node positions.
nlohmann::json segments_json(const World& world) {
  using nlohmann::json;
  json segments = json::array();
  const auto pos = world.node_positions();
  for (std::size_t s = 0; s < world.segment_count(); ++s) {
    const SegmentInfo& info = world.segment(s);
    json nodes = json::array();
    for (std::size_t k = info.nodes.offset; k < info.nodes.offset + info.nodes.count; ++k)
      nodes.push_back({pos.x[k], pos.y[k], pos.z[k]});
    segments.push_back({{"name", info.name},
                        {"nodes", info.nodes.count},
                        {"rest_length_m", info.length},
                        {"bending_stiffness_Nm2", info.bending_stiffness},
                        {"torsion_stiffness_Nm2", info.torsion_stiffness},
                        {"axial_stiffness_N", info.axial_stiffness},
                        {"linear_density_kg_per_m", info.linear_density},
                        {"rest_node_deviation_m", info.rest_node_deviation},
                        {"rest_polyline_deviation_m", info.rest_polyline_deviation},
                        {"final_node_positions_m", nodes}});
  }
  return segments;
}

// The deepest penetrations over the run and, per frame, at each frame's final positions.
nlohmann::json contacts_json(const std::vector<ContactReport>& contacts, std::size_t beads) {
  using nlohmann::json;
  json env = json::array(), env_ratio = json::array(), bead = json::array(), bead_ratio = json::array(),
       touching = json::array();
  double worst_env = 0.0, worst_bead = 0.0, worst_env_ratio = 0.0, worst_bead_ratio = 0.0;
  for (const ContactReport& c : contacts) {
    env.push_back(c.max_environment_depth);
    env_ratio.push_back(c.max_environment_depth_ratio);
    bead.push_back(c.max_bead_overlap);
    bead_ratio.push_back(c.max_bead_overlap_ratio);
    touching.push_back(c.touching);
    worst_env = std::max(worst_env, c.max_environment_depth);
    worst_bead = std::max(worst_bead, c.max_bead_overlap);
    worst_env_ratio = std::max(worst_env_ratio, c.max_environment_depth_ratio);
    worst_bead_ratio = std::max(worst_bead_ratio, c.max_bead_overlap_ratio);
  }
  return {{"beads", beads},
          {"max_environment_depth_m", worst_env},
          {"max_environment_depth_over_radius", worst_env_ratio},
          {"max_bead_overlap_m", worst_bead},
          {"max_bead_overlap_over_radius", worst_bead_ratio},
          {"per_frame",
           {{"max_environment_depth_m", env},
            {"max_environment_depth_over_radius", env_ratio},
            {"max_bead_overlap_m", bead},
            {"max_bead_overlap_over_radius", bead_ratio},
            {"touching", touching}}}};
}

// Each instrument's force, filtered force, torque and grasp, per frame.
nlohmann::json instruments_json(const std::vector<std::vector<InstrumentReading>>& readings, std::size_t count) {
  using nlohmann::json;
  json instruments = json::array();
  for (std::size_t i = 0; i < count; ++i) {
    json force = json::array(), filtered = json::array(), torque = json::array(), grasping = json::array();
    for (const auto& frame : readings) {
      const InstrumentReading& r = frame[i];
      force.push_back({r.force.x(), r.force.y(), r.force.z()});
      filtered.push_back({r.filtered_force.x(), r.filtered_force.y(), r.filtered_force.z()});
      torque.push_back({r.torque.x(), r.torque.y(), r.torque.z()});
      grasping.push_back(r.grasping);
    }
    instruments.push_back({{"index", i},
                           {"force_N_per_frame", force},
                           {"filtered_force_N_per_frame", filtered},
                           {"torque_Nm_per_frame", torque},
                           {"grasping_per_frame", grasping}});
  }
  return instruments;
}

nlohmann::json events_json(const World& world) {
  using nlohmann::json;
  json events = json::array();
  for (const Event& e : world.events())
    events.push_back({{"kind", std::string(event_kind_name(e.kind))},
                      {"frame", e.frame},
                      {"segment", e.segment},
                      {"node", e.node},
                      {"stage", stage_name(e.stage)},
                      {"substeps", e.substeps},
                      {"message", std::string(e.message())}});
  return events;
}

}  // namespace

void RunRecord::add(const FrameProfile& p, const World& world) {
  has_beads_ = world.bead_count() > 0;
  contacts_.push_back(world.contacts());
  energy_.push_back(world.energy());
  std::vector<InstrumentReading> readings;
  for (std::size_t i = 0; i < world.instrument_count(); ++i) readings.push_back(world.instrument(i));
  instruments_.push_back(std::move(readings));
  for (std::size_t s = 0; s < kStageCount; ++s) {
    stage_seconds_[s].push_back(static_cast<float>(p.seconds[s]));
    stage_calls_[s] += p.calls[s];
  }
  frame_seconds_.push_back(static_cast<float>(p.frame_seconds));
  substeps_.push_back(p.substeps);
  retries_.push_back(p.retries);
  newton_.push_back(p.newton ? 1 : 0);
  std::size_t c = 0;
#define HAUSTRA_ADD_FIELD(type, name, initial, meaning) \
  counter_total_[c] += p.name;                          \
  counter_max_[c] = std::max(counter_max_[c], p.name);  \
  ++c;
  HAUSTRA_PROFILE_COUNTERS(HAUSTRA_ADD_FIELD)
#undef HAUSTRA_ADD_FIELD
}

void RunRecord::print_contacts(std::FILE* out, const World& world) const {
  if (has_beads_ && !contacts_.empty()) {
    std::size_t env_frame = 0, bead_frame = 0;
    for (std::size_t f = 0; f < contacts_.size(); ++f) {
      if (contacts_[f].max_environment_depth_ratio > contacts_[env_frame].max_environment_depth_ratio) env_frame = f;
      if (contacts_[f].max_bead_overlap_ratio > contacts_[bead_frame].max_bead_overlap_ratio) bead_frame = f;
    }
    const ContactReport& last = contacts_.back();
    fmt::print(out,
               "\ncontacts ({} beads): deepest into the environment {:.3g} mm ({:.1f} % of r) at frame {}, "
               "between beads {:.3g} mm ({:.1f} %) at frame {}; last frame {:.1f} % and {:.1f} %, {} touching\n",
               world.bead_count(), 1e3 * contacts_[env_frame].max_environment_depth,
               100.0 * contacts_[env_frame].max_environment_depth_ratio, env_frame + 1,
               1e3 * contacts_[bead_frame].max_bead_overlap, 100.0 * contacts_[bead_frame].max_bead_overlap_ratio,
               bead_frame + 1, 100.0 * last.max_environment_depth_ratio, 100.0 * last.max_bead_overlap_ratio,
               last.touching);
  }
  if (!instruments_.empty())
    for (std::size_t i = 0; i < instruments_.back().size(); ++i) {
      const InstrumentReading& r = instruments_.back()[i];
      fmt::print(out, "instrument {}: {}force on it [{:.3f}, {:.3f}, {:.3f}] N, filtered [{:.3f}, {:.3f}, {:.3f}] N\n",
                 i, r.grasping ? fmt::format("grasping segment {} node {}; ", r.grasped_segment, r.grasped_node) : "",
                 r.force.x(), r.force.y(), r.force.z(), r.filtered_force.x(), r.filtered_force.y(),
                 r.filtered_force.z());
    }
}

void RunRecord::watch_skin(const World& world) {
  bool any_mesh = false;
  for (std::size_t s = 0; s < world.segment_count(); ++s) any_mesh = any_mesh || world.mesh(s).enabled;
  if (any_mesh) skin_.emplace(world);
}

void RunRecord::measure_skin(const World& world, int frame, bool last) {
  if (!skin_ || (frame % kSkinEvery != 0 && !last)) return;
  skin_->measure(world, false);
  ++skin_measures_;
}

void RunRecord::print_skin(std::FILE* out) const {
  if (!skin_ || skin_measures_ == 0) return;
  fmt::print(out,
             "skin: worst edge {:.2f}x its rest length over the rod's own stretch at its place, {} edges past 2x "
             "(the skin tearing; {:.2f}x not divided by the rod's; {} measures, every {} frames and the last)\n",
             skin_->worst, skin_->edges_past, skin_->worst_raw, skin_measures_, kSkinEvery);
}

RunRecord::StageStats RunRecord::stats(std::size_t s) const {
  StageStats st;
  const auto& v = stage_seconds_[s];
  if (v.empty() || stage_calls_[s] == 0) return st;
  st.ran = true;
  double total = 0;
  for (float x : v) total += x;
  st.total_ms = total * 1e3;
  st.mean_us = total / static_cast<double>(v.size()) * 1e6;
  st.median_us = quantile(v, 0.5) * 1e6;
  st.p99_us = quantile(v, 0.99) * 1e6;
  st.calls_per_frame = static_cast<double>(stage_calls_[s]) / static_cast<double>(v.size());
  return st;
}

void RunRecord::print_stage_table(std::FILE* out) const {
  double frame_total = 0;
  for (float x : frame_seconds_) frame_total += x;
  fmt::print(out, "\n{:<16} {:>10} {:>12} {:>12} {:>12} {:>7}\n", "stage", "calls/fr", "median µs", "mean µs", "p99 µs",
             "share");
  for (std::size_t s = 0; s < kStageCount; ++s) {
    const StageStats st = stats(s);
    const auto name = stage_name(static_cast<Stage>(s));
    if (!st.ran) {
      fmt::print(out, "{:<16} {:>10}\n", name, "not run");
      continue;
    }
    fmt::print(out, "{:<16} {:>10.2f} {:>12.2f} {:>12.2f} {:>12.2f} {:>6.1f}%\n", name, st.calls_per_frame,
               st.median_us, st.mean_us, st.p99_us, frame_total > 0 ? 100.0 * st.total_ms * 1e-3 / frame_total : 0.0);
  }
  fmt::print(out, "{:<16} {:>10} {:>12.2f} {:>12.2f} {:>12.2f}\n", "frame", "", quantile(frame_seconds_, 0.5) * 1e6,
             frames() ? frame_total / static_cast<double>(frames()) * 1e6 : 0.0, quantile(frame_seconds_, 0.99) * 1e6);
}

void RunRecord::write_summary(const std::filesystem::path& file, const SceneDesc& scene, const World& world,
                              int requested_frames, const std::string& status, const std::string& error) const {
  using nlohmann::json;
  json j;
  j["scene"] = scene.name;
  j["scene_file"] = scene.file.string();
  j["status"] = status;
  if (!error.empty()) j["error"] = error;
  std::size_t sections = 0;
  for (std::size_t s = 0; s < world.segment_count(); ++s) sections += world.segment(s).nodes.count - 1;
  j["counts"] = {{"segments", world.segment_count()}, {"nodes", world.node_count()}, {"sections", sections}};
  j["frames"] = frames();
  j["requested_frames"] = requested_frames;
  j["dt"] = world.dt();
  j["simulated_time"] = world.time();
  j["threads"] = world.threads();
  j["solver"] = {
      {"mode", solver_name(scene.world.solver.mode)},
      {"iterations", scene.world.solver.iterations},
      {"substeps", scene.world.solver.substeps},
      {"on_instability", scene.world.solver.on_instability == InstabilityPolicy::recover ? "recover" : "stop"}};
  json stages = json::object();
  for (std::size_t s = 0; s < kStageCount; ++s) {
    const StageStats st = stats(s);
    stages[std::string(stage_name(static_cast<Stage>(s)))] =
        st.ran ? json{{"ran", true},         {"median_us", st.median_us}, {"mean_us", st.mean_us},
                      {"p99_us", st.p99_us}, {"total_ms", st.total_ms},   {"calls_per_frame", st.calls_per_frame}}
               : json{{"ran", false}};
  }
  j["stages"] = stages;
  j["frame_time_us"] = {
      {"median", quantile(frame_seconds_, 0.5) * 1e6},
      {"p99", quantile(frame_seconds_, 0.99) * 1e6},
      {"max", frame_seconds_.empty() ? 0.0 : *std::max_element(frame_seconds_.begin(), frame_seconds_.end()) * 1e6}};
  int retried = 0;
  for (int r : retries_) retried += r > 0 ? 1 : 0;
  json counters = json::object();
  std::size_t counter = 0;
#define HAUSTRA_PUT_FIELD(type, name, initial, meaning)                                                    \
  counters[#name] = {                                                                                      \
      {"total", counter_total_[counter]}, {"max_per_frame", counter_max_[counter]}, {"meaning", meaning}}; \
  ++counter;
  HAUSTRA_PROFILE_COUNTERS(HAUSTRA_PUT_FIELD)
#undef HAUSTRA_PUT_FIELD
  j["counters"] = counters;
  j["robust_mode"] = {{"frames_redone", retried},
                      {"frames_with_newton", std::count(newton_.begin(), newton_.end(), 1)},
                      {"max_substeps", substeps_.empty() ? 0 : *std::max_element(substeps_.begin(), substeps_.end())}};
  j["segments"] = segments_json(world);
  if (has_beads_) j["contacts"] = contacts_json(contacts_, world.bead_count());
  if (world.instrument_count() > 0) j["instruments"] = instruments_json(instruments_, world.instrument_count());
  if (skin_ && skin_measures_ > 0)
    j["skin"] = {{"worst_edge_stretch", skin_->worst},
                 {"worst_edge_stretch_own", skin_->worst_raw},
                 {"edges_past_2x", skin_->edges_past},
                 {"measures", skin_measures_},
                 {"meaning",
                  "each mesh edge's length over its rest length, over the rod's axial stretch at its "
                  "vertices' places along the rod; past 2x is the skin tearing (decision 0121)"}};
  j["events"] = events_json(world);
  std::ofstream out(file);
  if (!out) throw Error(ErrorCode::io, fmt::format("{}: cannot write", file.string()));
  out << j.dump(2) << '\n';
}

void RunRecord::write_frames_csv(const std::filesystem::path& file) const {
  std::ofstream out(file);
  if (!out) throw Error(ErrorCode::io, fmt::format("{}: cannot write", file.string()));
  out << "frame,wall_us,substeps,newton,retries";
  for (std::size_t s = 0; s < kStageCount; ++s) out << ',' << stage_name(static_cast<Stage>(s)) << "_us";
  out << ",elastic_energy_J,gravity_energy_J";
  if (has_beads_) out << ",touching,max_environment_depth_m,max_bead_overlap_m";
  const std::size_t instruments = instruments_.empty() ? 0 : instruments_.front().size();
  for (std::size_t i = 0; i < instruments; ++i)
    out << fmt::format(",instrument{0}_fx,instrument{0}_fy,instrument{0}_fz", i);
  out << '\n';
  for (std::size_t f = 0; f < frames(); ++f) {
    out << f << ',' << frame_seconds_[f] * 1e6 << ',' << substeps_[f] << ',' << int{newton_[f]} << ',' << retries_[f];
    for (std::size_t s = 0; s < kStageCount; ++s) out << ',' << stage_seconds_[s][f] * 1e6;
    out << ',' << energy_[f].elastic << ',' << energy_[f].gravity;
    if (has_beads_)
      out << ',' << contacts_[f].touching << ',' << contacts_[f].max_environment_depth << ','
          << contacts_[f].max_bead_overlap;
    for (std::size_t i = 0; i < instruments; ++i)
      out << ',' << instruments_[f][i].force.x() << ',' << instruments_[f][i].force.y() << ','
          << instruments_[f][i].force.z();
    out << '\n';
  }
}

void write_nodes_csv(const std::filesystem::path& file, const World& world) {
  std::ofstream out(file);
  if (!out) throw Error(ErrorCode::io, fmt::format("{}: cannot write", file.string()));
  out << "segment,node,x_m,y_m,z_m,kappa1,kappa2,tau,eps\n";
  const auto pos = world.node_positions();
  const auto q = world.strains();
  for (std::size_t s = 0; s < world.segment_count(); ++s) {
    const SegmentInfo& info = world.segment(s);
    for (std::size_t k = 0; k < info.nodes.count; ++k) {
      const std::size_t i = info.nodes.offset + k;
      out << fmt::format("{},{},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}\n", info.name, k, pos.x[i], pos.y[i],
                         pos.z[i], q.at(i, 0), q.at(i, 1), q.at(i, 2), q.at(i, 3));
    }
  }
}

void print_mesh_info(std::FILE* out, const World& world, std::size_t segment) {
  const MeshInfo& m = world.mesh(segment);
  if (!m.enabled) return;
  const CageReport& c = m.cage;
  const SkinReport& k = m.skin;
  fmt::print(out, "  segment '{}': mesh {} ({} vertices, {} triangles)\n", world.segment(segment).name,
             std::filesystem::path(m.source).filename().string(), m.vertices.count, m.triangles.count);
  fmt::print(
      out,
      "    cage: {} rings ({} bead, {} middle, {} past an end, {} taken out) x {} vertices = {} vertices, {} "
      "triangles; "
      "clearance {:.2f} mm; rings grown {:+.1f} to {:+.1f} mm beyond the beads (mean {:+.1f}); {} passes, {:.2f} s; "
      "binding {}\n",
      c.rings, c.bead_rings, c.middle_rings, c.end_rings, c.dropped_rings, c.ring_vertices, c.vertices, c.triangles,
      1e3 * c.clearance, 1e3 * c.inflation_min, 1e3 * c.inflation_max, 1e3 * c.inflation_mean, c.iterations, c.seconds,
      c.binding == "harmonic"
          ? fmt::format(
                "from a harmonic function on the mesh ({} piece{}{}{})", c.binding_pieces,
                c.binding_pieces == 1 ? "" : "s",
                c.binding_closest_pieces > 0 ? fmt::format(", {} by closest points", c.binding_closest_pieces) : "",
                c.binding_followed > 0 ? fmt::format(", {} vertices placed from their neighbours", c.binding_followed)
                                       : "")
          : "by closest points on the rod");
  fmt::print(out,
             "    embedding (Embree, binding pose): {} mesh vertices outside, {} mesh edges crossing, {} cage "
             "self-intersections; at the curved rest pose {} outside; tightest bend {}\n",
             c.mesh_vertices_outside, c.crossing_edges, c.self_intersections, c.rest_pose_outside,
             std::isfinite(c.tightest_bend) && c.tightest_bend < 1e3 ? fmt::format("{:.1f} mm", 1e3 * c.tightest_bend)
                                                                     : "none (straight)");
  if (k.method == SkinningMethod::cage || k.method == SkinningMethod::cage_full)
    fmt::print(
        out,
        "    mean value coordinates ({}): {:.2f} rings per vertex (up to {}), {:.2f} slots per vertex; min weight "
        "{:.3g}; negative mass max {:.3g}, mean {:.3g} ({} vertices); weight left out max {:.3g}, mean {:.3g}; rest "
        "correction max {:.2f} mm; rest error {:.2g} m; {:.2f} s\n",
        k.method == SkinningMethod::cage ? "cage" : "cage-full, every ring", k.mean_rings_per_vertex,
        k.rings_per_vertex, k.slots_per_vertex, k.min_weight, k.max_negative_mass, k.mean_negative_mass,
        k.negative_vertices, k.max_dropped_mass, k.mean_dropped_mass, 1e3 * k.max_rest_correction, k.rest_error,
        k.seconds);
  else if (k.method == SkinningMethod::along_rod)
    fmt::print(out,
               "    along the rod: each vertex on the rod's frames either side of its own place ({} a vertex, decision "
               "0117), {:.2f} slots per vertex; rest error {:.2g} m\n",
               k.rings_per_vertex, k.slots_per_vertex, k.rest_error);
  else
    fmt::print(out, "    linear-blend skinning on the bead frames (2 per vertex); rest error {:.2g} m\n", k.rest_error);
}

namespace {
TriangleMesh compact_triangles(const World& world, std::vector<std::uint32_t>& used) {
  std::vector<std::int64_t> index(world.mesh_buffer_size(), -1);
  for (std::size_t s = 0; s < world.segment_count(); ++s) {
    const MeshInfo& m = world.mesh(s);
    for (std::size_t v = m.vertices.offset; v < m.vertices.offset + m.vertices.count; ++v) {
      index[v] = static_cast<std::int64_t>(used.size());
      used.push_back(static_cast<std::uint32_t>(v));
    }
  }
  TriangleMesh mesh;
  for (const auto& t : world.mesh_triangles())
    mesh.triangles.push_back({static_cast<std::uint32_t>(index[t[0]]), static_cast<std::uint32_t>(index[t[1]]),
                              static_cast<std::uint32_t>(index[t[2]])});
  mesh.vertices.resize(used.size());
  return mesh;
}
}  // namespace

MeshRecorder::MeshRecorder(const World& world, std::filesystem::path dir, std::string format)
    : dir_(std::move(dir)),
      format_(std::move(format)),
      mesh_(compact_triangles(world, used_)),
      animation_(mesh_.triangles) {
  std::filesystem::create_directories(dir_);
}

void MeshRecorder::record(const World& world) {
  const auto p = world.mesh_positions();
  const auto n = world.mesh_normals();
  std::vector<Eigen::Vector3d> normals(used_.size());
  std::vector<float> x(used_.size()), y(used_.size()), z(used_.size());
  for (std::size_t i = 0; i < used_.size(); ++i) {
    const std::uint32_t v = used_[i];
    mesh_.vertices[i] = Eigen::Vector3d(p.x[v], p.y[v], p.z[v]);
    normals[i] = Eigen::Vector3d(n.x[v], n.y[v], n.z[v]);
    x[i] = p.x[v];
    y[i] = p.y[v];
    z[i] = p.z[v];
  }
  save_mesh(dir_ / fmt::format("frame_{:05d}.{}", world.frame(), format_), mesh_, normals);
  animation_.add_frame(world.time(), x, y, z);
}

TrackRecorder::TrackRecorder(const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  centreline_.open(dir / "centreline.csv");
  beads_.open(dir / "beads.csv");
  if (!centreline_ || !beads_)
    throw Error(ErrorCode::io, fmt::format("{}: cannot write centreline.csv and beads.csv", dir.string()));
  centreline_ << "frame,time_s,segment,node,x_m,y_m,z_m\n";
  beads_ << "frame,time_s,bead,segment,node,x_m,y_m,z_m,radius_m\n";
}

void TrackRecorder::record(const World& world) {
  const auto p = world.node_positions();
  for (std::size_t s = 0; s < world.segment_count(); ++s) {
    const Range r = world.segment(s).nodes;
    for (std::size_t k = 0; k < r.count; ++k) {
      const Eigen::Vector3d x = p.get(r.offset + k);
      centreline_ << fmt::format("{},{:.6f},{},{},{:.9g},{:.9g},{:.9g}\n", world.frame(), world.time(),
                                 world.segment(s).name, k, x.x(), x.y(), x.z());
    }
  }
  for (std::size_t b = 0; b < world.bead_count(); ++b) {
    const std::uint32_t node = world.bead_nodes()[b];
    std::size_t s = 0;
    while (s + 1 < world.segment_count() && node >= world.segment(s).nodes.offset + world.segment(s).nodes.count) ++s;
    const Eigen::Vector3d x = p.get(node);
    beads_ << fmt::format("{},{:.6f},{},{},{},{:.9g},{:.9g},{:.9g},{:.9g}\n", world.frame(), world.time(), b,
                          world.segment(s).name, node - world.segment(s).nodes.offset, x.x(), x.y(), x.z(),
                          world.bead_radii()[b]);
  }
}

void MeshRecorder::finish(const std::filesystem::path& glb) { animation_.write_glb(glb); }

}  // namespace haustra::cli
