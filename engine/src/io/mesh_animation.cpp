// Deformed meshes over frames written as PLY files and one animated glTF.
#include "haustra/mesh_animation.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>

#include "haustra/error.hpp"

namespace haustra {

MeshAnimation::MeshAnimation(std::span<const std::array<std::uint32_t, 3>> triangles) {
  indices_.reserve(3 * triangles.size());
  for (const auto& t : triangles) indices_.insert(indices_.end(), t.begin(), t.end());
}

void MeshAnimation::add_frame(double time, std::span<const float> x, std::span<const float> y,
                              std::span<const float> z) {
  if (!positions_.empty() && x.size() * 3 != positions_.front().size())
    throw Error(ErrorCode::invalid_argument, "MeshAnimation: every frame needs the same vertex count");
  if (!times_.empty() && !(time > times_.back()))
    throw Error(ErrorCode::invalid_argument, "MeshAnimation: frame times must increase");
  std::vector<float> p(3 * x.size());
  for (std::size_t v = 0; v < x.size(); ++v) {
    p[3 * v] = x[v];
    p[3 * v + 1] = y[v];
    p[3 * v + 2] = z[v];
  }
  times_.push_back(static_cast<float>(time));
  positions_.push_back(std::move(p));
}

namespace {

// glTF's min and max of a position accessor (required for POSITION and its morph targets).
nlohmann::json position_bounds(const std::vector<float>& p) {
  std::array<float, 3> lo{}, hi{};
  lo.fill(std::numeric_limits<float>::max());
  hi.fill(std::numeric_limits<float>::lowest());
  for (std::size_t v = 0; v < p.size() / 3; ++v)
    for (std::size_t c = 0; c < 3; ++c) {
      lo[c] = std::min(lo[c], p[3 * v + c]);
      hi[c] = std::max(hi[c], p[3 * v + c]);
    }
  return nlohmann::json{{"min", lo}, {"max", hi}};
}

}  // namespace

void MeshAnimation::write_glb(const std::filesystem::path& file) const {
  using nlohmann::json;
  if (positions_.empty())
    throw Error(ErrorCode::invalid_argument, fmt::format("{}: no frames to write", file.string()));
  const std::size_t vertices = positions_.front().size() / 3;
  const std::size_t frames = positions_.size();
  std::vector<std::uint8_t> bin;
  json views = json::array(), accessors = json::array();
  // Appends a 4-byte aligned buffer view and an accessor over it.
  auto add = [&](const void* data, std::size_t bytes, int component, std::size_t count, const char* type, json extra) {
    const std::size_t offset = bin.size();
    bin.resize(offset + bytes);
    std::memcpy(bin.data() + offset, data, bytes);
    while (bin.size() % 4 != 0) bin.push_back(0);
    views.push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", bytes}});
    json a = {{"bufferView", views.size() - 1}, {"componentType", component}, {"count", count}, {"type", type}};
    a.update(extra);
    accessors.push_back(a);
    return accessors.size() - 1;
  };
  constexpr int kFloat = 5126, kUint = 5125;
  const std::vector<float>& base = positions_.front();
  const std::size_t position =
      add(base.data(), base.size() * sizeof(float), kFloat, vertices, "VEC3", position_bounds(base));
  const std::size_t index =
      add(indices_.data(), indices_.size() * sizeof(std::uint32_t), kUint, indices_.size(), "SCALAR", json::object());
  json targets = json::array();
  std::vector<float> delta(base.size());
  for (const auto& p : positions_) {
    for (std::size_t i = 0; i < p.size(); ++i) delta[i] = p[i] - base[i];
    targets.push_back({{"POSITION", add(delta.data(), delta.size() * sizeof(float), kFloat, vertices, "VEC3",
                                        position_bounds(delta))}});
  }
  std::vector<float> weights(frames * frames, 0.0f);
  for (std::size_t f = 0; f < frames; ++f) weights[f * frames + f] = 1.0f;
  const float t0 = times_.front();
  std::vector<float> times(frames);
  for (std::size_t f = 0; f < frames; ++f) times[f] = times_[f] - t0;
  const std::size_t input = add(times.data(), times.size() * sizeof(float), kFloat, frames, "SCALAR",
                                {{"min", {times.front()}}, {"max", {times.back()}}});
  const std::size_t output =
      add(weights.data(), weights.size() * sizeof(float), kFloat, weights.size(), "SCALAR", json::object());

  json gltf = {{"asset", {{"version", "2.0"}, {"generator", "haustra"}}},
               {"scene", 0},
               {"scenes", {{{"nodes", {0}}}}},
               {"nodes", {{{"mesh", 0}, {"name", "organ"}}}},
               {"meshes",
                {{{"primitives",
                   {{{"attributes", {{"POSITION", position}}}, {"indices", index}, {"mode", 4}, {"targets", targets}}}},
                  {"weights", std::vector<float>(frames, 0.0f)}}}},
               {"animations",
                {{{"name", "run"},
                  {"samplers", {{{"input", input}, {"output", output}, {"interpolation", "STEP"}}}},
                  {"channels", {{{"sampler", 0}, {"target", {{"node", 0}, {"path", "weights"}}}}}}}}},
               {"buffers", {{{"byteLength", bin.size()}}}},
               {"bufferViews", views},
               {"accessors", accessors}};
  std::string text = gltf.dump();
  while (text.size() % 4 != 0) text.push_back(' ');
  std::ofstream out(file, std::ios::binary);
  if (!out) throw Error(ErrorCode::io, fmt::format("{}: cannot write", file.string()));
  auto u32 = [&](std::uint32_t v) { out.write(reinterpret_cast<const char*>(&v), 4); };
  u32(0x46546C67U);  // "glTF"
  u32(2);
  u32(static_cast<std::uint32_t>(12 + 8 + text.size() + 8 + bin.size()));
  u32(static_cast<std::uint32_t>(text.size()));
  u32(0x4E4F534AU);  // "JSON"
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  u32(static_cast<std::uint32_t>(bin.size()));
  u32(0x004E4942U);  // "BIN\\0"
  out.write(reinterpret_cast<const char*>(bin.data()), static_cast<std::streamsize>(bin.size()));
  if (!out) throw Error(ErrorCode::io, fmt::format("{}: cannot write", file.string()));
}

}  // namespace haustra
