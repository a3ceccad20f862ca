// Checkpoints: the state a later frame depends on, to bytes and back (decision 0026); the World's
// calls that save and restore it, and files, are in api/world_checkpoint.cpp.
#include "io/checkpoint.hpp"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <cstring>

#include "haustra/error.hpp"

namespace haustra::detail {
namespace {

constexpr std::array<char, 8> kMagic = {'H', 'A', 'U', 'S', 'T', 'R', 'C', 'K'};
// 2: fast mode's chord state; 3: the instruments' coupling; 4: fast mode's prefactor; 5: anchors
// of connective tissue (which still hold), instruments' proxies and cutting; 6: the run-time
// parameters (decision 0099), the time step no longer in the fingerprint.
constexpr std::uint32_t kFormatVersion = 8;  // 8: sleeping ranges (decision 0127)

std::uint64_t fnv1a(std::span<const std::byte> bytes, std::uint64_t h = 0xcbf29ce484222325ull) {
  for (std::byte b : bytes) {
    h ^= static_cast<std::uint64_t>(b);
    h *= 0x100000001b3ull;
  }
  return h;
}

// What a checkpoint must match: the model's sizes, and a hash of the numbers that define its
// rod (rest shape, sections, masses, stiffness, bead radii). A checkpoint of another scene, or of
// the same scene with another node count or section, is refused by name rather than misread. The
// rod is hashed as the checkpoint's own run-time parameters make it (its material, decision 0099);
// the time step, a run-time parameter that builds nothing, is not hashed.
struct ModelHeader {
  std::uint64_t segments = 0, nodes = 0, beads = 0, attachments = 0, instruments = 0, mesh_vertices = 0;
  std::uint64_t fingerprint = 0;
  bool operator==(const ModelHeader&) const = default;
};

ModelHeader header_of(const WorldModel& m) {
  ModelHeader h{m.segments.size(),  m.node_total,         m.beads.size(),
                m.attachment_total, m.instruments.size(), m.mesh_vertex_total};
  auto hash_doubles = [](std::uint64_t seed, const std::vector<double>& v) {
    return fnv1a(std::as_bytes(std::span(v)), seed);
  };
  std::uint64_t f = 0xcbf29ce484222325ull;
  for (const SegmentModel& s : m.segments) {
    const std::array<std::uint64_t, 3> sizes{s.node_count, s.bead_count, s.attachments.size()};
    f = fnv1a(std::as_bytes(std::span(sizes)), f);
    f = fnv1a(std::as_bytes(std::span(s.stiffness)), f);
    f = fnv1a(std::as_bytes(std::span(s.viscosity)), f);
  }
  f = hash_doubles(f, m.rest_strain);
  f = hash_doubles(f, m.section_length);
  f = hash_doubles(f, m.node_mass);
  f = hash_doubles(f, m.beads.radius);
  // The tissue: which nodes its anchors hold, how, and towards where.
  f = fnv1a(std::as_bytes(std::span(m.anchors.node)), f);
  f = hash_doubles(f, m.anchors.stiffness);
  f = hash_doubles(f, m.anchors.damping);
  f = hash_doubles(f, m.anchors.slack);
  f = hash_doubles(f, m.anchors.strength);
  f = hash_doubles(f, m.anchors.support);
  for (const Eigen::Vector3d& t : m.anchors.target) f = fnv1a(std::as_bytes(std::span(t.data(), 3)), f);
  h.fingerprint = f;
  return h;
}

std::string describe(const ModelHeader& h) {
  return fmt::format("{} segment{}, {} nodes, {} beads, {} attachment slots, {} instruments, {} mesh vertices",
                     h.segments, h.segments == 1 ? "" : "s", h.nodes, h.beads, h.attachments, h.instruments,
                     h.mesh_vertices);
}

template <class T, class U>
concept StateOf = std::same_as<std::remove_const_t<T>, U>;

// The fields of each record the state holds, listed once for saving and for restoring.
template <class Io, StateOf<kernels::Pose> P>
void visit_members(Io& io, P& p) {
  io(p.rotation), io(p.position);
}
template <class Io, StateOf<Vec3Buffer> B>
void visit_members(Io& io, B& b) {
  io(b.x), io(b.y), io(b.z);  // three arrays, each with its length
}
template <class Io, StateOf<RotationBuffer> B>
void visit_members(Io& io, B& b) {
  io(b.w), io(b.x), io(b.y), io(b.z);
}
template <class Io, StateOf<AttachmentState> A>
void visit_members(Io& io, A& a) {
  io(a.active), io(a.node), io(a.hold_frame), io(a.target), io(a.target_rotation), io(a.force), io(a.moment);
}
template <class Io, StateOf<InstrumentState> I>
void visit_members(Io& io, I& in) {
#define HAUSTRA_VISIT_FIELD(type, name, initial, meaning) io(in.name);
  HAUSTRA_INSTRUMENT_STATE(HAUSTRA_VISIT_FIELD)  // state/world_state.hpp: the list, in this order
#undef HAUSTRA_VISIT_FIELD
}
template <class Io, StateOf<RunTimeParameters::Coupling> C>
void visit_members(Io& io, C& c) {
  io(c.stiffness), io(c.damping), io(c.force_limit);
}
template <class Io, StateOf<RunTimeParameters::Material> M>
void visit_members(Io& io, M& m) {
  auto& d = m.material;
  auto response = static_cast<std::uint8_t>(d.response);
  io(d.youngs_modulus), io(d.poisson_ratio), io(d.density), io(response), io(d.exp2_alpha), io(d.exp2_beta),
      io(d.exp2_gamma), io(d.failure_strain), io(m.relaxation_time);
  if constexpr (!std::is_const_v<M>) {
    if (response > static_cast<std::uint8_t>(TissueResponse::exp2))
      io.mismatch("names a tissue law this build does not know");
    d.response = static_cast<TissueResponse>(response);
  }
}
// The run-time parameters (decision 0099), ahead of the state: restoring reads them first.
template <class Io, class Parameters>
void visit_parameters(Io& io, Parameters& p) {
  io(p.gravity), io(p.dt), io(p.frame_budget), io(p.max_substeps), io(p.max_retries), io(p.calm_frames);
  io(p.couplings), io(p.materials);
}
template <class Io, StateOf<ContactReport> R>
void visit_members(Io& io, R& r) {
#define HAUSTRA_VISIT_FIELD(type, name, initial, meaning) io(r.name);
  HAUSTRA_CONTACT_FIELDS(HAUSTRA_VISIT_FIELD)
#undef HAUSTRA_VISIT_FIELD
}
// Fast mode's chord state (decision 0037): whether a recorded factorization may serve again (its
// frame, step length and contact pattern: at most an entry per attachment and bead), the record,
// the gains and the unit loads' responses it left — so a frame restored from here reuses it as the
// uninterrupted run does. A workspace with no record (another mode, a split rod) holds none of it.
template <class Io, class State>
void visit_chords(Io& io, const WorldModel& model, State& st) {
  std::uint64_t rods = st.newton.size();
  io(rods);
  if (rods != st.newton.size()) io.mismatch("was saved in another solver mode (its Newton workspaces)");
  for (std::size_t s = 0; s < st.newton.size(); ++s) {
    auto& ws = st.newton[s];
    bool recorded = !ws.record.empty();
    io(recorded);
    if (recorded != !ws.record.empty()) io.mismatch("was saved in another solver mode (fast mode's chord state)");
    if (!recorded) continue;
    io(ws.chord_ready), io(ws.chord_frame), io(ws.chord_dt);
    io.list(ws.chord_pattern, model.segments[s].attachments.size() + model.segments[s].bead_count);
    io(ws.record), io(ws.gain), io(ws.base_solution), io(ws.responses);
    // The sleeping range it was made around (decision 0127), and its base side's columns that a
    // chord iteration leaves standing (none unless the rod may hold a range).
    io(ws.chord_from), io(ws.chord_first);
    io(ws.split.base_gain), io(ws.split.base_solution), io(ws.split.raw), io(ws.split.at_joint);
    // Format 4 to 6 hold here whether fast mode's prefactor (solver.prefactor, removed by decision
    // 0108) had a sweep in flight: always 0 now, and a file that had one is refused.
    bool prefactor_pending = false;
    io(prefactor_pending);
    if (prefactor_pending)
      io.mismatch("was saved with fast mode's prefactor in flight (solver.prefactor, removed in decision 0108)");
  }
}
// Appends values as raw little-endian bytes (the checkpoint is for the machine that wrote it, or
// one of the same byte order; the header's magic would not match otherwise).
class Writer {
 public:
  std::vector<std::byte> bytes;

  template <class T>
  requires std::is_arithmetic_v<T>
  void operator()(const T& v) {
    const auto* p = reinterpret_cast<const std::byte*>(&v);
    bytes.insert(bytes.end(), p, p + sizeof(T));
  }
  template <class Derived>
  void operator()(const Eigen::MatrixBase<Derived>& m) {
    for (Eigen::Index i = 0; i < m.size(); ++i) (*this)(static_cast<double>(m.derived().data()[i]));
  }
  void operator()(const Eigen::Quaterniond& q) { (*this)(q.coeffs()); }
  template <class T>
  requires requires(Writer& w, const T& t) { visit_members(w, t); }
  void operator()(const T& record) { visit_members(*this, record); }
  template <class T>
  void operator()(const std::vector<T>& v) {
    array(std::span<const T>(v));
  }
  template <class T>
  void operator()(const std::span<T>& v) {
    array(std::span<const T>(v));
  }
  // A list whose length varies from frame to frame (up to `capacity`).
  template <class T>
  void list(const std::vector<T>& v, std::size_t /*capacity*/) {
    array(std::span<const T>(v));
  }
  void mismatch(const char*) const {}

 private:
  template <class T>
  void array(std::span<const T> v) {
    (*this)(static_cast<std::uint64_t>(v.size()));
    for (const T& e : v) (*this)(e);
  }
};

// Reads what Writer wrote. Every size must equal the state's (the model fixes them) and every
// number must be finite. With apply = false it only checks, so nothing is written until the whole
// checkpoint has been read once.
class Reader {
 public:
  Reader(std::span<const std::byte> bytes, bool apply, const std::string& source)
      : bytes_(bytes), apply_(apply), source_(source) {}

  template <class T>
  requires std::is_arithmetic_v<T>
  void operator()(T& v) {
    if (bytes_.size() - at_ < sizeof(T)) fail("ends early");
    T read;
    std::memcpy(&read, bytes_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    if constexpr (std::is_floating_point_v<T>)
      if (!std::isfinite(read)) fail(fmt::format("holds a non-finite number at byte {}", at_ - sizeof(T)));
    if (apply_) v = read;
  }
  void operator()(bool& v) {
    std::uint8_t byte = 0;
    const bool apply = apply_;
    apply_ = true;
    (*this)(byte);
    apply_ = apply;
    if (byte > 1) fail(fmt::format("holds {} where a flag (0 or 1) belongs", byte));
    if (apply_) v = byte != 0;
  }
  template <class Derived>
  void operator()(Eigen::MatrixBase<Derived>& m) {
    for (Eigen::Index i = 0; i < m.size(); ++i) (*this)(m.derived().data()[i]);
  }
  void operator()(Eigen::Quaterniond& q) { (*this)(q.coeffs()); }
  template <class T>
  requires requires(Reader& r, T& t) { visit_members(r, t); }
  void operator()(T& record) { visit_members(*this, record); }
  template <class T>
  void operator()(std::vector<T>& v) {
    (*this)(std::span<T>(v));
  }
  template <class T>
  void operator()(std::span<T> v) {
    std::uint64_t n = 0;
    const bool apply = apply_;
    apply_ = true;
    (*this)(n);
    apply_ = apply;
    if (n != v.size()) fail(fmt::format("has an array of {} entries where this world has {}", n, v.size()));
    for (T& e : v) (*this)(e);
  }
  template <class T>
  void list(std::vector<T>& v, std::size_t capacity) {
    std::uint64_t n = 0;
    const bool apply = apply_;
    apply_ = true;
    (*this)(n);
    apply_ = apply;
    if (n > capacity) fail(fmt::format("has a list of {} entries where this world holds at most {}", n, capacity));
    if (apply_) v.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      T e{};
      (*this)(e);
      if (apply_) v[i] = e;
    }
  }
  void mismatch(const std::string& what) const { fail(what); }
  [[nodiscard]] bool at_end() const { return at_ == bytes_.size(); }
  [[nodiscard]] std::size_t at() const { return at_; }
  [[noreturn]] void fail(const std::string& what) const {
    throw Error(ErrorCode::parse, fmt::format("checkpoint '{}': the state {}; it was not restored", source_, what));
  }

 private:
  std::span<const std::byte> bytes_;
  std::size_t at_ = 0;
  bool apply_;
  const std::string& source_;
};

// Every part of the state a later frame reads before writing it. The rest is either scratch of
// one substep or derived from these (meshes, the frame-start snapshot) and rebuilt on restore.
template <class Io, class State>
void visit_state(Io& io, State& st) {
  // The kept buffers of state/world_state.hpp's lists, in their order.
#define HAUSTRA_VISIT_KEPT(type, name, per, width, initial, role, meaning) \
  if constexpr (Role::role == Role::kept) io(st.now.name);
  HAUSTRA_PERSISTENT_STATE(HAUSTRA_VISIT_KEPT)
#undef HAUSTRA_VISIT_KEPT
#define HAUSTRA_VISIT_KEPT(type, name, per, width, initial, role, meaning) \
  if constexpr (Role::role == Role::kept) io(st.name);
  HAUSTRA_FRAME_STATE(HAUSTRA_VISIT_KEPT)
#undef HAUSTRA_VISIT_KEPT
  io(st.collision.bead_motion);
  io(st.collision.report);
  io(st.instruments);
  io(st.robust_substeps), io(st.robust_newton), io(st.robust_good_frames), io(st.robust_calm_spell);
  io(st.frame), io(st.time);
}

// Indices a corrupt or hand-made checkpoint could put out of range.
void check_indices(const WorldModel& model, const WorldState& st, const Reader& reader, int max_substeps) {
  for (const SegmentModel& seg : model.segments)
    for (std::size_t a = 0; a < seg.attachments.size(); ++a)
      if (st.now.attachment[seg.attachment_offset + a].node >= seg.node_count)
        reader.fail(fmt::format("attaches node {} of segment '{}', which has {}",
                                st.now.attachment[seg.attachment_offset + a].node, seg.info.name, seg.node_count));
  for (std::size_t r = 0; r < model.segments.size(); ++r) {
    const HeldRange h = st.held_range(r);
    const std::size_t n = model.segments[r].node_count;
    if ((h.any() || h.first != 0) && (!model.sleep.ranges || model.segments[r].split_node > 0 || h.last >= n ||
                                      h.last < h.first + kMinSleepingRange - 1 || (h.first == 0 && h.last + 1 >= n)))
      reader.fail(fmt::format("holds nodes {} to {} of segment '{}' asleep, which has {}{}", h.first, h.last,
                              model.segments[r].info.name, n,
                              !model.sleep.ranges                ? " (this world's sleep.ranges is off)"
                              : model.segments[r].split_node > 0 ? " (a split rod keeps its ranges awake)"
                                                                 : ""));
  }
  for (const InstrumentState& in : st.instruments) {
    if (!in.grasping) continue;
    if (in.grasp_segment >= model.segments.size() || in.grasp_attachment >= model.attachment_total ||
        in.grasp_bead >= model.beads.size() || in.grasp_node >= model.node_mass.size())
      reader.fail("has an instrument grasping a segment, slot or bead this world does not have");
  }
  if (st.robust_substeps < 1 || st.robust_substeps > std::max(max_substeps, model.solver.substeps))
    reader.fail(fmt::format("runs {} substeps, outside 1..{}", st.robust_substeps, max_substeps));
  if (st.robust_good_frames < 0 || st.robust_calm_spell < 1)
    reader.fail(fmt::format("has a calm spell of {} frames with {} calm frames served, expected at least 1 and 0",
                            st.robust_calm_spell, st.robust_good_frames));
}

}  // namespace

std::vector<std::byte> save_checkpoint(const WorldModel& model, const WorldState& state,
                                       const RunTimeParameters& parameters) {
  Writer payload;
  visit_parameters(payload, parameters);
  visit_state(payload, state);
  visit_chords(payload, model, state);
  Writer out;
  for (char c : kMagic) out(c);
  out(kFormatVersion);
  const ModelHeader h = header_of(model);
  out(h.segments), out(h.nodes), out(h.beads), out(h.attachments), out(h.instruments), out(h.mesh_vertices);
  out(h.fingerprint);
  out(static_cast<std::uint64_t>(payload.bytes.size()));
  out.bytes.insert(out.bytes.end(), payload.bytes.begin(), payload.bytes.end());
  out(fnv1a(payload.bytes));
  return out.bytes;
}

namespace {

[[noreturn]] void refuse(const std::string& source, const std::string& what) {
  throw Error(ErrorCode::parse, fmt::format("checkpoint '{}': {}; the world was left as it was", source, what));
}

}  // namespace

OpenedCheckpoint open_checkpoint(const WorldModel& model, const WorldDesc& desc, std::span<const std::byte> bytes,
                                 const std::string& source) {
  Reader head(bytes, true, source);
  std::array<char, 8> magic{};
  if (bytes.size() < magic.size())
    refuse(source, fmt::format("{} bytes is too short for a haustra checkpoint", bytes.size()));
  for (char& c : magic) head(c);
  if (magic != kMagic) refuse(source, "not a haustra checkpoint (it does not start with HAUSTRCK)");
  std::uint32_t version = 0;
  head(version);
  if (version != kFormatVersion)
    refuse(source, fmt::format("format version {}, this build reads version {}", version, kFormatVersion));
  ModelHeader h;
  head(h.segments), head(h.nodes), head(h.beads), head(h.attachments), head(h.instruments), head(h.mesh_vertices);
  head(h.fingerprint);
  ModelHeader mine = header_of(model);
  mine.fingerprint = h.fingerprint;  // compared once the model holds the checkpoint's material (restore_state)
  if (h != mine)
    refuse(source, fmt::format("saved from a world of {}; this world has {}", describe(h), describe(mine)));
  std::uint64_t size = 0;
  head(size);
  const std::size_t header_bytes = magic.size() + sizeof version + 8 * sizeof(std::uint64_t);
  if (bytes.size() - header_bytes < sizeof(std::uint64_t) ||
      size != bytes.size() - header_bytes - sizeof(std::uint64_t))
    refuse(source, fmt::format("{} bytes where its header promises {}", bytes.size(), header_bytes + size + 8));
  const std::span<const std::byte> payload = bytes.subspan(header_bytes, size);
  std::uint64_t checksum = 0;
  std::memcpy(&checksum, bytes.data() + header_bytes + size, sizeof checksum);
  if (checksum != fnv1a(payload)) refuse(source, "its checksum does not match its contents (the file is damaged)");
  OpenedCheckpoint opened{parameters_of(desc), h.fingerprint, {}};  // sized as this world's lists
  Reader parameters(payload, true, source);
  visit_parameters(parameters, opened.parameters);
  opened.state = payload.subspan(parameters.at());
  return opened;
}

void restore_state(const WorldModel& model, WorldState& state, const OpenedCheckpoint& checkpoint,
                   const std::string& source) {
  if (header_of(model).fingerprint != checkpoint.fingerprint)
    refuse(source,
           "saved from a world of the same sizes but another rod (rest shape, sections, masses, stiffness or bead "
           "radii differ, beyond what its run-time parameters set); restore it into a world built from the same scene");
  // Read once into a copy and check it whole; only then into the state, whose buffers (and the
  // views a host holds of them) stay where they are.
  WorldState staged = state;
  Reader check(checkpoint.state, true, source);
  visit_state(check, staged);
  visit_chords(check, model, staged);
  if (!check.at_end()) check.fail("is longer than this world's state");
  check_indices(model, staged, check, checkpoint.parameters.max_substeps);
  Reader apply(checkpoint.state, true, source);
  visit_state(apply, state);
  visit_chords(apply, model, state);
}

}  // namespace haustra::detail
