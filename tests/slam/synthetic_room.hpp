#pragma once
// A synthetic RGB-D / stereo sequence without the simulator: a closed box room whose six walls carry
// seeded random textures, rendered by ray casting each pixel of a distortion-free pinhole camera (exact
// metric depth along z, bilinear texture lookup), along a smooth known trajectory.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "fleetslam/core/camera.hpp"
#include "fleetslam/core/se3.hpp"
#include "fleetslam/core/sensor_frame.hpp"
#include "fleetslam/core/sensor_rig.hpp"
#include "fleetslam/core/time.hpp"

namespace fleetslam::slam::test {

// Overlapping shapes of random gray levels and log-uniform sizes on a mid-gray background, slightly
// blurred: corners at every scale, the same for the same seed.
inline cv::Mat wall_texture(int width, int height, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  cv::Mat image(height, width, CV_8UC1, cv::Scalar(128));
  const int shapes = width * height / 250;
  for (int i = 0; i < shapes; ++i) {
    const int half = static_cast<int>(2.0 * std::pow(45.0 / 2.0, unit(rng))) + 1;
    const cv::Point centre(static_cast<int>(unit(rng) * width), static_cast<int>(unit(rng) * height));
    const cv::Scalar gray(20.0 + 215.0 * unit(rng));
    if (unit(rng) < 0.5) {
      cv::rectangle(image, centre - cv::Point(half, half / 2), centre + cv::Point(half, half), gray, cv::FILLED);
    } else {
      cv::ellipse(image, centre, cv::Size(half, half / 2 + 1), unit(rng) * 180.0, 0.0, 360.0, gray, cv::FILLED);
    }
  }
  cv::GaussianBlur(image, image, cv::Size(0, 0), 0.8);
  return image;
}

class SyntheticRoom {
 public:
  // Room [min, max] in world coordinates (metres); texel size in metres. With repeat_z_m > 0 every
  // surface's texture repeats along z with that period (a corridor of identical bays: perceptual aliasing).
  SyntheticRoom(Eigen::Vector3d min, Eigen::Vector3d max, std::uint32_t seed, double texel_m = 0.004,
                double repeat_z_m = 0.0)
      : min_(std::move(min)), max_(std::move(max)), texel_m_(texel_m), repeat_z_m_(repeat_z_m) {
    for (int wall = 0; wall < 6; ++wall) {
      const int axis = wall / 2;
      const int a = (axis + 1) % 3, b = (axis + 2) % 3;
      const auto extent = [&](int k) { return k == 2 && repeat_z_m_ > 0.0 ? repeat_z_m_ : max_[k] - min_[k]; };
      const int w = static_cast<int>(std::ceil(extent(a) / texel_m)) + 2;
      const int h = static_cast<int>(std::ceil(extent(b) / texel_m)) + 2;
      textures_[static_cast<std::size_t>(wall)] = wall_texture(w, h, seed + static_cast<std::uint32_t>(wall) * 7919u);
    }
  }

  // Gray image (CV_8UC1) and metric depth (CV_32FC1) seen by `camera` (distortion ignored) at T_world_cam.
  void render(const core::PinholeCamera& camera, const Eigen::Isometry3d& T_world_cam, cv::Mat& gray,
              cv::Mat& depth_m) const {
    gray.create(camera.height(), camera.width(), CV_8UC1);
    depth_m.create(camera.height(), camera.width(), CV_32FC1);
    const Eigen::Matrix3d R = T_world_cam.linear();
    const Eigen::Vector3d c = T_world_cam.translation();
    for (int v = 0; v < camera.height(); ++v) {
      auto* g = gray.ptr<std::uint8_t>(v);
      auto* d = depth_m.ptr<float>(v);
      for (int u = 0; u < camera.width(); ++u) {
        const Eigen::Vector3d ray_cam((u - camera.cx()) / camera.fx(), (v - camera.cy()) / camera.fy(), 1.0);
        const Eigen::Vector3d ray = R * ray_cam;
        double t = 0.0;
        int wall = 0;
        exit_wall(c, ray, t, wall);
        const Eigen::Vector3d p = c + t * ray;
        g[u] = sample(wall, p);
        d[u] = static_cast<float>(t);  // ray_cam.z == 1: t is the depth along the optical axis
      }
    }
  }

 private:
  // The wall a ray from inside the room leaves through, and the ray parameter there.
  void exit_wall(const Eigen::Vector3d& c, const Eigen::Vector3d& ray, double& t_exit, int& wall) const {
    t_exit = std::numeric_limits<double>::infinity();
    for (int axis = 0; axis < 3; ++axis) {
      if (ray[axis] == 0.0) continue;
      const bool positive = ray[axis] > 0.0;
      const double t = ((positive ? max_[axis] : min_[axis]) - c[axis]) / ray[axis];
      if (t < t_exit) t_exit = t, wall = 2 * axis + (positive ? 1 : 0);
    }
  }

  std::uint8_t sample(int wall, const Eigen::Vector3d& p) const {
    const int axis = wall / 2;
    const int a = (axis + 1) % 3, b = (axis + 2) % 3;
    const cv::Mat& tex = textures_[static_cast<std::size_t>(wall)];
    const auto coordinate = [&](int k) {
      const double offset = p[k] - min_[k];
      return k == 2 && repeat_z_m_ > 0.0 ? offset - repeat_z_m_ * std::floor(offset / repeat_z_m_) : offset;
    };
    const double x = std::clamp(coordinate(a) / texel_m_, 0.0, tex.cols - 1.001);
    const double y = std::clamp(coordinate(b) / texel_m_, 0.0, tex.rows - 1.001);
    const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
    const double fx = x - x0, fy = y - y0;
    const auto at = [&](int r, int col) { return static_cast<double>(tex.at<std::uint8_t>(r, col)); };
    const double value = (1 - fy) * ((1 - fx) * at(y0, x0) + fx * at(y0, x0 + 1)) +
                         fy * ((1 - fx) * at(y0 + 1, x0) + fx * at(y0 + 1, x0 + 1));
    return static_cast<std::uint8_t>(std::lround(std::clamp(value, 0.0, 255.0)));
  }

  Eigen::Vector3d min_, max_;
  double texel_m_;
  double repeat_z_m_;
  std::array<cv::Mat, 6> textures_;
};

// The camera of the synthetic sequences and an RGB-D rig around it.
inline core::PinholeCamera synthetic_camera() { return core::PinholeCamera(640, 480, 500.0, 500.0, 319.5, 239.5); }

inline core::SensorRig synthetic_rgbd_rig() {
  core::SensorRig rig;
  rig.mode = core::SensorMode::kRgbd;
  rig.cam0 = synthetic_camera();
  rig.bf = 40.0;
  rig.fps = 30.0;
  rig.depth_scale = 5000.0;
  return rig;
}

// A rectified stereo rig: cam1 `baseline_m` along +x of cam0, same intrinsics, no distortion.
inline core::SensorRig synthetic_stereo_rig(double baseline_m = 0.1) {
  core::SensorRig rig;
  rig.mode = core::SensorMode::kStereo;
  rig.cam0 = synthetic_camera();
  rig.cam1 = synthetic_camera();
  rig.T_cam0_cam1 = Eigen::Translation3d(baseline_m, 0.0, 0.0) * Eigen::Isometry3d::Identity();
  rig.bf = baseline_m * rig.cam0.fx();
  rig.fps = 30.0;
  return rig;
}

// A smooth hand-held-like motion: the camera wanders around the room centre and turns its head.
inline Eigen::Isometry3d synthetic_pose(double t_s) {
  const Eigen::Vector3d position(0.4 * std::sin(0.9 * t_s), 0.15 * std::sin(1.3 * t_s), 0.3 * std::sin(0.6 * t_s));
  const Eigen::Vector3d rotation(0.12 * std::sin(0.8 * t_s), 0.5 * std::sin(0.5 * t_s), 0.05 * std::sin(1.1 * t_s));
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = core::so3_exp(rotation);
  T.translation() = position;
  return T;
}

inline SyntheticRoom default_room(std::uint32_t seed = 7) {
  return SyntheticRoom(Eigen::Vector3d(-2.0, -1.2, -1.8), Eigen::Vector3d(2.0, 1.2, 2.5), seed);
}

// Frame i of the sequence (30 Hz from t = 1 s), RGB-D or stereo.
inline core::SensorFrame synthetic_frame(const SyntheticRoom& room, const core::SensorRig& rig, int i) {
  core::SensorFrame f;
  f.sequence = i;
  f.t_ns = core::kNsPerSecond + static_cast<core::TimeNs>(i) * core::kNsPerSecond / 30;
  const Eigen::Isometry3d T_world_cam = synthetic_pose(core::ns_to_seconds(f.t_ns - core::kNsPerSecond));
  f.T_world_cam_gt = T_world_cam;
  cv::Mat depth;
  room.render(rig.cam0, T_world_cam, f.image, depth);
  if (rig.mode == core::SensorMode::kStereo) {
    cv::Mat unused;
    room.render(*rig.cam1, T_world_cam * rig.T_cam0_cam1, f.right, unused);
  } else {
    f.depth_m = depth;
  }
  return f;
}

// The frames with the gyro samples an IMU at the camera (T_body_cam0 identity) would give at 200 Hz along
// synthetic_pose, each the exact mean rate over its 5 ms, plus `bias_radps`.
inline std::vector<core::SensorFrame> with_gyro(const std::vector<core::SensorFrame>& frames,
                                                const Eigen::Vector3d& bias_radps = Eigen::Vector3d::Zero()) {
  std::vector<core::SensorFrame> out = frames;
  constexpr core::TimeNs kPeriodNs = 5'000'000;
  for (std::size_t i = 1; i < out.size(); ++i) {
    for (core::TimeNs t = out[i - 1].t_ns + kPeriodNs; t <= out[i].t_ns; t += kPeriodNs) {
      const double t0 = core::ns_to_seconds(t - kPeriodNs - core::kNsPerSecond);
      const double t1 = core::ns_to_seconds(t - core::kNsPerSecond);
      const Eigen::Matrix3d dR = synthetic_pose(t0).linear().transpose() * synthetic_pose(t1).linear();
      core::ImuSample sample;
      sample.t_ns = t;
      sample.gyro_radps = core::so3_log(dR) / (t1 - t0) + bias_radps;
      sample.accel_mps2 = Eigen::Vector3d(0.0, 0.0, 9.81);
      out[i].imu.push_back(sample);
    }
  }
  return out;
}

// The RGB-D rig with that IMU.
inline core::SensorRig synthetic_gyro_rig() {
  core::SensorRig rig = synthetic_rgbd_rig();
  rig.T_body_cam0 = Eigen::Isometry3d::Identity();
  rig.imu = core::ImuNoise{};
  return rig;
}

}  // namespace fleetslam::slam::test
