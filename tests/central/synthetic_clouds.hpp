#pragma once
// Synthetic room clouds for the central tests and bench_merge: a 6 x 5 x 3 m room (floor, ceiling, four
// walls) with three boxes standing on the floor, one of them in the middle so that a cloud cut to a band
// of x still constrains all six degrees of freedom. Points are spread over the surfaces by area, with
// Gaussian noise, coloured per surface, from one seeded generator.

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "fleetslam/core/point_cloud.hpp"

namespace fleetslam::central::synthetic {

// Points origin + a u + b v for a, b in [0, 1].
struct Rect {
  Eigen::Vector3f origin;
  Eigen::Vector3f u;
  Eigen::Vector3f v;
  float area() const { return u.cross(v).norm(); }
};

// The five visible faces of a box standing on the floor.
inline void add_box(std::vector<Rect>& rects, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi) {
  const Eigen::Vector3f size = hi - lo;
  const Eigen::Vector3f x(size.x(), 0, 0), y(0, size.y(), 0), z(0, 0, size.z());
  rects.push_back({Eigen::Vector3f(lo.x(), lo.y(), hi.z()), x, y});  // top
  rects.push_back({lo, x, z});
  rects.push_back({lo + y, x, z});
  rects.push_back({lo, y, z});
  rects.push_back({lo + x, y, z});
}

inline std::vector<Rect> room_surfaces() {
  const float X = 6.0f, Y = 5.0f, Z = 3.0f;
  std::vector<Rect> rects = {
      {{0, 0, 0}, {X, 0, 0}, {0, Y, 0}},  // floor
      {{0, 0, Z}, {X, 0, 0}, {0, Y, 0}},  // ceiling
      {{0, 0, 0}, {0, Y, 0}, {0, 0, Z}},  // wall x = 0
      {{X, 0, 0}, {0, Y, 0}, {0, 0, Z}},  // wall x = 6
      {{0, 0, 0}, {X, 0, 0}, {0, 0, Z}},  // wall y = 0
      {{0, Y, 0}, {X, 0, 0}, {0, 0, Z}},  // wall y = 5
  };
  add_box(rects, {1.0f, 1.0f, 0.0f}, {2.0f, 1.8f, 0.8f});   // table
  add_box(rects, {2.6f, 2.0f, 0.0f}, {3.4f, 2.6f, 1.2f});   // crate in the middle
  add_box(rects, {4.5f, 3.8f, 0.0f}, {5.5f, 4.6f, 1.8f});   // cabinet
  return rects;
}

// n points spread over the rects by area, one seeded generator: a drawn point p on rect s is kept when
// accept(s, p); then add(cloud, s, p, p + noise) (noise sigma noise_m per axis) adds it.
template <class Accept, class Add>
core::PointCloud sample_surfaces(const std::vector<Rect>& rects, std::size_t n, float noise_m, std::uint32_t seed,
                                 Accept accept, Add add) {
  std::vector<float> areas;
  for (const Rect& r : rects) areas.push_back(r.area());
  std::mt19937 rng(seed);
  std::discrete_distribution<std::size_t> pick(areas.begin(), areas.end());
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::normal_distribution<float> noise(0.0f, noise_m);
  core::PointCloud cloud;
  cloud.reserve(n);
  while (cloud.size() < n) {
    const std::size_t s = pick(rng);
    const Rect& r = rects[s];
    const Eigen::Vector3f p = r.origin + unit(rng) * r.u + unit(rng) * r.v;
    if (!accept(s, p)) continue;
    const Eigen::Vector3f jitter(noise(rng), noise(rng), noise(rng));
    add(cloud, s, p, p + jitter);
  }
  return cloud;
}

// n points on the room's surfaces with x in [x_min, x_max], noise sigma noise_m per axis.
inline core::PointCloud room_cloud(std::size_t n, float x_min, float x_max, float noise_m, std::uint32_t seed) {
  return sample_surfaces(
      room_surfaces(), n, noise_m, seed, [&](std::size_t, const Eigen::Vector3f& p) { return p.x() >= x_min && p.x() <= x_max; },
      [](core::PointCloud& cloud, std::size_t s, const Eigen::Vector3f&, const Eigen::Vector3f& noisy) {
        const auto shade = static_cast<std::uint8_t>(40 + 13 * s);
        cloud.push_back(noisy, {shade, static_cast<std::uint8_t>(255 - shade), static_cast<std::uint8_t>(7 * s)});
      });
}

// Two 5 x 3 m rooms side by side along x, parted by a 12 cm wall (x in [2.94, 3.06]) with a 1 m doorway
// (y in [2, 3], up to 2.1 m), a box in each room. The wall's two faces are 12 cm apart and face opposite
// ways: a robot in one room sees only its own face.
inline std::vector<Rect> two_room_surfaces() {
  const float Y = 5.0f, Z = 3.0f, a = 2.94f, b = 3.06f, door_lo = 2.0f, door_hi = 3.0f, door_z = 2.1f;
  std::vector<Rect> rects = {
      {{0, 0, 0}, {6, 0, 0}, {0, Y, 0}},  // floor
      {{0, 0, Z}, {6, 0, 0}, {0, Y, 0}},  // ceiling
      {{0, 0, 0}, {0, Y, 0}, {0, 0, Z}},  // wall x = 0
      {{6, 0, 0}, {0, Y, 0}, {0, 0, Z}},  // wall x = 6
      {{0, 0, 0}, {a, 0, 0}, {0, 0, Z}},  // walls y = 0 and y = 5 of both rooms
      {{0, Y, 0}, {a, 0, 0}, {0, 0, Z}},
      {{b, 0, 0}, {6 - b, 0, 0}, {0, 0, Z}},
      {{b, Y, 0}, {6 - b, 0, 0}, {0, 0, Z}},
  };
  for (const float x : {a, b}) {  // the parting wall's two faces, around the doorway
    rects.push_back({{x, 0, 0}, {0, door_lo, 0}, {0, 0, Z}});
    rects.push_back({{x, door_hi, 0}, {0, Y - door_hi, 0}, {0, 0, Z}});
    rects.push_back({{x, door_lo, door_z}, {0, door_hi - door_lo, 0}, {0, 0, Z - door_z}});
  }
  rects.push_back({{a, door_lo, 0}, {b - a, 0, 0}, {0, 0, door_z}});  // door jambs and head
  rects.push_back({{a, door_hi, 0}, {b - a, 0, 0}, {0, 0, door_z}});
  rects.push_back({{a, door_lo, door_z}, {b - a, 0, 0}, {0, door_hi - door_lo, 0}});
  add_box(rects, {0.8f, 0.6f, 0.0f}, {1.8f, 1.4f, 0.9f});
  add_box(rects, {4.2f, 3.4f, 0.0f}, {5.2f, 4.4f, 1.4f});
  return rects;
}

// n points of the two rooms that a sensor at `eye` sees: surfaces in its room or through the doorway (no
// other occlusion), Gaussian noise noise_m per axis, each with its surface's normal turned towards the eye.
inline core::PointCloud two_room_cloud(std::size_t n, const Eigen::Vector3f& eye, float noise_m, std::uint32_t seed) {
  const std::vector<Rect> rects = two_room_surfaces();
  const bool eye_left = eye.x() < 3.0f;
  const auto seen = [&](std::size_t, const Eigen::Vector3f& p) {
    const bool p_left = p.x() < 2.94f + 1e-4f;
    const bool p_right = p.x() > 3.06f - 1e-4f;
    if ((eye_left && p_right) || (!eye_left && p_left)) {  // the other room: only through the doorway
      const float s = (3.0f - eye.x()) / (p.x() - eye.x());
      const Eigen::Vector3f through = eye + s * (p - eye);
      if (through.y() < 2.0f || through.y() > 3.0f || through.z() > 2.1f) return false;
    }
    // A face of the parting wall is seen from its own side only.
    if (std::abs(p.x() - 2.94f) < 1e-4f && !eye_left) return false;
    return !(std::abs(p.x() - 3.06f) < 1e-4f && eye_left);
  };
  return sample_surfaces(rects, n, noise_m, seed, seen,
                         [&](core::PointCloud& cloud, std::size_t s, const Eigen::Vector3f& p, const Eigen::Vector3f& noisy) {
                           Eigen::Vector3f normal = rects[s].u.cross(rects[s].v).normalized();
                           if (normal.dot(eye - p) < 0.0f) normal = -normal;
                           cloud.push_back(noisy, {128, 128, 128}, normal);
                         });
}

// Rotation by roll/pitch/yaw (degrees, applied z-y-x) and a translation.
inline Eigen::Isometry3d pose(double roll_deg, double pitch_deg, double yaw_deg, const Eigen::Vector3d& t) {
  constexpr double kRad = 3.14159265358979323846 / 180.0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(yaw_deg * kRad, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(pitch_deg * kRad, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(roll_deg * kRad, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = t;
  return T;
}

// A prior error of 10 cm and 5 degrees about a tilted axis (the wrong prior).
inline Eigen::Isometry3d prior_error() {
  Eigen::Isometry3d E = Eigen::Isometry3d::Identity();
  E.linear() = Eigen::AngleAxisd(5.0 * 3.14159265358979323846 / 180.0, Eigen::Vector3d(0.3, -0.2, 1.0).normalized())
                   .toRotationMatrix();
  E.translation() = Eigen::Vector3d(0.06, -0.05, 0.06).normalized() * 0.10;
  return E;
}

// Translation (m) and rotation (rad) of the difference between two poses.
inline std::pair<double, double> pose_error(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  const Eigen::Isometry3d d = a.inverse() * b;
  return {d.translation().norm(), Eigen::AngleAxisd(d.linear()).angle()};
}

}  // namespace fleetslam::central::synthetic
