// Depth and image noise models on synthetic images with known geometry: axial noise against
// sigma_z(z) of Nguyen et al. 2012 on fronto-parallel planes, the valid range, grazing dropout against
// the analytic incidence angle of a floor, dropout near a depth step, all dropout against a plain
// per-pixel reference on a cluttered scene, intensity noise and saturation (also under exposure
// changes), the exposure process, repeatability from the seed and independence of the thread count,
// the draws expanded apart (on another thread) giving the same bytes, a pixel's depth noise not
// depending on the rest of the image, and the cost of a 640x480 frame.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <future>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "fleetslam/sim/sensor_noise.hpp"

namespace fleetslam::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

core::PinholeCamera vga_camera() { return core::PinholeCamera(640, 480, 525.0, 525.0, 319.5, 239.5); }

cv::Mat constant_depth(const core::PinholeCamera& camera, float depth_m) {
  return cv::Mat(camera.height(), camera.width(), CV_32FC1, cv::Scalar(depth_m));
}

// A horizontal floor height_m below a level camera (y down): rows below the horizon see it at
// z = height_m / y_n, rows above see nothing (0).
cv::Mat floor_depth(const core::PinholeCamera& camera, double height_m) {
  cv::Mat depth = constant_depth(camera, 0.0f);
  for (int v = 0; v < depth.rows; ++v) {
    const double yn = (v - camera.cy()) / camera.fy();
    if (yn > 0.0) depth.row(v).setTo(cv::Scalar(height_m / yn));
  }
  return depth;
}

// Angle between the floor normal (0, 1, 0) and the ray through (u, v), in degrees.
double floor_incidence_deg(const core::PinholeCamera& camera, int u, int v) {
  const Eigen::Vector3d ray((u - camera.cx()) / camera.fx(), (v - camera.cy()) / camera.fy(), 1.0);
  return std::acos(std::abs(ray.y()) / ray.norm()) * 180.0 / kPi;
}

DepthNoiseConfig noise_only_config() {
  DepthNoiseConfig config;
  config.grazing_dropout_deg = 90.0;
  config.edge_dropout_probability = 0.0;
  return config;
}

struct ErrorStats {
  double mean = 0.0;
  double std = 0.0;
  int valid = 0;
};

ErrorStats error_stats(const cv::Mat& noisy, const cv::Mat& truth) {
  double sum = 0.0, sum_sq = 0.0;
  int valid = 0;
  for (int v = 0; v < noisy.rows; ++v) {
    for (int u = 0; u < noisy.cols; ++u) {
      if (noisy.at<float>(v, u) == 0.0f) continue;
      const double e = double{noisy.at<float>(v, u)} - double{truth.at<float>(v, u)};
      sum += e;
      sum_sq += e * e;
      ++valid;
    }
  }
  const double mean = sum / valid;
  return {mean, std::sqrt(sum_sq / valid - mean * mean), valid};
}

TEST(DepthNoise, AxialNoiseFollowsTheKinectModel) {
  const core::PinholeCamera camera = vga_camera();
  DepthNoiseModel model(noise_only_config(), 1);
  for (double z : {0.5, 1.0, 2.0, 4.0, 6.0}) {
    const cv::Mat truth = constant_depth(camera, static_cast<float>(z));
    const ErrorStats stats = error_stats(model.apply(truth, camera), truth);
    const double expected = 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4);
    EXPECT_DOUBLE_EQ(model.axial_sigma_m(z), expected);
    std::printf("depth %.1f m: std %.5f m, model %.5f m, ratio %.4f, mean %+.2e m\n", z, stats.std, expected,
                stats.std / expected, stats.mean);
    EXPECT_EQ(stats.valid, camera.width() * camera.height()) << "z " << z;
    // 307200 samples: 0.13 % spread of the std estimate, and float resolution at 6 m is 5e-7 m.
    EXPECT_NEAR(stats.std / expected, 1.0, 0.01) << "z " << z << " std " << stats.std << " expected " << expected;
    EXPECT_LT(std::abs(stats.mean), 5.0 * expected / std::sqrt(static_cast<double>(stats.valid))) << "z " << z;
  }
}

TEST(DepthNoise, OutOfRangeDepthIsDropped) {
  const core::PinholeCamera camera = vga_camera();
  DepthNoiseModel model(DepthNoiseConfig{}, 2);
  EXPECT_EQ(cv::countNonZero(model.apply(constant_depth(camera, 0.2f), camera)), 0);
  EXPECT_EQ(cv::countNonZero(model.apply(constant_depth(camera, 9.0f), camera)), 0);
  EXPECT_EQ(cv::countNonZero(model.apply(constant_depth(camera, 0.0f), camera)), 0);
  EXPECT_EQ(cv::countNonZero(model.apply(constant_depth(camera, std::nanf("")), camera)), 0);
  EXPECT_EQ(cv::countNonZero(model.apply(constant_depth(camera, 3.0f), camera)), camera.width() * camera.height());

  // Holes are never measured, even when the range starts at 0.
  DepthNoiseConfig from_zero;
  from_zero.min_depth_m = 0.0;
  DepthNoiseModel from_zero_model(from_zero, 2);
  EXPECT_EQ(cv::countNonZero(from_zero_model.apply(constant_depth(camera, 0.0f), camera)), 0);
}

TEST(DepthNoise, FrontoParallelPlaneIsKept) {
  const core::PinholeCamera camera = vga_camera();
  DepthNoiseModel model(DepthNoiseConfig{}, 3);  // every dropout on, defaults
  for (float z : {0.5f, 2.0f, 7.5f}) {
    EXPECT_EQ(cv::countNonZero(model.apply(constant_depth(camera, z), camera)), camera.width() * camera.height());
  }
}

TEST(DepthNoise, GrazingFloorIsDroppedBeyondTheAngle) {
  const core::PinholeCamera camera = vga_camera();
  DepthNoiseConfig config;
  config.edge_dropout_probability = 0.0;
  config.max_depth_m = 20.0;
  DepthNoiseModel model(config, 4);
  const cv::Mat truth = floor_depth(camera, 0.5);
  const cv::Mat noisy = model.apply(truth, camera);
  int beyond = 0, beyond_kept = 0, within = 0, within_kept = 0;
  for (int v = 0; v < truth.rows; ++v) {
    for (int u = 0; u < truth.cols; ++u) {
      const float z = truth.at<float>(v, u);
      if (double{z} < config.min_depth_m || double{z} > config.max_depth_m) continue;
      const double angle = floor_incidence_deg(camera, u, v);
      const bool kept = noisy.at<float>(v, u) != 0.0f;
      if (angle > config.grazing_dropout_deg + 0.5) {
        ++beyond;
        beyond_kept += kept ? 1 : 0;
      } else if (angle < config.grazing_dropout_deg - 0.5) {
        ++within;
        within_kept += kept ? 1 : 0;
      }
    }
  }
  std::printf("grazing floor: kept %d of %d beyond %.0f deg, %d of %d within\n", beyond_kept, beyond,
              config.grazing_dropout_deg, within_kept, within);
  ASSERT_GT(beyond, 10000);
  ASSERT_GT(within, 10000);
  EXPECT_EQ(beyond_kept, 0);
  EXPECT_EQ(within_kept, within);
}

// Left half at 1 m, right half at 2 m: the step lies between columns 319 and 320.
cv::Mat step_depth(const core::PinholeCamera& camera) {
  cv::Mat depth = constant_depth(camera, 1.0f);
  depth.colRange(camera.width() / 2, camera.width()).setTo(cv::Scalar(2.0f));
  return depth;
}

std::vector<double> kept_fraction_per_column(const cv::Mat& noisy) {
  std::vector<double> fraction(static_cast<std::size_t>(noisy.cols));
  for (int u = 0; u < noisy.cols; ++u) {
    fraction[static_cast<std::size_t>(u)] = cv::countNonZero(noisy.col(u)) / static_cast<double>(noisy.rows);
  }
  return fraction;
}

TEST(DepthNoise, DepthStepDropsTheBandAroundIt) {
  const core::PinholeCamera camera = vga_camera();
  DepthNoiseConfig config;
  config.edge_band_px = 2;
  config.edge_dropout_probability = 1.0;
  DepthNoiseModel model(config, 5);
  const std::vector<double> kept = kept_fraction_per_column(model.apply(step_depth(camera), camera));
  // Edge pixels are columns 319 and 320; the band widens them by 2 on each side.
  for (int u = 0; u < camera.width(); ++u) {
    const bool in_band = u >= 317 && u <= 322;
    EXPECT_DOUBLE_EQ(kept[static_cast<std::size_t>(u)], in_band ? 0.0 : 1.0) << "column " << u;
  }
}

TEST(DepthNoise, EdgeDropoutHasItsProbability) {
  const core::PinholeCamera camera = vga_camera();
  DepthNoiseModel model(DepthNoiseConfig{}, 6);  // band 1 px, probability 0.5
  const std::vector<double> kept = kept_fraction_per_column(model.apply(step_depth(camera), camera));
  double band_kept = 0.0;
  for (int u = 318; u <= 321; ++u) band_kept += kept[static_cast<std::size_t>(u)] / 4.0;
  std::printf("edge band kept fraction %.4f (probability 0.5)\n", band_kept);
  // 4 x 480 Bernoulli(0.5) draws: std of the fraction 0.011.
  EXPECT_NEAR(band_kept, 0.5, 0.05);
  EXPECT_DOUBLE_EQ(kept[316], 1.0);
  EXPECT_DOUBLE_EQ(kept[323], 1.0);
}

// A scene with every case the dropout handles: a floor seen at grazing incidence, a box and a
// slanted wall (depth edges, one-sided normals), holes of every kind and depths out of range.
cv::Mat cluttered_depth(const core::PinholeCamera& camera) {
  cv::Mat depth = floor_depth(camera, 0.5);
  for (int v = 0; v < depth.rows; ++v) {
    for (int u = 0; u < depth.cols; ++u) {
      float& z = depth.at<float>(v, u);
      if (u >= 100 && u < 220 && v >= 150 && v < 330) z = 1.5f + 0.002f * static_cast<float>(u - 100);  // box
      if (u >= 400 && v < 300) z = 2.0f + 0.05f * static_cast<float>(u - 400);  // wall turning away
      if (u >= 440 && v >= 330) z = 1.0f + 0.3f * static_cast<float>((u / 20 + v / 20) % 2);  // steps
      if (u >= 300 && u < 330 && v >= 60 && v < 90) z = 0.0f;                     // holes
      if (u >= 330 && u < 340 && v >= 60 && v < 90) z = std::nanf("");
      if (u >= 340 && u < 350 && v >= 60 && v < 90) z = std::numeric_limits<float>::infinity();
      if (u >= 350 && u < 360 && v >= 60 && v < 90) z = -1.0f;
      if (u >= 360 && u < 370 && v >= 60 && v < 90) z = 0.1f;                     // too near
      if (u >= 250 && u < 280 && v >= 400) z = 9.5f;                              // too far
    }
  }
  return depth;
}

// The dropout model written plainly, per pixel (no noise): 1 where a pixel is kept.
cv::Mat reference_keep(const cv::Mat& depth, const core::PinholeCamera& camera, const DepthNoiseConfig& config,
                       bool drop_band) {
  const auto valid = [](float z) { return z > 0.0f && z < std::numeric_limits<float>::infinity(); };
  const auto at = [&](int v, int u) {
    return v >= 0 && v < depth.rows && u >= 0 && u < depth.cols ? depth.at<float>(v, u) : 0.0f;
  };
  const auto jump_m = static_cast<float>(config.edge_jump_m);
  cv::Mat edges(depth.size(), CV_8UC1, cv::Scalar(0));
  for (int v = 0; v < depth.rows; ++v) {
    for (int u = 0; u < depth.cols; ++u) {
      const float z = at(v, u);
      for (const float n : {at(v, u - 1), at(v, u + 1), at(v - 1, u), at(v + 1, u)}) {
        if (valid(z) && valid(n) && std::abs(n - z) > jump_m) edges.at<std::uint8_t>(v, u) = 1;
      }
    }
  }
  cv::Mat band;
  const int b = config.edge_band_px;
  cv::dilate(edges, band, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * b + 1, 2 * b + 1)));
  // Depth change per pixel: central where both neighbours continue the surface, else towards the
  // valid neighbour nearer in depth; none without a valid neighbour.
  const auto slope = [&](float z, float prev, float next, float* dz) {
    const float inf = std::numeric_limits<float>::infinity();
    const float jump_prev = valid(prev) ? std::abs(prev - z) : inf;
    const float jump_next = valid(next) ? std::abs(next - z) : inf;
    if (jump_prev == inf && jump_next == inf) return false;
    if (jump_prev <= jump_m && jump_next <= jump_m) {
      *dz = 0.5f * (next - prev);
    } else {
      *dz = jump_prev < jump_next ? z - prev : next - z;
    }
    return true;
  };
  const double c = std::cos(config.grazing_dropout_deg * kPi / 180.0);
  const auto min_cos_sq = static_cast<float>(c * c);
  cv::Mat keep(depth.size(), CV_8UC1, cv::Scalar(0));
  for (int v = 0; v < depth.rows; ++v) {
    for (int u = 0; u < depth.cols; ++u) {
      const float z = at(v, u);
      if (!valid(z) || !(z >= static_cast<float>(config.min_depth_m) && z <= static_cast<float>(config.max_depth_m))) {
        continue;
      }
      if (drop_band && band.at<std::uint8_t>(v, u) != 0) continue;
      float z_u = 0.0f, z_v = 0.0f;
      if (slope(z, at(v, u - 1), at(v, u + 1), &z_u) && slope(z, at(v - 1, u), at(v + 1, u), &z_v)) {
        const auto xn = static_cast<float>((u - camera.cx()) / camera.fx());
        const auto yn = static_cast<float>((v - camera.cy()) / camera.fy());
        const float gx = static_cast<float>(camera.fx()) * z_u;
        const float gy = static_cast<float>(camera.fy()) * z_v;
        const float nz = gx * xn + gy * yn + z;
        if (z * z < min_cos_sq * (gx * gx + gy * gy + nz * nz) * (xn * xn + yn * yn + 1.0f)) continue;
      }
      keep.at<std::uint8_t>(v, u) = 1;
    }
  }
  return keep;
}

TEST(DepthNoise, DropoutMatchesAPlainReference) {
  const core::PinholeCamera camera = vga_camera();
  const cv::Mat truth = cluttered_depth(camera);
  DepthNoiseConfig config;
  config.sigma_base_m = 0.0;  // no noise: kept pixels keep their depth exactly
  config.sigma_quadratic = 0.0;
  config.edge_band_px = 2;
  for (double probability : {0.0, 1.0}) {
    config.edge_dropout_probability = probability;
    DepthNoiseModel model(config, 7);
    const cv::Mat noisy = model.apply(truth, camera);
    const cv::Mat expected = reference_keep(truth, camera, config, probability > 0.0);
    int mismatches = 0, kept = 0;
    for (int v = 0; v < truth.rows; ++v) {
      for (int u = 0; u < truth.cols; ++u) {
        const bool keep = expected.at<std::uint8_t>(v, u) != 0;
        kept += keep ? 1 : 0;
        const float want = keep ? truth.at<float>(v, u) : 0.0f;
        if (noisy.at<float>(v, u) != want) ++mismatches;
      }
    }
    std::printf("edge probability %.0f: %d kept, %d mismatches\n", probability, kept, mismatches);
    EXPECT_EQ(mismatches, 0) << "edge probability " << probability;
    EXPECT_GT(kept, truth.rows * truth.cols / 4);
    EXPECT_LT(kept, truth.rows * truth.cols * 3 / 4);
  }

  // In between, band pixels that survive everything else are dropped with the probability.
  config.edge_dropout_probability = 0.3;
  DepthNoiseModel model(config, 8);
  const cv::Mat noisy = model.apply(truth, camera);
  const cv::Mat all = reference_keep(truth, camera, config, false);
  const cv::Mat outside_band = reference_keep(truth, camera, config, true);
  int band_pixels = 0, band_kept = 0, wrong = 0;
  for (int v = 0; v < truth.rows; ++v) {
    for (int u = 0; u < truth.cols; ++u) {
      const bool kept = noisy.at<float>(v, u) != 0.0f;
      if (all.at<std::uint8_t>(v, u) != 0 && outside_band.at<std::uint8_t>(v, u) == 0) {
        ++band_pixels;
        band_kept += kept ? 1 : 0;
      } else if (kept != (all.at<std::uint8_t>(v, u) != 0)) {
        ++wrong;
      }
    }
  }
  const double kept_fraction = band_kept / static_cast<double>(band_pixels);
  std::printf("edge probability 0.3: %d of %d band pixels kept (%.4f)\n", band_kept, band_pixels, kept_fraction);
  EXPECT_EQ(wrong, 0);
  ASSERT_GT(band_pixels, 2000);
  EXPECT_NEAR(kept_fraction, 0.7, 5.0 * std::sqrt(0.21 / band_pixels));
}

// Depth of every kind (slanted surfaces, steps, holes, out of range) at any size, from the pixel
// coordinates alone.
cv::Mat patterned_depth(int width, int height) {
  cv::Mat depth(height, width, CV_32FC1);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      float z = 1.0f + 0.3f * static_cast<float>((u / 3 + v / 2) % 3) + 0.01f * static_cast<float>(u + 2 * v);
      if ((u * 7 + v * 3) % 23 == 0) z = 0.0f;
      if ((u + v) % 31 == 0) z = 0.1f;
      depth.at<float>(v, u) = z;
    }
  }
  return depth;
}

TEST(DepthNoise, DropoutMatchesAPlainReferenceAtEverySize) {
  // Heights below, at and around the eight row bands, with bands narrower than the edge band.
  for (const auto& [width, height] : {std::pair{40, 13}, std::pair{24, 5}, std::pair{17, 8}, std::pair{9, 1},
                                      std::pair{33, 47}}) {
    const core::PinholeCamera camera(width, height, 30.0, 30.0, (width - 1) / 2.0, (height - 1) / 2.0);
    const cv::Mat truth = patterned_depth(width, height);
    for (int band_px : {0, 1, 3}) {
      for (double probability : {0.0, 1.0}) {
        DepthNoiseConfig config;
        config.sigma_base_m = 0.0;
        config.sigma_quadratic = 0.0;
        config.edge_band_px = band_px;
        config.edge_dropout_probability = probability;
        DepthNoiseModel model(config, 11);
        const cv::Mat noisy = model.apply(truth, camera);
        const cv::Mat expected = reference_keep(truth, camera, config, probability > 0.0);
        int mismatches = 0;
        for (int v = 0; v < height; ++v) {
          for (int u = 0; u < width; ++u) {
            const float want = expected.at<std::uint8_t>(v, u) != 0 ? truth.at<float>(v, u) : 0.0f;
            if (noisy.at<float>(v, u) != want) ++mismatches;
          }
        }
        EXPECT_EQ(mismatches, 0) << width << "x" << height << ", band " << band_px << ", probability "
                                 << probability;
      }
    }
  }
}

// OpenCV's thread count for a scope.
class OpenCvThreads {
 public:
  explicit OpenCvThreads(int threads) : previous_(cv::getNumThreads()) { cv::setNumThreads(threads); }
  ~OpenCvThreads() { cv::setNumThreads(previous_); }
  OpenCvThreads(const OpenCvThreads&) = delete;
  OpenCvThreads& operator=(const OpenCvThreads&) = delete;

 private:
  int previous_;
};

TEST(SensorNoise, ImagesDoNotDependOnTheThreadCount) {
  const core::PinholeCamera camera = vga_camera();
  const cv::Mat depth = cluttered_depth(camera);
  cv::Mat rgb(480, 640, CV_8UC3);
  cv::randu(rgb, cv::Scalar::all(0), cv::Scalar::all(256));
  ImageNoiseConfig exposure;
  exposure.exposure_changes = true;  // the general path (gain), besides the rounded table at unit gain
  const auto run = [&](int threads) {
    const OpenCvThreads scope(threads);
    DepthNoiseModel depth_model(DepthNoiseConfig{}, 3);
    ImageNoiseModel image_model(ImageNoiseConfig{}, 3);
    ImageNoiseModel exposure_model(exposure, 3);
    std::vector<cv::Mat> images;
    for (int k = 0; k < 3; ++k) {
      images.push_back(depth_model.apply(depth, camera));
      images.push_back(image_model.apply(rgb, k * 33'000'000));
      images.push_back(exposure_model.apply(rgb, k * 33'000'000));
    }
    return images;
  };
  const std::vector<cv::Mat> one = run(1);
  for (int threads : {2, 5}) {
    const std::vector<cv::Mat> many = run(threads);
    ASSERT_EQ(many.size(), one.size());
    for (std::size_t i = 0; i < one.size(); ++i) {
      EXPECT_EQ(cv::norm(one[i], many[i], cv::NORM_INF), 0.0) << "image " << i << " with " << threads << " threads";
    }
  }
}

// The three steps (draw, expand the image-independent noise, apply to the image) give the one step's
// bytes, with the expansion on the pool or serial and run on another thread, for depth, the image at
// unit gain (rounded table), under exposure changes and with a sigma too large for the table.
TEST(SensorNoise, ExpandingTheDrawsApartGivesTheSameImages) {
  const core::PinholeCamera camera = vga_camera();
  const cv::Mat depth = cluttered_depth(camera);
  cv::Mat rgb(480, 640, CV_8UC3);
  cv::randu(rgb, cv::Scalar::all(0), cv::Scalar::all(256));
  cv::Mat gray;
  cv::cvtColor(rgb, gray, cv::COLOR_BGR2GRAY);
  ImageNoiseConfig exposure;
  exposure.exposure_changes = true;
  ImageNoiseConfig wide;
  wide.sigma_intensity = 40.0;  // round(sigma n) does not fit in a byte: the float path at unit gain
  for (const bool parallel : {true, false}) {
    DepthNoiseModel depth_one(DepthNoiseConfig{}, 3), depth_three(DepthNoiseConfig{}, 3);
    for (int k = 0; k < 2; ++k) {
      const DepthNoiseDraw draw = depth_three.next();
      const DepthNoiseField field = std::async(std::launch::async, [&] {
        return depth_three.expand(draw, depth.size(), parallel);
      }).get();
      EXPECT_EQ(cv::norm(depth_one.apply(depth, camera), depth_three.apply(depth, camera, field), cv::NORM_INF), 0.0)
          << "depth image " << k << (parallel ? " on the pool" : " serial");
    }
    for (const ImageNoiseConfig& config : {ImageNoiseConfig{}, exposure, wide}) {
      for (const cv::Mat& image : {rgb, gray}) {
        ImageNoiseModel one(config, 4), three(config, 4);
        for (int k = 0; k < 3; ++k) {
          const ImageNoiseDraw draw = three.next(k * 33'000'000);
          const ImageNoiseField field = std::async(std::launch::async, [&] {
            return three.expand(draw, image.size(), image.channels(), parallel);
          }).get();
          const cv::Mat a = one.apply(image, k * 33'000'000);
          const cv::Mat b = three.apply(image, field);
          ASSERT_EQ(a.type(), b.type());
          EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0)
              << "image " << k << ", " << image.channels() << " channels, sigma " << config.sigma_intensity
              << (config.exposure_changes ? ", exposure changes" : "") << (parallel ? ", on the pool" : ", serial");
        }
      }
    }
  }
}

// A pixel's Gaussian noise is drawn whether or not the pixel is kept, so it depends on the pixel's
// place and the seed, not on the rest of the image: a hole or a step elsewhere leaves every other
// pixel's noisy depth as it was.
TEST(DepthNoise, APixelsNoiseDoesNotDependOnTheRestOfTheImage) {
  const core::PinholeCamera camera = vga_camera();
  const DepthNoiseConfig config = noise_only_config();
  const cv::Mat plane = constant_depth(camera, 2.0f);
  cv::Mat holed = plane.clone();
  holed(cv::Rect(100, 50, 200, 100)).setTo(cv::Scalar(0.0f));
  holed(cv::Rect(400, 300, 100, 100)).setTo(cv::Scalar(9.5f));  // out of range: dropped
  DepthNoiseModel a(config, 21), b(config, 21);
  const cv::Mat noisy_plane = a.apply(plane, camera);
  const cv::Mat noisy_holed = b.apply(holed, camera);
  int compared = 0, differing = 0;
  for (int v = 0; v < plane.rows; ++v) {
    for (int u = 0; u < plane.cols; ++u) {
      if (holed.at<float>(v, u) != 2.0f) continue;
      ++compared;
      differing += noisy_plane.at<float>(v, u) != noisy_holed.at<float>(v, u) ? 1 : 0;
    }
  }
  EXPECT_GT(compared, plane.rows * plane.cols * 8 / 10);
  EXPECT_EQ(differing, 0);
  EXPECT_GT(cv::norm(noisy_plane, plane, cv::NORM_INF), 0.0);  // there is noise
}

TEST(SensorNoise, AFieldOfAnotherSizeIsRejected) {
  const core::PinholeCamera camera = vga_camera();
  DepthNoiseModel depth_model(DepthNoiseConfig{}, 1);
  const DepthNoiseField small = depth_model.expand(depth_model.next(), cv::Size(320, 240));
  EXPECT_THROW(depth_model.apply(constant_depth(camera, 1.0f), camera, small), std::invalid_argument);
  ImageNoiseModel image_model(ImageNoiseConfig{}, 1);
  const ImageNoiseField gray_field = image_model.expand(image_model.next(0), cv::Size(640, 480), 1);
  EXPECT_THROW(image_model.apply(cv::Mat(480, 640, CV_8UC3, cv::Scalar::all(9)), gray_field), std::invalid_argument);
  EXPECT_EQ(image_model.apply(cv::Mat(480, 640, CV_8UC1, cv::Scalar(9)), gray_field).size(), cv::Size(640, 480));
}

// Each row band draws its own stream: the noise of two bands is uncorrelated (not one stream
// repeated or shifted), here on rows 60 apart that each band starts with.
TEST(ImageNoise, RowBandsDrawIndependentNoise) {
  const cv::Mat clean(480, 640, CV_8UC1, cv::Scalar(128));
  ImageNoiseConfig config;
  config.sigma_intensity = 10.0;
  ImageNoiseModel model(config, 12);
  cv::Mat noise;
  model.apply(clean, 0).convertTo(noise, CV_64F, 1.0, -128.0);
  for (int shift = 0; shift <= 4; ++shift) {
    for (int band = 0; band + 1 < 8; ++band) {
      const cv::Mat a = noise.row(band * 60).colRange(0, 600);
      const cv::Mat b = noise.row((band + 1) * 60).colRange(shift, 600 + shift);
      const double correlation = a.dot(b) / std::sqrt(a.dot(a) * b.dot(b));
      // 600 samples: std of the sample correlation 0.04.
      EXPECT_LT(std::abs(correlation), 0.2) << "bands " << band << ", " << band + 1 << ", shift " << shift;
    }
  }
}

TEST(DepthNoise, SameSeedSameImageAndDisabledIsACopy) {
  const core::PinholeCamera camera = vga_camera();
  const cv::Mat truth = step_depth(camera);
  DepthNoiseModel a(DepthNoiseConfig{}, 9), b(DepthNoiseConfig{}, 9), c(DepthNoiseConfig{}, 10);
  const cv::Mat noisy_a = a.apply(truth, camera);
  EXPECT_EQ(cv::norm(noisy_a, b.apply(truth, camera), cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(noisy_a, c.apply(truth, camera), cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(noisy_a, a.apply(truth, camera), cv::NORM_INF), 0.0);  // the stream moves on

  DepthNoiseConfig off;
  off.enabled = false;
  DepthNoiseModel disabled(off, 9);
  const cv::Mat copy = disabled.apply(truth, camera);
  EXPECT_EQ(cv::norm(copy, truth, cv::NORM_INF), 0.0);
  EXPECT_NE(copy.data, truth.data);
}

TEST(DepthNoise, RejectsBadInput) {
  DepthNoiseConfig config;
  config.min_depth_m = 5.0;
  config.max_depth_m = 5.0;
  EXPECT_THROW(DepthNoiseModel(config, 1), std::invalid_argument);
  DepthNoiseModel model(DepthNoiseConfig{}, 1);
  const core::PinholeCamera camera = vga_camera();
  EXPECT_THROW(model.apply(cv::Mat(480, 640, CV_16UC1, cv::Scalar(0)), camera), std::invalid_argument);
  EXPECT_THROW(model.apply(cv::Mat(240, 320, CV_32FC1, cv::Scalar(1.0f)), camera), std::invalid_argument);
}

ErrorStats intensity_error(const cv::Mat& noisy, const cv::Mat& clean) {
  cv::Mat diff;
  noisy.convertTo(diff, CV_64F);
  cv::Mat clean64;
  clean.convertTo(clean64, CV_64F);
  diff -= clean64;
  cv::Scalar mean, std;
  cv::meanStdDev(diff.reshape(1), mean, std);
  return {mean[0], std[0], static_cast<int>(diff.total() * diff.channels())};
}

TEST(ImageNoise, IntensityNoiseHasItsStandardDeviation) {
  ImageNoiseModel model(ImageNoiseConfig{}, 1);  // sigma 2 levels
  for (int type : {CV_8UC1, CV_8UC3}) {
    const cv::Mat clean(480, 640, type, cv::Scalar::all(128));
    const ErrorStats stats = intensity_error(model.apply(clean, 0), clean);
    // Rounding to integers adds 1/12 level^2 of variance.
    const double expected = std::sqrt(2.0 * 2.0 + 1.0 / 12.0);
    std::printf("intensity noise (%d channels): std %.4f, expected %.4f\n", CV_MAT_CN(type), stats.std, expected);
    EXPECT_NEAR(stats.std / expected, 1.0, 0.02) << "std " << stats.std << " expected " << expected;
    EXPECT_LT(std::abs(stats.mean), 0.02);
  }
}

TEST(ImageNoise, SaturatesInsteadOfWrapping) {
  ImageNoiseModel model(ImageNoiseConfig{}, 2);
  const cv::Mat white(480, 640, CV_8UC1, cv::Scalar(255));
  const cv::Mat black(480, 640, CV_8UC1, cv::Scalar(0));
  const cv::Mat noisy_white = model.apply(white, 0);
  const cv::Mat noisy_black = model.apply(black, 0);
  double min_white = 0.0, max_black = 0.0;
  cv::minMaxLoc(noisy_white, &min_white);
  cv::minMaxLoc(noisy_black, nullptr, &max_black);
  EXPECT_GE(min_white, 240.0);
  EXPECT_LE(max_black, 15.0);
  // 255 stays 255 when the noise rounds to >= 0: P(n > -0.5) = Phi(0.25) = 0.599.
  const double at_255 = cv::countNonZero(noisy_white == 255) / static_cast<double>(white.total());
  const double at_0 = cv::countNonZero(noisy_black == 0) / static_cast<double>(black.total());
  std::printf("saturation: %.4f at 255, %.4f at 0 (expected 0.599)\n", at_255, at_0);
  EXPECT_NEAR(at_255, 0.599, 0.01);
  EXPECT_NEAR(at_0, 0.599, 0.01);
}

TEST(ImageNoise, ExposureGainIsAStationaryLogNormalProcess) {
  ImageNoiseConfig config;
  config.sigma_intensity = 0.0;
  config.exposure_changes = true;
  ImageNoiseModel model(config, 3);
  const cv::Mat clean(4, 4, CV_8UC1, cv::Scalar(100));
  std::vector<double> log_gains;
  constexpr core::TimeNs kFrameNs = core::kNsPerSecond;  // 1 s frames, tau 2 s: correlation 0.61
  for (int k = 0; k < 40'000; ++k) {
    const cv::Mat noisy = model.apply(clean, k * kFrameNs);
    if (k == 0) {
      EXPECT_EQ(model.current_gain(), 1.0);
    }
    EXPECT_NEAR(noisy.at<std::uint8_t>(0, 0), 100.0 * model.current_gain(), 0.5 + 1e-4);
    log_gains.push_back(std::log(model.current_gain()));
  }
  double sum = 0.0, sum_sq = 0.0, lag1 = 0.0;
  for (std::size_t k = 0; k < log_gains.size(); ++k) {
    sum += log_gains[k];
    sum_sq += log_gains[k] * log_gains[k];
    if (k > 0) lag1 += log_gains[k] * log_gains[k - 1];
  }
  const double n = static_cast<double>(log_gains.size());
  const double variance = sum_sq / n - (sum / n) * (sum / n);
  std::printf("exposure: log gain std %.4f (model %.2f), lag-1 correlation %.4f (model %.4f)\n", std::sqrt(variance),
              config.exposure_sigma, lag1 / sum_sq, std::exp(-0.5));
  EXPECT_NEAR(std::sqrt(variance) / config.exposure_sigma, 1.0, 0.04);
  EXPECT_NEAR(lag1 / sum_sq, std::exp(-0.5), 0.03);

  ImageNoiseModel steady(ImageNoiseConfig{}, 3);
  steady.apply(clean, 0);
  steady.apply(clean, 10 * kFrameNs);
  EXPECT_EQ(steady.current_gain(), 1.0);
}

// With exposure changes the gain is rarely 1: noise on top of the scaled intensity, then rounding.
TEST(ImageNoise, IntensityNoiseWithExposureChanges) {
  ImageNoiseConfig config;
  config.exposure_changes = true;
  ImageNoiseModel model(config, 5);
  const cv::Mat clean(480, 640, CV_8UC3, cv::Scalar::all(100));
  double sum = 0.0, sum_sq = 0.0;
  long count = 0;
  for (int k = 0; k < 10; ++k) {
    const cv::Mat noisy = model.apply(clean, k * core::kNsPerSecond);
    const double scaled = static_cast<float>(model.current_gain() * 100.0);
    for (int v = 0; v < noisy.rows; ++v) {
      for (int u = 0; u < noisy.cols * 3; ++u) {
        const double e = noisy.at<std::uint8_t>(v, u) - scaled;
        sum += e;
        sum_sq += e * e;
        ++count;
      }
    }
  }
  const double mean = sum / static_cast<double>(count);
  const double std = std::sqrt(sum_sq / static_cast<double>(count) - mean * mean);
  const double expected = std::sqrt(2.0 * 2.0 + 1.0 / 12.0);
  std::printf("intensity noise with exposure changes: std %.4f, expected %.4f, mean %+.4f\n", std, expected, mean);
  EXPECT_NEAR(model.current_gain(), 1.0, 0.8);
  EXPECT_NE(model.current_gain(), 1.0);
  EXPECT_NEAR(std / expected, 1.0, 0.02);
  EXPECT_LT(std::abs(mean), 0.02);

  ImageNoiseModel a(config, 6), b(config, 6);
  for (int k = 0; k < 3; ++k) {
    const core::TimeNs t_ns = k * core::kNsPerSecond;
    EXPECT_EQ(cv::norm(a.apply(clean, t_ns), b.apply(clean, t_ns), cv::NORM_INF), 0.0);
  }
}

TEST(ImageNoise, SameSeedSameImageAndDisabledIsACopy) {
  cv::Mat clean(480, 640, CV_8UC3);
  cv::randu(clean, cv::Scalar::all(0), cv::Scalar::all(256));
  ImageNoiseModel a(ImageNoiseConfig{}, 4), b(ImageNoiseConfig{}, 4), c(ImageNoiseConfig{}, 5);
  const cv::Mat noisy_a = a.apply(clean, 0);
  EXPECT_EQ(cv::norm(noisy_a, b.apply(clean, 0), cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(noisy_a, c.apply(clean, 0), cv::NORM_INF), 0.0);

  ImageNoiseConfig off;
  off.enabled = false;
  ImageNoiseModel disabled(off, 4);
  const cv::Mat copy = disabled.apply(clean, 0);
  EXPECT_EQ(cv::norm(copy, clean, cv::NORM_INF), 0.0);
  EXPECT_NE(copy.data, clean.data);
}

TEST(ImageNoise, RejectsBadInput) {
  ImageNoiseModel model(ImageNoiseConfig{}, 1);
  EXPECT_THROW(model.apply(cv::Mat(4, 4, CV_32FC1, cv::Scalar(0)), 0), std::invalid_argument);
  model.apply(cv::Mat(4, 4, CV_8UC1, cv::Scalar(0)), 100);
  EXPECT_THROW(model.apply(cv::Mat(4, 4, CV_8UC1, cv::Scalar(0)), 99), std::invalid_argument);
}

// Reports the cost per 640x480 frame; asserts only a generous bound (the machine is shared).
TEST(SensorNoise, VgaFrameCostsAFewMilliseconds) {
  const core::PinholeCamera camera = vga_camera();
  const cv::Mat depth = floor_depth(camera, 0.5) + step_depth(camera);
  cv::Mat rgb(480, 640, CV_8UC3);
  cv::randu(rgb, cv::Scalar::all(0), cv::Scalar::all(256));
  DepthNoiseModel depth_model(DepthNoiseConfig{}, 1);
  ImageNoiseModel image_model(ImageNoiseConfig{}, 1);
  constexpr int kFrames = 30;
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  for (int k = 0; k < kFrames; ++k) depth_model.apply(depth, camera);
  const auto t1 = Clock::now();
  for (int k = 0; k < kFrames; ++k) image_model.apply(rgb, k * 33'000'000);
  const auto t2 = Clock::now();
  const double depth_ms = std::chrono::duration<double, std::milli>(t1 - t0).count() / kFrames;
  const double rgb_ms = std::chrono::duration<double, std::milli>(t2 - t1).count() / kFrames;
  std::printf("per 640x480 frame: depth %.2f ms, rgb %.2f ms\n", depth_ms, rgb_ms);
  EXPECT_LT(depth_ms + rgb_ms, 100.0);
}

}  // namespace
}  // namespace fleetslam::sim
