#pragma once
// Synthetic images for the front-end tests (ORB extractor, stereo depth, frame builder): a seeded
// texture of overlapping shapes with corners at every scale, and rectified stereo pairs of
// fronto-parallel planes made from it by exact horizontal shifts.

#include <cmath>
#include <cstdint>
#include <random>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace fleetslam::slam::test {

// Shapes (rectangles, triangles, ellipses) of random gray levels and log-uniform sizes (4 to 90 px)
// on a mid-gray background, slightly blurred so that sub-pixel shifts interpolate well. CV_32FC1 in
// [0, 255], the same for the same arguments.
inline cv::Mat texture_float(int width, int height, unsigned seed, double blur_sigma = 1.0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  cv::Mat image(height, width, CV_32FC1, cv::Scalar(128.0));
  const int shapes = width * height / 300;
  for (int i = 0; i < shapes; ++i) {
    const double size = 4.0 * std::pow(90.0 / 4.0, unit(rng));
    const cv::Point centre(static_cast<int>(unit(rng) * width), static_cast<int>(unit(rng) * height));
    const cv::Scalar gray(20.0 + 215.0 * unit(rng));
    const int half = static_cast<int>(size / 2.0) + 1;
    switch (static_cast<int>(unit(rng) * 3.0)) {
      case 0:
        cv::rectangle(image, centre - cv::Point(half, half / 2), centre + cv::Point(half, half), gray, cv::FILLED);
        break;
      case 1: {
        const cv::Point corners[3] = {centre + cv::Point(-half, half), centre + cv::Point(half, half / 3),
                                      centre + cv::Point(half / 4, -half)};
        cv::fillConvexPoly(image, corners, 3, gray);
        break;
      }
      default:
        cv::ellipse(image, centre, cv::Size(half, half / 2 + 1), unit(rng) * 180.0, 0.0, 360.0, gray, cv::FILLED);
        break;
    }
  }
  cv::GaussianBlur(image, image, cv::Size(0, 0), blur_sigma);
  return image;
}

inline cv::Mat to_8u(const cv::Mat& image) {
  cv::Mat out;
  image.convertTo(out, CV_8UC1);
  return out;
}

inline cv::Mat textured_image(int width, int height, unsigned seed) {
  return to_8u(texture_float(width, height, seed));
}

// A rectified pair seeing a background plane at depth background_m and, in front of it, a plane at
// foreground_m covering `foreground` of the left image. Each plane carries its own texture in left
// image coordinates, so the right image pixel (x, y) shows the foreground texture at x + bf / z_fg when
// that lands inside the foreground rectangle, else the background texture at x + bf / z_bg (bicubic).
struct StereoScene {
  cv::Mat left;
  cv::Mat right;
  cv::Rect foreground;
  double foreground_m = 1.0;
  double background_m = 2.5;

  double true_depth(double u, double v) const {
    return foreground.contains(cv::Point(static_cast<int>(std::lround(u)), static_cast<int>(std::lround(v))))
               ? foreground_m
               : background_m;
  }
};

inline StereoScene make_stereo_scene(int width, int height, double bf, cv::Rect foreground, double foreground_m,
                                     double background_m, unsigned seed) {
  const cv::Mat bg = texture_float(width, height, seed);
  const cv::Mat fg = texture_float(width, height, seed + 1000u);
  const float d_fg = static_cast<float>(bf / foreground_m);
  const float d_bg = static_cast<float>(bf / background_m);
  cv::Mat left = bg.clone();
  fg(foreground).copyTo(left(foreground));
  cv::Mat map_x(height, width, CV_32FC1), map_y(height, width, CV_32FC1), use_fg(height, width, CV_8UC1);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const float x_fg = static_cast<float>(x) + d_fg;
      // The foreground covers the pixel centres of its rectangle: [x - 0.5, x + width - 0.5) continuously.
      const bool on_fg = y >= foreground.y && y < foreground.y + foreground.height &&
                         x_fg >= static_cast<float>(foreground.x) - 0.5f &&
                         x_fg < static_cast<float>(foreground.x + foreground.width) - 0.5f;
      use_fg.at<std::uint8_t>(y, x) = on_fg ? 255 : 0;
      map_x.at<float>(y, x) = on_fg ? x_fg : static_cast<float>(x) + d_bg;
      map_y.at<float>(y, x) = static_cast<float>(y);
    }
  }
  cv::Mat right_bg, right_fg;
  cv::remap(bg, right_bg, map_x, map_y, cv::INTER_CUBIC, cv::BORDER_REFLECT_101);
  cv::remap(fg, right_fg, map_x, map_y, cv::INTER_CUBIC, cv::BORDER_REFLECT_101);
  right_fg.copyTo(right_bg, use_fg);
  StereoScene scene;
  scene.left = to_8u(left);
  scene.right = to_8u(right_bg);
  scene.foreground = foreground;
  scene.foreground_m = foreground_m;
  scene.background_m = background_m;
  return scene;
}

}  // namespace fleetslam::slam::test
