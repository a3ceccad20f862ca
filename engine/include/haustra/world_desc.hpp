#pragma once
// What a world is made of: plain, copyable descriptions filled by a scene file or by a host.
// Units are SI throughout (m, kg, s, N, Pa). Defaults are the paper's (Chang et al. 2011) where it
// gives one; docs/decisions/ explains the others.
#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <numbers>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace haustra {

// Index of a strain component in every 4-vector of strains.
enum StrainComponent : std::uint8_t { kappa1 = 0, kappa2 = 1, torsion = 2, axial = 3 };

enum class StrainLaw : std::uint8_t {
  elastic,       // k M (q − q̂) = R
  viscous,       // η M q̇ = R           (the paper's choice for bending and torsion)
  kelvin_voigt,  // k M (q − q̂) + η M q̇ = R
};

enum class BaseMode : std::uint8_t {
  clamped,  // node 0's pose is prescribed
  free,     // node 0 moves rigidly against a viscous drag of the whole rod
};

enum class InstabilityPolicy : std::uint8_t {
  stop,     // keep the last good frame and report the cause
  recover,  // redo the frame with Newton, then with more substeps, then stop
};

enum class SolverMode : std::uint8_t {
  lagged,  // the paper: R from the previous configuration, one tridiagonal solve. Fastest;
           // diverges when load stiffness dominates (tension, large loads, soft rods).
  newton,  // the implicit law solved by Newton on the block-tridiagonal mixed system, O(N).
  fast,    // Newton reusing its last factorization (a chord iteration: one scalar replay of the
           // sweep and a back-substitution) while the contacts touching and the attachments stay
           // as they were; contacts enter node by node. For haptic loops (decision 0037).
};

// A mode as the scene file names it (solver.mode).
[[nodiscard]] constexpr const char* solver_mode_name(SolverMode mode) noexcept {
  switch (mode) {
    case SolverMode::lagged: return "lagged";
    case SolverMode::newton: return "newton";
    case SolverMode::fast: return "fast";
  }
  return "?";
}

// How the tissue's elastic stress follows strain in bending and stretch (torsion stays Hooke's).
enum class TissueResponse : std::uint8_t {
  hooke,  // σ = E ε: the paper's simplification, constant stiffness
  exp2,   // σ = β(e^{αε²} − 1) + γε (Rosen et al., the paper's eq. 1), odd in ε; Newton only
};

struct MaterialDesc {
  double youngs_modulus = 33.2e3;  // Pa, the paper's fit to Rosen et al.
  double poisson_ratio = 0.35;     // the paper's
  double density = 1050.0;         // kg/m³, soft tissue
  TissueResponse response = TissueResponse::hooke;
  // EXP2 parameters. The paper gives none; the defaults are the illustrative fit of its Fig. 2
  // (γ = 20 kPa, α = 8, β such that E = 33.2 kPa is the least-squares line over 0–25 % strain).
  double exp2_alpha = 8.0;
  double exp2_beta = 6.7e3;    // Pa
  double exp2_gamma = 20.0e3;  // Pa
  // The axial strain at which the wall tears (Egorov et al. 2002: 1.4 for small, 1.8 for large
  // bowel, the smaller taken): a coupled grasp pulling its organ past it anywhere lets go, the
  // tissue torn out of its jaws (an event, decision 0096), where the pull would go on stretching it.
  double failure_strain = 1.4;
};

struct CrossSectionDesc {
  double radius = 0.02;           // m, centreline to the wall
  double wall_thickness = 0.003;  // m
};

enum class RestShapeKind : std::uint8_t {
  straight,         // a straight rod of `length` along the base tangent
  constant_strain,  // a circular arc or helix: constant (κ1, κ2, τ) over `length`
  centreline,       // a measured polyline (e.g. from CT), resampled to the nodes
};

struct RestShapeDesc {
  RestShapeKind kind = RestShapeKind::straight;
  double length = 1.66;                                         // m (straight, constant_strain)
  Eigen::Vector3d curvature_torsion = Eigen::Vector3d::Zero();  // (κ1, κ2, τ), 1/m
  std::vector<Eigen::Vector3d> centreline;                      // m (centreline)
  std::string centreline_source;                                // where it came from, for messages
};

struct AttachmentDesc {
  int node = -1;                          // negative counts from the tip: −1 is the tip
  bool hold_frame = false;                // also hold the node's orientation (a clamp rather than a pin)
  std::optional<Eigen::Vector3d> target;  // m; default: the node's initial position
  bool active = true;
};

struct PointLoadDesc {
  int node = -1;                                     // negative counts from the tip
  Eigen::Vector3d force = Eigen::Vector3d::Zero();   // N, world frame, constant direction
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();  // N·m, world frame
};

// A load per metre of rest length on the nodes from `from` to `to` (decision 0102), lumped onto
// them by their share of the rest length (half of each section beside them within the range).
struct DistributedLoadDesc {
  int from = 0;  // negative counts from the tip
  int to = -1;
  Eigen::Vector3d force = Eigen::Vector3d::Zero();   // N/m, world frame, constant direction
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();  // N·m/m, world frame
};

// Connective tissue over a range of the organ (decision 0095): an anchor on every node of the range,
// a spring with slack and a damper from the node to where the anatomy holds it — its rest place,
// or the nearest point of a root line (the mesentery's root on the posterior wall) — torn when its
// tension passes its strength. Per length of organ, so the anchors of a finer rod hold alike.
enum class AnchorTarget : std::uint8_t {
  rest,  // where the node rests: the support of the mesentery, the peritoneum and the organs around
  root,  // the nearest point of `root` (a polyline), slack beyond the rest distance: a tether
};

struct AnchorsDesc {
  std::string name = "tissue";  // for events and the viewer
  double from = 0.0, to = 1.0;  // fractions of the rod's rest length (a chain's: of the whole chain)
  AnchorTarget target = AnchorTarget::rest;
  std::vector<Eigen::Vector3d> root;  // m, two points or more (target = root)
  // The tether (the mesentery, the peritoneal attachments; decision 0095 for the defaults: porcine
  // mesentery, White et al. 2018, as a sheet ~1 mm thick in its toe region): pulls the node back
  // from any side, and holds its frame (× the tube's radius²).
  double stiffness = 1000.0;  // N/m per metre of organ (N/m²)
  double damping = 50.0;      // N·s/m per metre of organ (N·s/m²), on the node's velocity
  double slack = 0.0;         // m of free play before the spring pulls (beyond the rest distance)
  double strength = 1000.0;   // N per metre of organ: an anchor tears past this times its length; 0: never
  // The support (the organs and the wall below): against sinking along gravity only, so the organ
  // rests on it and a grasper lifts it freely. 0: none (the tether alone carries the weight).
  double support = 0.0;  // N/m per metre of organ (N/m²)
};

// Beads: rigid spheres centred on chosen nodes, for collision (the paper: 55 beads on 167 nodes).
// Choose the nodes by count (spread evenly by node index, both ends included), by spacing along
// the rest length, or by an explicit list; give the radius as a constant or a profile along the rod.
struct BeadsDesc {
  bool enabled = false;
  int count = 0;           // beads spread evenly over the nodes
  double spacing = 0.0;    // m of rest arc length between beads (first and last node included)
  std::vector<int> nodes;  // explicit node indices (negative counts from the tip)
  double radius = 0.0;     // m; 0: the segment's cross-section radius
  std::vector<std::pair<double, double>> radius_profile;  // (fraction of the length, radius in m)
  // Each bead as wide as the organ mesh's cross-section at its node (the median distance from the
  // node to the mesh wall over a ring of rays in the node's normal plane). Needs a mesh.
  bool radius_from_mesh = false;
};

// A procedural organ: a closed tube around the rod's rest centreline, with regular haustral bulges
// between semilunar folds and the three taeniae coli (longitudinal bands) pulling the wall in.
struct ProceduralOrganDesc {
  int vertices = 10'000;          // about this many (1,000 to 1,000,000)
  double radius = 0.0;            // m, mean wall radius; 0: the segment's radius
  double haustra_spacing = 0.03;  // m between folds; 0: no haustra
  double haustra_depth = 0.15;    // fraction of the radius a fold pulls in
  double taenia_depth = 0.08;     // fraction of the radius a taenia pulls in; 0: none
  double end_taper = 0.25;        // the caps: fraction of the radius the tube rounds off over
};

enum class MeshSource : std::uint8_t { procedural, file };
// The skin a user chooses (decision 0120): cost against accuracy, measured in docs/skinning.md
// ("Choosing a skin").
enum class SkinningMethod : std::uint8_t {
  cage,          // the paper's cage, mean value coordinates localized by decision 0048's rule
  linear_blend,  // linear-blend skinning on the bead frames (for comparison: the collapsing joint)
  along_rod,     // each vertex on the rod's own frames either side of its place along the rod (decision 0117)
  cage_full,     // the cage with every ring (full mean value coordinates: the exact reference)
};

// The cage around the organ mesh (the paper's §6): a bead template ring on every bead, a middle
// template ring halfway between beads, each of `ring_vertices` vertices pushed out until the mesh
// is embedded; capped ends.
// How each mesh vertex finds its place along the rod in the binding pose (decision 0049).
enum class CageBinding : std::uint8_t {
  automatic,  // harmonic for a mesh from a file, closest for a procedural one (made around the rod)
  closest,    // the closest point of the rest centreline (neighbours' median where it jumps)
  harmonic,   // from a harmonic function on the mesh's surface: smooth, never folds where loops touch
};

struct CageDesc {
  int ring_vertices = 8;
  CageBinding binding = CageBinding::automatic;
  bool middle_rings = true;
  double clearance = 0.0;   // m between the mesh and the cage; 0: 5 % of the segment radius
  int max_iterations = 40;  // inflation passes
};

// The detailed organ mesh a segment drives, at the rod's rest pose.
struct OrganMeshDesc {
  bool enabled = false;
  MeshSource source = MeshSource::procedural;
  ProceduralOrganDesc procedural;
  std::string file;                                     // any format assimp reads
  double scale = 1.0;                                   // file units to metres (0.001 for millimetres)
  Eigen::Vector3d translate = Eigen::Vector3d::Zero();  // m, after scaling
  CageDesc cage;
  SkinningMethod skinning = SkinningMethod::along_rod;  // the default since decision 0120
  bool normals = true;                                  // per-vertex normals every frame
};

struct SegmentDesc {
  std::string name = "segment";
  int nodes = 167;  // N+1; the paper's count
  RestShapeDesc rest;
  Eigen::Vector3d base_position = Eigen::Vector3d::Zero();  // node 0 (straight, constant_strain)
  Eigen::Vector3d base_tangent = Eigen::Vector3d::UnitX();  // d3 at node 0
  Eigen::Vector3d base_normal = Eigen::Vector3d::UnitZ();   // hint for d1 at node 0
  MaterialDesc material;
  CrossSectionDesc cross_section;
  std::optional<double> linear_density;  // kg/m; default: density × wall cross-section
  // Law per component (κ1, κ2, τ, ε); the paper: viscous bending and torsion, elastic axial.
  std::array<StrainLaw, 4> law = {StrainLaw::viscous, StrainLaw::viscous, StrainLaw::viscous, StrainLaw::elastic};
  double relaxation_time = 1.0;  // s; η_c = k_c × relaxation_time (the paper uses 1 s)
  BaseMode base = BaseMode::clamped;
  // N·s/m²: viscous drag of the surrounding medium per metre of rod (f = −c v on every node).
  // It is what moves a free base; default 4 for a free base (a 0.4 kg/m rod falls at ~1 m/s),
  // 0 for a clamped one.
  std::optional<double> drag;
  std::vector<AttachmentDesc> attachments;
  std::vector<AnchorsDesc> anchors;  // connective tissue, by ranges along the organ
  std::vector<PointLoadDesc> loads;
  std::vector<DistributedLoadDesc> distributed_loads;  // [[segment.distributed_load]]
  BeadsDesc beads;
  OrganMeshDesc mesh;
  // Chained end to end (docs/decisions/0030-chains-as-one-rod.md): above 1, the rod runs as this
  // many segments "<name>-1" .. "<name>-K", each of `nodes` nodes and `beads`, with its own
  // procedural mesh; the tip node of one is the base node of the next (position and frame), and
  // the chain's Newton system is solved as one. The rest shape and `rest.length` cover the whole
  // chain; attachments' and loads' node indices count along the whole chain (K·(nodes−1)+1 nodes).
  int chain_pieces = 1;
};

enum class BroadPhase : std::uint8_t { automatic, brute, grid };

// Which pairs of beads that overlap or touch in the rest pose never collide: those of one segment
// (its own folds, as built), or any two (organs imported from one body touch where the segmentation
// has them touch — the ileum at its valve, loops lying on each other — and do not push apart at
// rest: decision 0094).
enum class RestExclusions : std::uint8_t { segment, world };

// The paper's penalty response (eq. 13), f = coefficient × E × depth^exponent, along the
// separating direction; E is the bead's tissue (the harmonic mean for two tissues).
struct ContactDesc {
  double coefficient = 50.0;
  double exponent = 2.0;
  double margin = -1.0;  // m: candidates within r_a + r_b + margin; < 0: half the smallest bead radius
  BroadPhase broad_phase = BroadPhase::automatic;  // brute below 256 beads, else the grid
  bool self = true;                                // beads of one segment collide (except pairs touching at rest)
  RestExclusions rest_exclusions = RestExclusions::segment;
};

struct PlaneDesc {
  std::string name;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // the free side
};

struct SphereObstacleDesc {
  std::string name;
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  double radius = 0.1;
};

struct CapsuleObstacleDesc {
  std::string name;
  Eigen::Vector3d a = Eigen::Vector3d::Zero(), b = Eigen::Vector3d::UnitX();
  double radius = 0.05;
};

// A static triangle mesh (another organ, the pelvis), queried through Embree.
struct MeshObstacleDesc {
  std::string name;
  std::string source;                     // file it came from, for messages
  std::vector<Eigen::Vector3d> vertices;  // m
  std::vector<std::array<std::uint32_t, 3>> triangles;
  // A container (the body's boundary, a cavity) keeps beads inside it: a bead touches when its
  // centre is within its radius of the surface from inside, or anywhere outside, and is pushed
  // inward. It must be closed (decision 0093). false: an obstacle that keeps beads out.
  bool container = false;
};

// One obstacle, for World::add_obstacle; its kind is the alternative it holds.
enum class ObstacleKind : std::uint8_t { plane, sphere, capsule, mesh };
using ObstacleDesc = std::variant<PlaneDesc, SphereObstacleDesc, CapsuleObstacleDesc, MeshObstacleDesc>;

struct EnvironmentDesc {
  std::vector<PlaneDesc> planes;
  std::vector<SphereObstacleDesc> spheres;
  std::vector<CapsuleObstacleDesc> capsules;
  std::vector<MeshObstacleDesc> meshes;
};

struct InstrumentKeyframe {
  double time = 0.0;                                // s
  Eigen::Vector3d tip = Eigen::Vector3d::Zero();    // m
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  // from the tip towards the handle
  bool grasp = false;                               // jaws closed from this keyframe on
  bool cut = false;  // cutting from this keyframe on: connective tissue within cut_radius of the tip
};

// A kinematic capsule (grasper, retractor) from its tip back along its axis. It pushes tissue by
// contact; closing it within reach of a bead attaches that bead's node until it opens. Its pose
// follows the keyframes (position and axis linear, the axis renormalized; grasp stepwise) until a host sets
// it through the API.
struct InstrumentDesc {
  std::string name = "instrument";
  double radius = 0.004;      // m
  double length = 0.3;        // m
  double grasp_reach = 0.01;  // m beyond a bead's surface within which closing grasps it
  bool hold_frame = false;    // a grasp holds the node's orientation too
  double force_filter = 0.0;  // s: time constant of the low-pass filter on the reported force; 0 = none
  // The virtual coupling (decision 0057): a grasped node follows the grasp point through a spring
  // and a damper whose force saturates at force_limit, inside the frame's implicit solve; the force
  // reported is the coupling's. coupling_stiffness = 0: a rigid grasp (a constraint, hold_frame
  // honoured), as before the coupling.
  double coupling_stiffness = 1000.0;  // N/m
  // The instrument as a proxy (decision 0096, haptic rendering's god-object): its capsule is not
  // where it is commanded but where the same capped spring–damper from the commanded pose balances
  // what the capsule meets (beads, the floor, walls, obstacles); the force reported for it — the
  // grasp's and the capsule's together — never exceeds force_limit. false (or a rigid grasp,
  // coupling_stiffness = 0): a kinematic capsule at the commanded pose, its contacts unbounded.
  bool proxy = true;
  double coupling_damping = 2.0;  // N·s/m, on the node's velocity relative to the grasp point's
  double force_limit = 8.0;       // N
  // A grasp pulled harder than this lets go (the tissue slips out of the jaws: an event, decision
  // 0058); 0 (the default): it never slips, the force limit alone bounds the pull. Closing again
  // grasps anew.
  double holding_force = 0.0;  // N
  // Dissection (decision 0095): while cutting, the anchors of connective tissue that pass within this
  // distance of the tip are cut, with an event (a keyframe's `cut`, or the host's call).
  double cut_radius = 0.005;  // m
  Eigen::Vector3d tip = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  std::vector<InstrumentKeyframe> keyframes;
};

struct SolverDesc {
  SolverMode mode = SolverMode::newton;
  int iterations = 1;       // per substep: fixed-point (lagged) or Newton iterations
  int substeps = 1;         // per frame
  double relaxation = 1.0;  // ω in (0, 1]: q ← q + ω (q* − q)
  double tolerance = 0.0;   // stop iterating when the largest strain change × h is below this
  // Newton only: past `iterations`, a segment keeps iterating, up to this many in all, while the
  // contact line search cut its last step short or an active attachment misses its target by more
  // than kAttachmentTolerance (1 µm). A grasp that starts to pull or a contact that opens then
  // converges within the frame; steady frames and rods without contacts or attachments pay nothing.
  // (How close is close enough, how old fast mode's factorization may grow, and the guard's limits
  // other than max_displacement are the model's constants: decision 0108.)
  int max_iterations = 8;
  InstabilityPolicy on_instability = InstabilityPolicy::recover;
  // What a frame may cost (decision 0100): the robust mode's ladder climbs no higher than
  // max_substeps and redoes a frame at most max_retries times (a frame it cannot hold within them
  // stops as unstable); a rung it climbed to is kept for a calm spell, then halved: 8 frames, twice
  // that each time a rung is needed again within calm_frames calm frames, at most calm_frames (0109).
  int max_substeps = 64;
  int max_retries = 16;
  int calm_frames = 120;
  // The guard, checked at the end of every frame: no node may move more than this many segment
  // lengths in one frame. A model without inertia may jump to a new equilibrium within a frame, so
  // this only catches runaways, not fast motion.
  double max_displacement = 4.0;
};

struct FilterDesc {
  bool enabled = true;
  double zeta_scale = 1.0;  // ζ = zeta_scale × π / (16 EA), the paper's regulator
};

// A host's own job system, used instead of oneTBB to run a step's parallel stages
// (docs/decisions/0027-host-job-system.md). A stage hands over a batch of ranges with enqueue and
// then calls wait once; the host runs each range's task on whichever of its threads it likes. Every
// index writes its own slice of the state, so the results are the same bits as with oneTBB or one
// thread. The task never throws. Both callbacks are called from the thread that steps the world.
struct JobSystemDesc {
  using Task = void (*)(void* task_data, std::size_t first, std::size_t last);
  void (*enqueue)(void* host, Task task, void* task_data, std::size_t first, std::size_t last) = nullptr;
  void (*wait)(void* host) = nullptr;  // returns once every range enqueued since the last wait has run
  void* host = nullptr;
  int workers = 2;  // how many ranges a batch is split into (the host's worker count)
  [[nodiscard]] bool enabled() const { return enqueue != nullptr; }
};

// When the organ meshes follow the rod (decision 0060): when a reader asks for them (the mesh
// accessors, a FramePublisher's reader in its own thread), or at the end of every step as before.
enum class MeshUpdate : std::uint8_t { on_read, every_frame };

// Rods at rest and untouched sleep (issue 40, decision 0119): a rod whose every node moved less than
// `speed` × dt a frame for `time` seconds is no longer solved — it is held where it is, a fixed
// body for the others — until a moving rod or an instrument comes within the contact margin of its
// beads, an instrument grasps it, one of its anchors tears, or the host changes the world.
//
// ranges (decision 0127): a rod's base-side range at rest sleeps too while the rest of the rod
// moves — held where it is, the moving range clamped to its last node — in the Newton and fast
// modes (the lagged scheme solves a rod whole). Woken node by node: a moving node wakes its
// neighbours within kRangeBand nodes, a contact, grasp or torn anchor the nodes around it.
struct SleepDesc {
  bool enabled = false;
  double speed = 1e-3;  // m/s: slower than this a node is at rest
  double time = 0.1;    // s at rest before the rod sleeps
  bool ranges = false;  // also ranges within a rod (needs enabled and solver.mode newton or fast)
};

struct WorldDesc {
  Eigen::Vector3d gravity{0.0, 0.0, -9.81};
  double dt = 1.0 / 60.0;
  SolverDesc solver;
  FilterDesc filter;
  int threads = 0;  // 0: all hardware threads
  // Bytes the world may take (its estimate, decision 0038); 0: what the machine has available.
  double memory_limit = 0.0;
  MeshUpdate mesh_update = MeshUpdate::on_read;
  // Seconds a frame may take (a haptic loop's deadline, decision 0061): a frame over it is counted in
  // its profile (`late`). 0: no budget.
  double frame_budget = 0.0;
  JobSystemDesc jobs;  // when set, the step's parallel stages run on the host's jobs, not oneTBB
  SleepDesc sleep;
  std::vector<SegmentDesc> segments;
  ContactDesc contact;
  EnvironmentDesc environment;
  std::vector<InstrumentDesc> instruments;
};

}  // namespace haustra
