#pragma once
// Frames for map bookkeeping tests (test_map.cpp, test_global_ba_apply.cpp).

#include <cstddef>
#include <cstdint>
#include <random>

#include <opencv2/core.hpp>

#include "fleetslam/core/time.hpp"
#include "fleetslam/slam/frame.hpp"
#include "fleetslam/slam/map.hpp"

namespace fleetslam::slam::test {

// A frame of n features on a grid of the image, each with depth 2 m, level 0 and random descriptors.
inline Frame make_frame(std::size_t n, std::uint32_t seed, core::TimeNs t_ns = 0) {
  Frame f;
  f.t_ns = t_ns;
  f.camera = core::PinholeCamera(640, 480, 500.0, 500.0, 319.5, 239.5);
  f.pyramid = ScalePyramid::make(8, 1.2);
  f.bf = 40.0;
  f.close_depth_m = 3.0;
  std::mt19937 rng(seed);
  f.descriptors = cv::Mat(static_cast<int>(n), 32, CV_8UC1);
  for (std::size_t i = 0; i < n; ++i) {
    const double u = 20.0 + 600.0 * static_cast<double>(i % 20) / 20.0;
    const double v = 20.0 + 440.0 * static_cast<double>(i / 20) / (static_cast<double>(n / 20) + 1.0);
    f.keypoints.emplace_back(static_cast<float>(u), static_cast<float>(v), 31.0f, 0.0f, 0.0f, 0);
    f.uv.emplace_back(u, v);
    f.level.push_back(0);
    f.depth_m.push_back(2.0);
    f.u_right.push_back(u - f.bf / 2.0);
    for (int b = 0; b < 32; ++b) f.descriptors.at<std::uint8_t>(static_cast<int>(i), b) = static_cast<std::uint8_t>(rng());
  }
  f.map_points.assign(n, kNoMapPoint);
  f.outlier.assign(n, false);
  return f;
}

}  // namespace fleetslam::slam::test
