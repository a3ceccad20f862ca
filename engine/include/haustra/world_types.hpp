#pragma once
// The plain structs a world reports (ranges, segment and mesh reports, contacts, instrument
// readings, energy, events): what model building and the API share, without the World class.
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include <Eigen/Core>

#include "haustra/profile.hpp"

namespace haustra {

struct Range {
  std::size_t offset = 0;
  std::size_t count = 0;
};

// What the model builder derived for one segment: stiffnesses, masses, and how well the rest
// shape reproduces its source.
struct SegmentInfo {
  std::string name;
  Range nodes;
  double length = 0.0;                // m, rest
  double bending_stiffness = 0.0;     // B = π E R³ h_w, N·m²
  double torsion_stiffness = 0.0;     // T = 2π G R³ h_w, N·m²
  double axial_stiffness = 0.0;       // EA, A = 2π R h_w, N
  std::array<double, 4> viscosity{};  // η per component, zero for elastic ones
  double linear_density = 0.0;        // kg/m
  double zeta = 0.0;                  // inertia filter regulator, 1/N
  // Rest shape from a centreline: largest distance of the rod's interpolation nodes from the
  // resampled polyline (reproduction error of the construction itself), and of the source
  // polyline's vertices from the rod's curve (includes the resampling to N+1 nodes). Metres.
  double rest_node_deviation = 0.0;
  double rest_polyline_deviation = 0.0;
};

// How the cage around a segment's organ mesh came out (docs/decisions/0017-cage-builder.md).
struct CageReport {
  std::size_t rings = 0, bead_rings = 0, middle_rings = 0;
  std::size_t end_rings = 0;      // rings past an end, where the mesh runs on beyond the rod (decision 0050)
  std::size_t dropped_rings = 0;  // middle rings taken out where longer quads were needed
  std::size_t ring_vertices = 0;  // m per ring
  std::size_t vertices = 0, triangles = 0;
  double clearance = 0.0;  // m asked between mesh and cage
  // How far ring vertices went beyond their template (the bead's radius), m; negative: inside it.
  double inflation_min = 0.0, inflation_mean = 0.0, inflation_max = 0.0;
  int iterations = 0;          // inflation passes
  double tightest_bend = 0.0;  // m: the smallest bend radius of the rest rod at a ring
  // The binding pose: "harmonic" or "closest" (decision 0049), the mesh's connected pieces, and
  // how many of them had no two ends for the harmonic place (or had every vertex astray of it) and
  // took each vertex's closest point, and the vertices the harmonic function passed by, placed
  // from their neighbours.
  std::string binding = "closest";
  std::size_t binding_pieces = 0, binding_closest_pieces = 0, binding_followed = 0;
  // Vertices copied where the surface fused two loops of the organ into one wall and was cut back
  // into two (issue 35; a mesh from a file, on a chain's first piece): the copies follow the mesh's
  // own vertices, each with its loop.
  std::size_t fused_copies = 0;
  // Embree's final verification in the binding pose, where the weights are computed: all zero for
  // a cage that embeds the mesh.
  std::size_t mesh_vertices_outside = 0, crossing_edges = 0, self_intersections = 0;
  // The same cage at the curved rest pose: mesh vertices outside it where the organ bends more
  // tightly than its own radius or its loops touch (for the record; the binding does not use it).
  std::size_t rest_pose_outside = 0;
  double seconds = 0.0;
};

// The binding of the mesh to the cage: mean value coordinates (or linear-blend weights) per mesh
// vertex, grouped by ring, localized to the rings of largest weight.
struct SkinReport {
  SkinningMethod method = SkinningMethod::along_rod;
  std::size_t rings_per_vertex = 0;    // rings kept, the vertex that keeps most (all rings when not localized)
  double mean_rings_per_vertex = 0.0;  // over the vertices
  double slots_per_vertex = 0.0;       // what skinning costs: rings × lanes of every block (padding too), per vertex
  double min_weight = 0.0;             // most negative MVC weight of any vertex
  double max_negative_mass = 0.0;      // Σ|w| of negative weights, worst vertex
  double mean_negative_mass = 0.0;
  std::size_t negative_vertices = 0;       // vertices with any negative weight
  std::size_t on_face = 0, on_vertex = 0;  // vertices found on the cage (exact branches)
  double max_dropped_mass = 0.0;           // Σ|w| of the rings left out by localization, worst vertex
  double mean_dropped_mass = 0.0;
  double rest_error = 0.0;  // m: skinned rest pose vs the input mesh (float rounding)
  // m: how far the binding-pose weights, carried to the rings' curved rest poses, would put a
  // vertex from where it is; taken up by the binding so the rest pose is exact (worst vertex).
  double max_rest_correction = 0.0;
  double seconds = 0.0;  // to compute the weights
};

// A segment's organ mesh: where its vertices are in the world's mesh buffers, and how it was bound.
struct MeshInfo {
  bool enabled = false;
  std::string source;  // file, or "procedural"
  Range vertices;      // into mesh_positions()
  Range triangles;     // into mesh_triangles()
  CageReport cage;
  SkinReport skin;
};

enum class ContactKind : std::uint8_t { bead, plane, sphere, capsule, mesh, instrument };

// A contact of the last substep: a bead and what it may touch (another bead, or the shape's index
// among planes, spheres, capsules, meshes or instruments), listed at the substep's start within a
// margin, with the penalty evaluated at the positions of the solve's last iteration. A mesh
// contact keeps the tangent plane found at the start.
struct Contact {
  std::uint32_t bead = 0;
  std::uint32_t other = 0;
  ContactKind kind = ContactKind::bead;
  // Where the other surface comes nearest the bead's centre (at the frame's end; a plane: the foot).
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();     // mesh: the plane's free side
  Eigen::Vector3d force = Eigen::Vector3d::Zero();       // N, on `bead`; a second bead gets the opposite
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();  // separating direction
  double stiffness = 0.0;                                // of the linearization, N/m
  double depth = 0.0;                                    // m; > 0 overlapping
  bool coupled = false;  // two beads of one segment, solved as a pair by Newton (not node by node)
};

// Contacts of the last frame, measured at its final positions.
struct ContactReport {
  HAUSTRA_CONTACT_FIELDS(HAUSTRA_DECLARE_FIELD)  // candidates, touching, depths and overlaps (report_fields.h)
};

// An attachment as it stands (World::attachment).
struct AttachmentReading {
  std::size_t node = 0;  // along the chain
  bool active = false;
  bool grasp_slot = false;     // an instrument's grasp on this segment
  std::size_t instrument = 0;  // whose, for a grasp slot
  Eigen::Vector3d target = Eigen::Vector3d::Zero();
  Eigen::Vector3d force = Eigen::Vector3d::Zero();   // on the rod, last frame, N
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();  // N·m
};

// An instrument's state after the last frame. Force and torque are what the tissue exerts on the
// instrument (the negative of what the instrument exerts on the rod), torque about the tip.
struct InstrumentReading {
  // Where the capsule is; for a proxy (decision 0096) where its coupling and what it meets
  // balance, which may fall short of where it is commanded.
  Eigen::Vector3d tip = Eigen::Vector3d::Zero();
  Eigen::Vector3d commanded_tip = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  bool closed = false;
  bool cutting = false;  // cuts the connective tissue within its cut radius (decision 0095)
  bool grasping = false;
  bool slipped = false;  // closed, but its grasp let go: pulled past its holding force (decision 0058)
  std::size_t grasped_segment = 0;
  std::size_t grasped_node = 0;  // local to the segment
  // The segment's attachment that holds the grasp (for attachment_force), and where the grasp
  // wants the node: the tip plus the offset the node had from it at the moment of grasping.
  std::size_t grasp_attachment = 0;
  Eigen::Vector3d grasp_target = Eigen::Vector3d::Zero();
  Eigen::Vector3d force = Eigen::Vector3d::Zero();
  Eigen::Vector3d torque = Eigen::Vector3d::Zero();
  Eigen::Vector3d filtered_force = Eigen::Vector3d::Zero();  // low-passed (InstrumentDesc::force_filter)
  Eigen::Vector3d filtered_torque = Eigen::Vector3d::Zero();
};

// Energies of the current configuration, J: what the elastic strain components store
// (½ Σ k_c Δqᵀ M Δq over elastic and Kelvin–Voigt components; viscous ones store none), the
// potential of the rod's weight (−Σ m_k g·r_k, zero at the origin) and what the springs of the
// connective tissue's intact anchors store.
struct Energy {
  double elastic = 0.0;
  double gravity = 0.0;
  double tissue = 0.0;
  [[nodiscard]] double total() const { return elastic + gravity + tissue; }
};

struct Event {
  // slipped: a grasp pulled past its holding force let go (the frame itself went well).
  // torn: anchors of connective tissue pulled past their strength let go (one event per range and
  // frame); cut: anchors cut by a host's call or an instrument (one per range and cut).
  enum class Kind : std::uint8_t { recovered, unstable, slipped, torn, cut };
  Kind kind = Kind::recovered;
  std::uint64_t frame = 0;
  std::size_t segment = 0;
  std::size_t node = 0;
  Stage stage = Stage::guard;
  int substeps = 1;
  // The message lives in place, so recording an event inside a step allocates nothing.
  std::array<char, 512> text{};
  [[nodiscard]] std::string_view message() const { return {text.data()}; }
};

// "recovered", "unstable", "slipped", "torn" or "cut".
[[nodiscard]] constexpr std::string_view event_kind_name(Event::Kind k) noexcept {
  switch (k) {
    case Event::Kind::recovered: return "recovered";
    case Event::Kind::unstable: return "unstable";
    case Event::Kind::slipped: return "slipped";
    case Event::Kind::torn: return "torn";
    case Event::Kind::cut: return "cut";
  }
  return "unknown";
}

}  // namespace haustra
