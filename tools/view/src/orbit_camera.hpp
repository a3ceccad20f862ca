#pragma once
// The viewer's camera: orbits a target (azimuth, elevation, distance; z up), pans and zooms like
// MuJoCo's viewer, and turns a pixel into a ray and a world point into a pixel.
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace haustra::view {

struct Ray {
  Eigen::Vector3d origin, direction;  // direction unit length
};

struct OrbitCamera {
  Eigen::Vector3d target = Eigen::Vector3d::Zero();
  double azimuth = -1.0;           // rad about +z, from +x
  double elevation = 0.45;         // rad above the horizon
  double distance = 1.5;           // m
  double fov_degrees = 35.0;       // vertical
  int width = 1280, height = 720;  // the viewport, pixels

  [[nodiscard]] Eigen::Vector3d eye() const;
  [[nodiscard]] Eigen::Vector3d forward() const;  // unit, from the eye to the target
  [[nodiscard]] Eigen::Matrix4f view_projection() const;
  // The ray through a pixel (window coordinates: x right, y down, pixel centres at +0.5).
  [[nodiscard]] Ray ray(double x, double y) const;
  // Where a world point lands in window coordinates.
  [[nodiscard]] Eigen::Vector2d project(const Eigen::Vector3d& p) const;

  void orbit(double dx_pixels, double dy_pixels);
  void pan(double dx_pixels, double dy_pixels);
  void zoom(double steps);  // > 0 closer
  // Frames a box from the current direction, within `free_width` pixels of the window's width (what
  // the panels leave; 0: all of it).
  void fit(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double free_width = 0.0);
};

// Where a ray meets the plane through `point` with `normal`; the origin when parallel.
[[nodiscard]] Eigen::Vector3d intersect_plane(const Ray& ray, const Eigen::Vector3d& point,
                                              const Eigen::Vector3d& normal);

}  // namespace haustra::view
