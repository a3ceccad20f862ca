// The World's checkpoint calls: the state and run-time parameters to bytes or a file and back
// (io/checkpoint.cpp writes and reads the bytes; here, what a restore does to the world).
#include <fmt/format.h>

#include <filesystem>
#include <fstream>

#include "haustra/error.hpp"
#include "io/bounded_input.hpp"
#include "io/checkpoint.hpp"
#include "model/world_desc_checks.hpp"
#include "step/world_impl.hpp"

namespace haustra {

std::vector<std::byte> World::save_checkpoint() const {
  const Use use(*this);
  return detail::save_checkpoint(impl_->model, impl_->state, detail::parameters_of(impl_->desc));
}

// The checkpoint's run-time parameters are put back (decision 0099): checked as the setters check
// them; a material other than the world's rebuilds the rods as set_material does, into a world not
// yet in place, so that a checkpoint refused after it leaves the world as it was.
void World::restore_checkpoint(std::span<const std::byte> bytes, const std::string& source) {
  const Use use(*this);
  const detail::OpenedCheckpoint opened = detail::open_checkpoint(impl_->model, impl_->desc, bytes, source);
  WorldDesc next = impl_->desc;
  detail::apply_parameters(opened.parameters, next);
  try {
    detail::check_world_desc(next);
    for (std::size_t i = 0; i < next.instruments.size(); ++i)
      if ((next.instruments[i].coupling_stiffness == 0.0) != (impl_->desc.instruments[i].coupling_stiffness == 0.0))
        throw FieldError(ErrorCode::invalid_argument, fmt::format("instrument[{}].coupling_stiffness", i),
                         "a rigid grasp (0) and a coupled one differ in their constraints: only a rebuild switches");
  } catch (const Error& e) {
    throw Error(ErrorCode::parse, fmt::format("checkpoint '{}': its run-time parameters do not suit this world: {}; "
                                              "the world was left as it was",
                                              source, e.what()));
  }
  std::unique_ptr<Impl> fresh;
  if (!detail::same_materials(opened.parameters, impl_->desc)) {
    std::vector<std::size_t> rod_map(impl_->model.segments.size());
    for (std::size_t r = 0; r < rod_map.size(); ++r) rod_map[r] = r;
    fresh = rebuilt(next, rod_map, false, true);
  }
  Impl& target = fresh ? *fresh : *impl_;
  detail::restore_state(target.model, target.state, opened, source);
  detail::apply_parameters(opened.parameters, target.desc);
  detail::apply_parameters(opened.parameters, target.model);
  if (fresh) impl_ = std::move(fresh);
  impl_->state.frame_start.copy_from(impl_->state.now);
  impl_->profile = FrameProfile{};
  impl_->motion_dt = 0.0;
  impl_->follow_rod();
}

void World::save_checkpoint_file(const std::string& path) const {
  const Use use(*this);
  const std::vector<std::byte> bytes = save_checkpoint();
  const std::filesystem::path target(path);
  std::filesystem::path temp = target;
  temp += ".partial";
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    if (!out)
      throw Error(ErrorCode::io, fmt::format("checkpoint '{}': cannot open '{}' for writing", path, temp.string()));
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out) {
      std::error_code ignored;
      std::filesystem::remove(temp, ignored);
      throw Error(ErrorCode::io,
                  fmt::format("checkpoint '{}': writing {} bytes failed (disk full?)", path, bytes.size()));
    }
  }
  std::error_code ec;
  std::filesystem::rename(temp, target, ec);
  if (ec)
    throw Error(ErrorCode::io,
                fmt::format("checkpoint '{}': cannot rename '{}' over it: {}", path, temp.string(), ec.message()));
}

bool World::checkpoint_rebuilds(const std::string& path) const {
  const Use use(*this);
  const std::string text = io::read_bounded_file(path, "checkpoint", io::kMaxCheckpointBytes);
  const detail::OpenedCheckpoint opened =
      detail::open_checkpoint(impl_->model, impl_->desc, std::as_bytes(std::span(text)), path);
  return !detail::same_materials(opened.parameters, impl_->desc);
}

void World::restore_checkpoint_file(const std::string& path) {
  const Use use(*this);
  // A checkpoint holds a few hundred bytes per node and bead: 1 GiB is far beyond any world. A
  // regular file only (a FIFO would block, a device never end).
  const std::string text = io::read_bounded_file(path, "checkpoint", io::kMaxCheckpointBytes);
  restore_checkpoint(std::as_bytes(std::span(text)), path);
}

}  // namespace haustra
