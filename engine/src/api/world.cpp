// The C++ API's accessors and setters: reading a world's buffers and reports, posing rods,
// loads, attachments, instruments. The frame itself is frame.cpp; checkpoints checkpoint.cpp;
// adding and removing segments state_carry_over.cpp.
#include <fmt/format.h>

#include <algorithm>
#include <vector>

#include "haustra/kernels/rod_forward_sweep.hpp"
#include "model/field_checks.hpp"
#include "step/collision.hpp"
#include "step/instruments.hpp"
#include "step/world_impl.hpp"

namespace haustra {

namespace {

// Finite and within the bound every vector of a description has (field_checks.hpp).
bool bounded(const Eigen::Vector3d& v) {
  return v.allFinite() && v.cwiseAbs().maxCoeff() <= detail::kMaxVectorComponent;
}

}  // namespace

std::string_view api_call_name(const std::source_location& where) {
  // GCC's "const haustra::SegmentInfo& haustra::World::segment(std::size_t) const" → "World::segment".
  std::string_view name = where.function_name();
  name = name.substr(0, name.find('('));
  if (const std::size_t space = name.rfind(' '); space != std::string_view::npos) name.remove_prefix(space + 1);
  constexpr std::string_view kNamespace = "haustra::";
  if (name.starts_with(kNamespace)) name.remove_prefix(kNamespace.size());
  return name;
}

std::unique_ptr<World> World::create(const WorldDesc& desc) {
  if (desc.jobs.enabled() != (desc.jobs.wait != nullptr))
    throw Error(ErrorCode::invalid_argument, "jobs: a host job system needs both enqueue and wait (or neither)");
  if (desc.jobs.enabled() && (desc.jobs.workers < 1 || desc.jobs.workers > 1024))
    throw Error(ErrorCode::invalid_argument, fmt::format("jobs.workers = {}: expected 1 to 1024", desc.jobs.workers));
  return std::unique_ptr<World>(new World(std::make_unique<Impl>(desc, detail::build_world_model(desc))));
}

World::World(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

World::~World() = default;

// ---- One thread at a time (decision 0100) ------------------------------------------------------------

World::Use::Use(const World& world, const std::source_location& where) : world_(world) { take(api_call_name(where)); }

World::Use::Use(const World& world, std::string_view call) : world_(world) { take(call); }

void World::Use::take(std::string_view call) {
  const std::string prefix = call.empty() ? std::string() : fmt::format("{}: ", call);
  const std::thread::id me = std::this_thread::get_id();
  if (world_.user_.load(std::memory_order_acquire) == me) {  // only this thread could have set it
    if (world_.stepping_)
      throw Error(ErrorCode::busy, prefix +
                                       "called from inside a step of this world (a job system's callback?): "
                                       "the world takes calls again once its step returns");
    ++world_.holds_;
    return;
  }
  std::thread::id none{};
  if (!world_.user_.compare_exchange_strong(none, me, std::memory_order_acquire, std::memory_order_relaxed))
    throw Error(ErrorCode::busy, prefix +
                                     "the world is in use by another thread: one thread at a time steps, changes "
                                     "or reads a world's meshes (decision 0100); call again once its call returns");
  world_.holds_ = 1;
}

World::Use::~Use() {
  if (--world_.holds_ == 0) world_.user_.store(std::thread::id{}, std::memory_order_release);
}

std::size_t World::segment_count() const { return impl_->model.pieces.size(); }
std::size_t World::node_count() const { return impl_->model.node_total; }
const SegmentInfo& World::segment(std::size_t index) const { return impl_->piece(index).info; }
std::size_t World::chain_of(std::size_t segment) const {
  const detail::SegmentPiece& p = impl_->piece(segment);
  return impl_->model.segments[p.rod].first_piece;
}
double World::dt() const { return impl_->model.dt; }
std::uint64_t World::frame() const { return impl_->state.frame; }
double World::time() const { return impl_->state.time; }
kernels::Vec3View<const double> World::node_positions() const { return impl_->state.now.position.view(); }
kernels::RotationView<const double> World::node_rotations() const { return impl_->state.now.rotation.view(); }
kernels::StrainView<const double> World::strains() const {
  return kernels::StrainView<const double>{impl_->state.now.strain};
}
kernels::StrainView<const double> World::rest_strains() const {
  return kernels::StrainView<const double>{impl_->model.rest_strain};
}
std::span<const double> World::section_lengths() const { return impl_->model.section_length; }
kernels::Pose World::base_pose(std::size_t segment) const {
  const detail::SegmentPiece& p = impl_->piece(segment);
  if (p.first_node == 0) return impl_->state.now.base[p.rod];
  const std::size_t node = p.info.nodes.offset;  // a chained piece's base is its predecessor's tip
  return {impl_->state.now.rotation.view().get(node), impl_->state.now.position.view().get(node)};
}

void World::pose_rod(std::size_t segment, const kernels::Pose& base, std::span<const double> strains) {
  const Use use(*this);
  const Impl::WakeOnChange wake(impl_);  // sleeping rods move again (decision 0119)
  auto& m = impl_->model;
  const detail::SegmentPiece& piece = impl_->piece(segment);
  if (piece.first_node != 0)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("segment '{}' is a later piece of the chain '{}': pose the chain through its first piece",
                            piece.info.name, m.segments[piece.rod].info.name));
  segment = piece.rod;
  impl_->motion_dt = 0.0;  // the posed rod did not move there over a frame
  const detail::SegmentModel& seg = m.segments[segment];
  if (strains.size() != 4 * seg.node_count)
    throw Error(ErrorCode::invalid_argument, fmt::format("segment '{}' needs {} strains (4 per node), got {}",
                                                         seg.info.name, 4 * seg.node_count, strains.size()));
  if (!base.position.allFinite() || !base.rotation.coeffs().allFinite() || !(base.rotation.norm() > 0.0))
    throw Error(ErrorCode::invalid_argument, "pose_rod: the base pose must be finite");
  for (double q : strains)
    if (!std::isfinite(q)) throw Error(ErrorCode::invalid_argument, "pose_rod: strains must be finite");
  auto& st = impl_->state;
  std::copy(strains.begin(), strains.end(), st.now.strain.begin() + static_cast<std::ptrdiff_t>(4 * seg.node_offset));
  st.now.base[segment] = {base.rotation.normalized(), base.position};
  const detail::SegmentViews v = detail::segment_views(m, st, segment);
  kernels::rod_forward_sweep(st.now.base[segment], v.section_length, v.strain, v.poses);
  st.frame_start.copy_from(st.now);
  impl_->follow_rod();
}

void World::set_external_load(std::size_t node, const Eigen::Vector3d& force, const Eigen::Vector3d& moment) {
  const Use use(*this);
  const Impl::WakeOnChange wake(impl_);  // sleeping rods move again (decision 0119)
  impl_->check_node(node);
  if (!bounded(force) || !bounded(moment))
    throw Error(
        ErrorCode::invalid_argument,
        fmt::format("external load: force ({:.6g}, {:.6g}, {:.6g}) N and moment ({:.6g}, {:.6g}, {:.6g}) N·m "
                    "must be finite and within ±{:g} in each component",
                    force.x(), force.y(), force.z(), moment.x(), moment.y(), moment.z(), detail::kMaxVectorComponent));
  impl_->state.external_force.view().set(node, force);
  impl_->state.external_moment.view().set(node, moment);
}

void World::set_attachment_target(std::size_t segment, std::size_t attachment, const Eigen::Vector3d& position) {
  const Use use(*this);
  const Impl::WakeOnChange wake(impl_);  // sleeping rods move again (decision 0119)
  if (!bounded(position))
    throw Error(ErrorCode::invalid_argument,
                fmt::format("attachment target must be finite and within ±{:g} m", detail::kMaxVectorComponent));
  impl_->state.now.attachment[impl_->attachment_index(segment, attachment)].target = position;
}

void World::set_attachment_target_rotation(std::size_t segment, std::size_t attachment,
                                           const Eigen::Quaterniond& rotation) {
  const Use use(*this);
  const Impl::WakeOnChange wake(impl_);  // sleeping rods move again (decision 0119)
  if (!rotation.coeffs().allFinite() || !(rotation.norm() > 0.0))
    throw Error(ErrorCode::invalid_argument, "attachment rotation must be a finite, non-zero quaternion");
  impl_->state.now.attachment[impl_->attachment_index(segment, attachment)].target_rotation = rotation.normalized();
}

void World::set_attachment_active(std::size_t segment, std::size_t attachment, bool active) {
  const Use use(*this);
  const Impl::WakeOnChange wake(impl_);  // sleeping rods move again (decision 0119)
  impl_->state.now.attachment[impl_->attachment_index(segment, attachment)].active = active;
}

std::size_t World::attachment_count(std::size_t segment) const {
  return impl_->model.segments[impl_->piece(segment).rod].attachments.size();
}

AttachmentReading World::attachment(std::size_t segment, std::size_t attachment) const {
  const std::size_t index = impl_->attachment_index(segment, attachment);
  const detail::AttachmentModel& m = impl_->model.segments[impl_->piece(segment).rod].attachments[attachment];
  const detail::AttachmentState& a = impl_->state.now.attachment[index];
  return {a.node, a.active, m.grasp_slot, m.grasp_slot ? m.instrument : 0, a.target, a.force, a.moment};
}

Eigen::Vector3d World::attachment_force(std::size_t segment, std::size_t attachment) const {
  return impl_->state.now.attachment[impl_->attachment_index(segment, attachment)].force;
}

Eigen::Vector3d World::attachment_moment(std::size_t segment, std::size_t attachment) const {
  return impl_->state.now.attachment[impl_->attachment_index(segment, attachment)].moment;
}

std::size_t World::bead_count() const { return impl_->model.beads.size(); }
Range World::beads(std::size_t segment) const {
  const detail::SegmentPiece& p = impl_->piece(segment);
  return {p.bead_offset, p.bead_count};
}
std::span<const double> World::bead_radii() const { return impl_->model.beads.radius; }
std::span<const std::uint32_t> World::bead_nodes() const { return impl_->model.beads.node; }
kernels::Vec3View<const double> World::bead_centres() const { return impl_->state.collision.bead_position.view(); }
std::shared_ptr<const void> World::buffers_keeper() const { return impl_; }
bool World::beads_may_collide(std::size_t a, std::size_t b) const {
  const auto& beads = impl_->model.beads;
  if (a >= beads.size() || b >= beads.size() || a == b)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("bead indices {} and {}: need two different beads below {}", a, b, beads.size()));
  if (beads.segment[a] != beads.segment[b] && impl_->model.contact.rest_exclusions == RestExclusions::segment)
    return true;
  if (beads.segment[a] == beads.segment[b] && !impl_->model.contact.self) return false;
  return !beads.excluded(static_cast<std::uint32_t>(std::min(a, b)), static_cast<std::uint32_t>(std::max(a, b)));
}
const ContactReport& World::contacts() const { return impl_->state.collision.report; }
std::span<const Contact> World::contact_list() const { return impl_->state.collision.candidates; }

std::size_t World::instrument_count() const { return impl_->model.instruments.size(); }

void World::set_instrument_pose(std::size_t instrument, const Eigen::Vector3d& tip, const Eigen::Vector3d& axis) {
  const Use use(*this);
  impl_->check_instrument(instrument);
  if (!bounded(tip) || !bounded(axis) || !(axis.norm() > 0.0))
    throw Error(ErrorCode::invalid_argument,
                fmt::format("instrument pose: the tip must be finite (within ±{:g} m) and the axis a finite, non-zero "
                            "direction",
                            detail::kMaxVectorComponent));
  detail::InstrumentState& s = impl_->state.instruments[instrument];
  s.scripted = false;
  detail::set_instrument_pose(s, tip, axis);
  // Before the first frame a proxy is placed where it is commanded; after, it gets there as its
  // coupling and what it meets on the way let it (decision 0096).
  if (impl_->state.frame == 0) s.tip = s.command_start = s.proxy_start = s.command_tip;
}

void World::set_instrument_grasp(std::size_t instrument, bool closed) {
  const Use use(*this);
  impl_->check_instrument(instrument);
  impl_->state.instruments[instrument].scripted = false;
  impl_->state.instruments[instrument].closed = closed;
}

void World::set_instrument_cutting(std::size_t instrument, bool cutting) {
  const Use use(*this);
  impl_->check_instrument(instrument);
  impl_->state.instruments[instrument].scripted = false;
  impl_->state.instruments[instrument].cutting = cutting;
}

InstrumentReading World::instrument(std::size_t instrument) const {
  impl_->check_instrument(instrument);
  const detail::InstrumentState& s = impl_->state.instruments[instrument];
  InstrumentReading r;
  r.tip = s.tip;
  r.commanded_tip = s.command_tip;
  r.axis = s.axis;
  r.closed = s.closed;
  r.cutting = s.cutting;
  r.grasping = s.grasping;
  r.slipped = s.slipped;
  if (s.grasping) {
    const detail::AttachmentState& as = impl_->state.now.attachment[s.grasp_attachment];
    std::tie(r.grasped_segment, r.grasped_node) = impl_->piece_of(s.grasp_segment, as.node);
    r.grasp_attachment = s.grasp_attachment - impl_->model.segments[s.grasp_segment].attachment_offset;
    r.grasp_target = s.grasp_target;
  }
  r.force = s.force;
  r.torque = s.torque;
  r.filtered_force = s.filtered_force;
  r.filtered_torque = s.filtered_torque;
  return r;
}

const MeshInfo& World::mesh(std::size_t segment) const { return impl_->mesh_of(segment).info; }
std::size_t World::mesh_buffer_size() const { return impl_->model.mesh_vertex_total; }
kernels::Vec3View<const float> World::mesh_positions() const {
  const Use use(*this);
  impl_->bring_mesh_up_to_date();
  const auto& p = impl_->state.mesh.position;
  return {p.x, p.y, p.z};
}
kernels::Vec3View<const float> World::mesh_normals() const {
  const Use use(*this);
  impl_->bring_mesh_up_to_date();
  const auto& p = impl_->state.mesh.normal;
  return {p.x, p.y, p.z};
}
std::size_t World::ring_count() const { return impl_->model.ring_total; }
void World::current_rings(std::span<kernels::RingPose> out) const {
  const Use use(*this);
  if (out.size() != impl_->model.ring_total)
    throw Error(ErrorCode::invalid_argument, fmt::format("current_rings: {} ring poses given, the world has {}",
                                                         out.size(), impl_->model.ring_total));
  if (!impl_->rings_stale) {  // already made this frame: the same bits, copied
    std::copy(impl_->state.mesh.ring_pose.begin(), impl_->state.mesh.ring_pose.end(), out.begin());
    return;
  }
  for (std::size_t piece = 0; piece < impl_->model.pieces.size(); ++piece)
    detail::stage_rings(impl_->model, impl_->state, out, piece);
}
void World::mesh_from_rings(std::span<const kernels::RingPose> rings, std::span<float> ring_delta,
                            kernels::Vec3View<float> positions, kernels::Vec3View<float> normals) const {
  const detail::WorldModel& m = impl_->model;
  if (rings.size() != m.ring_total || ring_delta.size() != kernels::kRingScratchFloats * m.ring_total ||
      positions.size() != m.mesh_vertex_total || normals.size() != m.mesh_vertex_total)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("mesh_from_rings: expected {} rings, {} floats of scratch and {} vertices", m.ring_total,
                            kernels::kRingScratchFloats * m.ring_total, m.mesh_vertex_total));
  impl_->mesh_from_rings(
      {rings, ring_delta, {positions.x, positions.y, positions.z}, {normals.x, normals.y, normals.z}});
}
MeshUpdate World::mesh_update() const { return impl_->desc.mesh_update; }

void World::set_frame_budget(double seconds) {
  const Use use(*this);
  if (!(seconds >= 0.0 && seconds <= 3600.0))
    throw Error(ErrorCode::invalid_argument,
                fmt::format("frame_budget = {}: expected seconds in [0, 3600] (0: no budget)", seconds));
  impl_->desc.frame_budget = seconds;
  impl_->model.frame_budget = seconds;
}
double World::frame_budget() const { return impl_->desc.frame_budget; }
std::uint64_t World::late_frames() const { return impl_->late_frames; }

std::span<const std::array<std::uint32_t, 3>> World::mesh_triangles() const { return impl_->model.mesh_triangles; }
std::span<const std::array<std::uint32_t, 3>> World::cage_triangles(std::size_t segment) const {
  return impl_->mesh_of(segment).cage.triangles;
}
std::vector<Eigen::Vector3d> World::cage_vertices(std::size_t segment) const {
  const Use use(*this);
  const detail::SegmentMesh& m = impl_->mesh_of(segment);
  if (!m.enabled) return {};
  impl_->bring_mesh_up_to_date(/*rings_only=*/true);
  std::vector<Eigen::Vector3d> out(m.cage.offset.size());
  kernels::cage_vertices(std::span(impl_->state.mesh.ring_pose).subspan(m.ring_offset, m.cage.ring_station.size()),
                         m.cage.vertex_ring, m.cage.offset, out);
  return out;
}
std::span<const kernels::RingPose> World::ring_poses(std::size_t segment) const {
  const Use use(*this);
  const detail::SegmentMesh& m = impl_->mesh_of(segment);
  impl_->bring_mesh_up_to_date(/*rings_only=*/true);
  return std::span<const kernels::RingPose>(impl_->state.mesh.ring_pose)
      .subspan(m.ring_offset, m.cage.ring_station.size());
}

Energy World::energy() const {
  Energy e;
  for (std::size_t s = 0; s < impl_->model.segments.size(); ++s) {
    const Energy es = detail::segment_energy(impl_->model, impl_->state, impl_->state.now.strain,
                                             impl_->state.now.position.view(), impl_->state.now.rotation.view(), s);
    e.elastic += es.elastic;
    e.gravity += es.gravity;
    e.tissue += es.tissue;
  }
  return e;
}

std::vector<std::uint32_t> World::mesh_vertex_nodes() const {
  const detail::WorldModel& m = impl_->model;
  std::vector<std::uint32_t> out(m.mesh_vertex_total, 0);
  for (std::size_t p = 0; p < m.pieces.size(); ++p) {
    const detail::SegmentMesh& mesh = m.meshes_of[p];
    if (!mesh.enabled) continue;
    // The piece's nodes' places along it (its mesh's places are from its first node).
    const std::size_t first = m.pieces[p].info.nodes.offset, count = m.pieces[p].info.nodes.count;
    std::vector<double> at(count, 0.0);
    for (std::size_t k = 1; k < count; ++k) at[k] = at[k - 1] + m.section_length[first + k - 1];
    for (std::size_t v = 0; v < mesh.cage.mesh_place.size(); ++v) {
      const double s = mesh.cage.mesh_place[v];
      const auto above = static_cast<std::size_t>(std::lower_bound(at.begin(), at.end(), s) - at.begin());
      std::size_t k = std::min(above, count - 1);
      if (k > 0 && s - at[k - 1] < at[k] - s) --k;
      out[mesh.vertex_offset + v] = static_cast<std::uint32_t>(first + k);
    }
  }
  return out;
}

std::span<const std::uint32_t> World::cage_vertex_rings(std::size_t segment) const {
  return impl_->mesh_of(segment).cage.vertex_ring;
}

const FrameProfile& World::last_profile() const { return impl_->profile; }

bool World::node_asleep(std::size_t node) const {
  const detail::WorldModel& m = impl_->model;
  const detail::WorldState& s = impl_->state;
  if (node >= m.node_total) throw Error(ErrorCode::invalid_argument, fmt::format("node {} of {}", node, m.node_total));
  for (std::size_t rod = 0; rod < m.segments.size(); ++rod) {
    const detail::SegmentModel& seg = m.segments[rod];
    if (node < seg.node_offset || node >= seg.node_offset + seg.node_count) continue;
    const detail::HeldRange held = s.held_range(rod);
    const std::size_t local = node - seg.node_offset;
    return s.rod_asleep[rod] != 0 || (held.any() && local >= held.first && local <= held.last);
  }
  return false;
}
std::span<const Event> World::events() const { return impl_->events; }
std::size_t World::take_events(std::span<Event> out, std::uint64_t* dropped) {
  const Use use(*this);
  std::vector<Event>& waiting = impl_->events;
  const std::size_t n = std::min(out.size(), waiting.size());
  std::copy_n(waiting.begin(), n, out.begin());
  waiting.erase(waiting.begin(), waiting.begin() + static_cast<std::ptrdiff_t>(n));
  if (dropped != nullptr) *dropped = impl_->events_dropped;
  impl_->events_dropped = 0;
  return n;
}
int World::threads() const { return impl_->scheduler.threads(); }

}  // namespace haustra
