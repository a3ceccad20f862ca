// Triple-buffered frames for a reader on another thread: only index swaps happen under the lock,
// so neither side waits on the other's copying, and the slot a reader holds is never written.
#include "haustra/frame_publisher.hpp"

#include <algorithm>

#include "haustra/error.hpp"

namespace haustra {

FramePublisher::FramePublisher(const World& world, bool details, bool cages)
    : world_(&world), details_(details), cages_(cages) {
  for (Slot& s : slots_) size_slot(s, world);
  publish(world);
}

void FramePublisher::size_slot(Slot& s, const World& w) const {
  for (auto* v : {&s.x, &s.y, &s.z}) v->resize(w.node_count());
  for (auto* v : {&s.px, &s.py, &s.pz, &s.nx, &s.ny, &s.nz}) v->resize(w.mesh_buffer_size());
  s.rings.resize(w.ring_count());
  s.ring_delta.resize(kernels::kRingScratchFloats * w.ring_count());
  s.gpu_rings.resize(kGpuRingDataFloats * w.ring_count());
  s.mesh_pending = s.gpu_pending = s.mesh_made = false;
  if (!details_) return;
  s.details.strain.resize(4 * w.node_count());
  s.details.rest_strain.resize(4 * w.node_count());
  s.details.instruments.resize(w.instrument_count());
  s.details.cages.resize(w.segment_count());
  s.details.anchors_intact.resize(w.anchor_count());
}

void FramePublisher::publish(const World& world) {
  fill(slots_[back_], world);
  std::lock_guard lock(mutex_);
  std::swap(back_, ready_);
  fresh_ = true;
}

void FramePublisher::want_cages(bool on) { cages_ = on; }
void FramePublisher::skin_on_gpu(bool on) { gpu_ = on; }

const FramePublisher::Slot& FramePublisher::acquire() {
  std::unique_lock lock(mutex_);
  if (held_)
    throw Error(ErrorCode::invalid_argument,
                "a frame is already acquired: call haustra_world_release_frame before acquiring the next");
  if (fresh_) {
    std::swap(ready_, reading_);
    fresh_ = false;
  }
  held_ = true;
  Slot& s = slots_[reading_];
  // Outside the lock: the stepping thread publishes meanwhile; the held slot is never written
  // and the world's model is not changed while a slot is held (resize).
  lock.unlock();
  if (gpu_) {
    if (s.gpu_pending) world_->gpu_ring_frame_from(s.rings, s.gpu_rings);
    s.gpu_pending = false;
  } else if (s.mesh_pending) {
    world_->mesh_from_rings(s.rings, s.ring_delta, {s.px, s.py, s.pz}, {s.nx, s.ny, s.nz});
    s.mesh_pending = false;
    s.mesh_made = true;
  }
  return s;
}

void FramePublisher::release() {
  {
    std::lock_guard lock(mutex_);
    if (!held_)
      throw Error(ErrorCode::invalid_argument, "no frame is acquired: call haustra_world_acquire_frame first");
    held_ = false;
  }
  released_.notify_all();
}

void FramePublisher::refuse_if_held() const {
  if (held_)
    throw Error(ErrorCode::invalid_argument,
                "the render thread holds a frame: release it before changing what the world holds (segments, "
                "instruments, obstacles, attachments, tissue, a material)");
}

void FramePublisher::fill(Slot& s, const World& w) const {
  s.frame = w.frame();
  s.time = w.time();
  const auto copy3 = [](const auto& from, auto& x, auto& y, auto& z) {
    std::copy(from.x.begin(), from.x.end(), x.begin());
    std::copy(from.y.begin(), from.y.end(), y.begin());
    std::copy(from.z.begin(), from.z.end(), z.begin());
  };
  copy3(w.node_positions(), s.x, s.y, s.z);
  w.current_rings(s.rings);  // the reader makes the mesh or the GPU's ring data (acquire)
  s.gpu_pending = true;
  if (w.mesh_update() == MeshUpdate::on_read) {
    s.mesh_pending = true;
    s.mesh_made = false;
  } else {
    copy3(w.mesh_positions(), s.px, s.py, s.pz);
    copy3(w.mesh_normals(), s.nx, s.ny, s.nz);
    s.mesh_made = true;
  }
  if (!details_) return;
  FrameDetails& d = s.details;
  const auto strain = w.strains().data, rest = w.rest_strains().data;
  std::copy(strain.begin(), strain.end(), d.strain.begin());
  std::copy(rest.begin(), rest.end(), d.rest_strain.begin());
  const auto contacts = w.contact_list();
  d.contacts.assign(contacts.begin(), contacts.end());  // grows once to the largest pile
  for (std::size_t i = 0; i < w.instrument_count(); ++i) d.instruments[i] = w.instrument(i);
  const auto intact = w.anchors_intact();
  std::copy(intact.begin(), intact.end(), d.anchors_intact.begin());
  for (std::size_t g = 0; g < w.segment_count(); ++g) {
    if (cages_ && w.mesh(g).enabled)
      d.cages[g] = w.cage_vertices(g);
    else
      d.cages[g].clear();
  }
  d.profile = w.last_profile();
}

}  // namespace haustra
