#include "embree_scene.hpp"

#include <fmt/format.h>

#include <oneapi/tbb/task_arena.h>

#include "haustra/error.hpp"

namespace haustra::detail {
namespace {

void check(RTCDevice device, const char* what) {
  const RTCError e = rtcGetDeviceError(device);
  if (e != RTC_ERROR_NONE) throw Error(ErrorCode::internal, fmt::format("Embree: {} failed (error {})", what, static_cast<int>(e)));
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
  const unsigned id = geometries_++;
  rtcAttachGeometryByID(scene_, geom, id);
  rtcReleaseGeometry(geom);
  check(device_, "adding a triangle mesh");
  return id;
}

void EmbreeScene::commit() {
  tbb::task_arena one_thread(1);
  one_thread.execute([&] { rtcCommitScene(scene_); });
  check(device_, "building the scene");
}

}  // namespace haustra::detail
