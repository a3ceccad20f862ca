// Embree scenes of triangle meshes: ray casts and closest points for the cage builder, static obstacles and
// the renderer.
#include "haustra/embree_scene.hpp"

#include <embree3/rtcore.h>

#include <fmt/format.h>

#include <cmath>
#include <limits>

#include <oneapi/tbb/task_arena.h>

#include "haustra/error.hpp"
#include "haustra/kernels/contact_geometry.hpp"

namespace haustra {
namespace {

void check(RTCDevice device, const char* what) {
  const RTCError e = rtcGetDeviceError(device);
  if (e != RTC_ERROR_NONE)
    throw Error(ErrorCode::internal, fmt::format("Embree: {} failed (error {})", what, static_cast<int>(e)));
}

}  // namespace

EmbreeScene::EmbreeScene() {
  device_ = rtcNewDevice(nullptr);
  if (device_ == nullptr) throw Error(ErrorCode::internal, "Embree: cannot create a device");
  scene_ = rtcNewScene(device_);
  rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_HIGH);
  check(device_, "creating a scene");
}

EmbreeScene::~EmbreeScene() {
  if (scene_ != nullptr) rtcReleaseScene(scene_);
  if (device_ != nullptr) rtcReleaseDevice(device_);
}

unsigned EmbreeScene::add_triangles(std::span<const Eigen::Vector3d> vertices,
                                    std::span<const std::array<std::uint32_t, 3>> triangles) {
  RTCGeometry geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vb = static_cast<float*>(
      rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), vertices.size()));
  auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                            3 * sizeof(unsigned), triangles.size()));
  if (vb == nullptr || ib == nullptr) {
    rtcReleaseGeometry(geom);
    check(device_, "allocating a triangle mesh");
    throw Error(ErrorCode::internal, "Embree: cannot allocate a triangle mesh");
  }
  for (std::size_t v = 0; v < vertices.size(); ++v)
    for (int i = 0; i < 3; ++i) vb[3 * v + static_cast<std::size_t>(i)] = static_cast<float>(vertices[v][i]);
  for (std::size_t t = 0; t < triangles.size(); ++t)
    for (std::size_t i = 0; i < 3; ++i) ib[3 * t + i] = triangles[t][i];
  rtcCommitGeometry(geom);
  meshes_.push_back({std::vector<Eigen::Vector3d>(vertices.begin(), vertices.end()),
                     std::vector<std::array<std::uint32_t, 3>>(triangles.begin(), triangles.end())});
  const unsigned id = geometries_++;
  rtcAttachGeometryByID(scene_, geom, id);
  rtcReleaseGeometry(geom);
  check(device_, "adding a triangle mesh");
  return id;
}

EmbreeScene::Hit EmbreeScene::first_hit(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_near,
                                        double t_far) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh{};
  rh.ray.org_x = static_cast<float>(origin.x());
  rh.ray.org_y = static_cast<float>(origin.y());
  rh.ray.org_z = static_cast<float>(origin.z());
  rh.ray.dir_x = static_cast<float>(direction.x());
  rh.ray.dir_y = static_cast<float>(direction.y());
  rh.ray.dir_z = static_cast<float>(direction.z());
  rh.ray.tnear = static_cast<float>(t_near);
  rh.ray.tfar = std::isfinite(t_far) ? static_cast<float>(t_far) : std::numeric_limits<float>::infinity();
  rh.ray.mask = 0xFFFFFFFFU;
  rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(scene_, &context, &rh);
  Hit h;
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return h;
  h.found = true;
  h.geometry = rh.hit.geomID;
  h.triangle = rh.hit.primID;
  h.distance = rh.ray.tfar;
  h.u = rh.hit.u;
  h.v = rh.hit.v;
  return h;
}

int EmbreeScene::winding(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) const {
  int count = 0;
  double t = 0.0;
  const Eigen::Vector3d dir = direction.normalized();
  // Step past each hit by a little more than float rounding of the coordinates.
  const double step = 64.0 * std::numeric_limits<float>::epsilon() * (1.0 + origin.cwiseAbs().maxCoeff());
  for (int guard = 0; guard < 4096; ++guard) {
    const Hit h = first_hit(origin, dir, t, std::numeric_limits<double>::infinity());
    if (!h.found) break;
    const Mesh& mesh = meshes_[h.geometry];
    const auto& tri = mesh.triangles[h.triangle];
    const Eigen::Vector3d n =
        (mesh.vertices[tri[1]] - mesh.vertices[tri[0]]).cross(mesh.vertices[tri[2]] - mesh.vertices[tri[0]]);
    count += n.dot(dir) > 0.0 ? 1 : -1;
    t = h.distance + step;
  }
  return count;
}

bool EmbreeScene::inside(const Eigen::Vector3d& p) const {
  static const Eigen::Vector3d directions[3] = {Eigen::Vector3d(0.5773, 0.6124, 0.5403).normalized(),
                                                Eigen::Vector3d(-0.7071, 0.1234, -0.6963).normalized(),
                                                Eigen::Vector3d(0.2113, -0.9412, 0.2638).normalized()};
  int votes = 0;
  for (const auto& d : directions) votes += winding(p, d) >= 1 ? 1 : 0;
  return votes >= 2;
}

struct EmbreeScene::ClosestQuery {
  const EmbreeScene* self = nullptr;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Hit best;
};

bool EmbreeScene::on_closest(RTCPointQueryFunctionArguments* args) {
  auto* q = static_cast<ClosestQuery*>(args->userPtr);
  const Mesh& mesh = q->self->meshes_[args->geomID];
  const auto& t = mesh.triangles[args->primID];
  const Eigen::Vector3d c =
      kernels::closest_point_on_triangle(q->p, mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]]);
  const double d = (q->p - c).norm();
  if (d >= q->best.distance) return false;
  q->best = {true, args->geomID, args->primID, d, 0.0, 0.0};
  // Embree culls in float: pad the shrinking radius by float rounding so nothing nearer is lost.
  const double pad = 8.0 * std::numeric_limits<float>::epsilon() * (q->p.cwiseAbs().maxCoeff() + d);
  args->query->radius = std::nextafter(static_cast<float>(d + pad), std::numeric_limits<float>::infinity());
  return true;
}

EmbreeScene::Hit EmbreeScene::closest(const Eigen::Vector3d& p, double radius) const {
  ClosestQuery q;
  q.self = this;
  q.p = p;
  q.best.distance = radius;
  RTCPointQuery query;
  query.x = static_cast<float>(p.x());
  query.y = static_cast<float>(p.y());
  query.z = static_cast<float>(p.z());
  query.radius = static_cast<float>(radius);
  query.time = 0.0f;
  RTCPointQueryContext context;
  rtcInitPointQueryContext(&context);
  rtcPointQuery(scene_, &query, &context, &EmbreeScene::on_closest, &q);
  return q.best;
}

void EmbreeScene::commit() {
  tbb::task_arena one_thread(1);
  one_thread.execute([&] { rtcCommitScene(scene_); });
  check(device_, "building the scene");
}

}  // namespace haustra
