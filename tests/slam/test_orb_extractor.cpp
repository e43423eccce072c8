// ORB extractor on synthetic textures: feature count near the target, spread over the image, every
// level used within its share, determinism, no features on empty or flat images, the FAST fallback
// threshold in low-contrast cells, and orientations that turn with the image.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <tuple>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "fleetslam/core/error.hpp"
#include "fleetslam/slam/matcher.hpp"
#include "fleetslam/slam/orb_extractor.hpp"
#include "front_end_test_util.hpp"

namespace fleetslam::slam {
namespace {

OrbFeatures extract(const cv::Mat& image, int num_features = 1000) {
  OrbExtractorConfig config;
  config.num_features = num_features;
  return OrbExtractor(config).extract(image);
}

// Signed difference a - b of two angles in degrees, in (-180, 180].
double angle_difference_deg(double a, double b) {
  double d = std::fmod(a - b, 360.0);
  if (d <= -180.0) d += 360.0;
  if (d > 180.0) d -= 360.0;
  return d;
}

double median(std::vector<double> values) {
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

TEST(OrbExtractor, FeaturesPerLevelAreGeometricAndSumToTarget) {
  OrbExtractorConfig config;
  const OrbExtractor extractor(config);
  const std::vector<int>& share = extractor.features_per_level();
  ASSERT_EQ(share.size(), 8u);
  EXPECT_EQ(std::accumulate(share.begin(), share.end(), 0), 1000);
  EXPECT_EQ(share[0], 217);  // 1000 (1 - 1/1.2) / (1 - 1.2^-8)
  for (std::size_t l = 1; l + 1 < share.size(); ++l) {
    EXPECT_NEAR(share[l], share[l - 1] / 1.2, 1.0) << "level " << l;
  }
  EXPECT_DOUBLE_EQ(extractor.pyramid().scale[2], 1.44);
}

TEST(OrbExtractor, CountIsCloseToTargetAndFeaturesAreWellFormed) {
  const cv::Mat image = test::textured_image(640, 480, 1);
  const OrbFeatures f = extract(image);
  EXPECT_GE(f.keypoints.size(), 950u);
  EXPECT_LE(f.keypoints.size(), 1000u);
  ASSERT_EQ(f.descriptors.rows, static_cast<int>(f.keypoints.size()));
  EXPECT_EQ(f.descriptors.cols, 32);
  EXPECT_EQ(f.descriptors.type(), CV_8UC1);
  ASSERT_EQ(f.levels.size(), 8u);
  EXPECT_EQ(f.levels[3].size(), cv::Size(370, 278));  // round(640 / 1.728), round(480 / 1.728)
  for (const cv::KeyPoint& k : f.keypoints) {
    ASSERT_GE(k.octave, 0);
    ASSERT_LT(k.octave, 8);
    EXPECT_GE(k.pt.x, 0.0f);
    EXPECT_LT(k.pt.x, 640.0f);
    EXPECT_GE(k.pt.y, 0.0f);
    EXPECT_LT(k.pt.y, 480.0f);
    EXPECT_GE(k.angle, 0.0f);
    EXPECT_LT(k.angle, 360.0f);
    EXPECT_GE(k.response, 7.0f);
    EXPECT_EQ(k.class_id, -1);
    EXPECT_NEAR(k.size, 31.0 * std::pow(1.2, k.octave), 1e-3);
  }
}

TEST(OrbExtractor, FeaturesCoverTheImage) {
  const OrbFeatures f = extract(test::textured_image(640, 480, 2));
  std::vector<int> cells(8 * 6, 0);
  for (const cv::KeyPoint& k : f.keypoints) {
    ++cells[static_cast<std::size_t>(static_cast<int>(k.pt.y / 80.0f) * 8 + static_cast<int>(k.pt.x / 80.0f))];
  }
  const auto covered = std::count_if(cells.begin(), cells.end(), [](int c) { return c > 0; });
  EXPECT_GE(covered, 46) << "cells of an 8x6 grid with a feature";
  // Even spread: no cell holds a large part of the features.
  EXPECT_LT(*std::max_element(cells.begin(), cells.end()), 80);
}

TEST(OrbExtractor, EveryLevelContributesWithinItsShare) {
  const OrbExtractor extractor{OrbExtractorConfig{}};
  const OrbFeatures f = extractor.extract(test::textured_image(640, 480, 3));
  std::vector<int> per_level(8, 0);
  for (const cv::KeyPoint& k : f.keypoints) ++per_level[static_cast<std::size_t>(k.octave)];
  for (std::size_t l = 0; l < 8; ++l) {
    EXPECT_LE(per_level[l], extractor.features_per_level()[l]) << "level " << l;
    EXPECT_GE(per_level[l], extractor.features_per_level()[l] * 8 / 10) << "level " << l;
  }
  // Features come level by level.
  EXPECT_TRUE(std::is_sorted(f.keypoints.begin(), f.keypoints.end(),
                             [](const cv::KeyPoint& a, const cv::KeyPoint& b) { return a.octave < b.octave; }));
}

TEST(OrbExtractor, IsDeterministic) {
  const cv::Mat image = test::textured_image(640, 480, 4);
  const OrbFeatures a = extract(image);
  const OrbFeatures b = extract(image.clone());
  ASSERT_EQ(a.keypoints.size(), b.keypoints.size());
  for (std::size_t i = 0; i < a.keypoints.size(); ++i) {
    EXPECT_EQ(a.keypoints[i].pt, b.keypoints[i].pt);
    EXPECT_EQ(a.keypoints[i].angle, b.keypoints[i].angle);
    EXPECT_EQ(a.keypoints[i].octave, b.keypoints[i].octave);
  }
  EXPECT_EQ(cv::norm(a.descriptors, b.descriptors, cv::NORM_HAMMING), 0.0);
}

TEST(OrbExtractor, ColourInputGivesTheSameFeaturesAsGray) {
  const cv::Mat gray = test::textured_image(320, 240, 5);
  cv::Mat bgr;
  cv::cvtColor(gray, bgr, cv::COLOR_GRAY2BGR);
  const OrbFeatures a = extract(gray, 300);
  const OrbFeatures b = extract(bgr, 300);
  ASSERT_EQ(a.keypoints.size(), b.keypoints.size());
  EXPECT_EQ(cv::norm(a.descriptors, b.descriptors, cv::NORM_HAMMING), 0.0);
  EXPECT_THROW(extract(cv::Mat(240, 320, CV_16UC1, cv::Scalar(5))), InputError);
}

TEST(OrbExtractor, EmptyFlatAndTinyImagesGiveNoFeatures) {
  for (const cv::Mat& image : {cv::Mat(), cv::Mat(480, 640, CV_8UC1, cv::Scalar(90)),
                               cv::Mat(30, 30, CV_8UC1, cv::Scalar(0))}) {
    const OrbFeatures f = extract(image);
    EXPECT_TRUE(f.keypoints.empty());
    EXPECT_TRUE(f.descriptors.empty());
  }
}

// Textured images barely larger than the 19 px border (detection areas of 0 to 10 px): no crash, every
// keypoint inside the area, one descriptor per keypoint, the same result twice; 64 px images find corners.
TEST(OrbExtractor, TexturedImagesNearTheBorderSizeKeepFeaturesAndDescriptorsPaired) {
  for (const auto& [width, height] : std::vector<std::pair<int, int>>{{38, 38}, {40, 40}, {41, 45}, {45, 40}, {48, 48},
                                                                      {64, 64}, {200, 40}, {100, 64}, {64, 100}}) {
    const cv::Mat image = test::to_8u(test::texture_float(width, height, 3));
    const OrbFeatures f = extract(image);
    EXPECT_EQ(static_cast<std::size_t>(f.descriptors.rows), f.keypoints.size()) << width << "x" << height;
    for (const cv::KeyPoint& k : f.keypoints) {
      EXPECT_GE(k.pt.x, 0.0f) << width << "x" << height;
      EXPECT_GE(k.pt.y, 0.0f) << width << "x" << height;
      EXPECT_LT(k.pt.x, static_cast<float>(width)) << width << "x" << height;
      EXPECT_LT(k.pt.y, static_cast<float>(height)) << width << "x" << height;
      EXPECT_GE(k.angle, 0.0f);
      EXPECT_LT(k.angle, 360.0f);
    }
    const OrbFeatures again = extract(image);
    ASSERT_EQ(again.keypoints.size(), f.keypoints.size());
    if (!f.descriptors.empty()) {
      EXPECT_EQ(cv::norm(again.descriptors, f.descriptors, cv::NORM_HAMMING), 0.0);
    }
    if (width >= 64 && height >= 64) {
      EXPECT_FALSE(f.keypoints.empty()) << width << "x" << height;
    }
    ::testing::Test::RecordProperty("features_" + std::to_string(width) + "x" + std::to_string(height),
                                    static_cast<int>(f.keypoints.size()));
  }
}

TEST(OrbExtractor, LowContrastCellsFallBackToTheMinimumThreshold) {
  // Left half: full contrast. Right half: a two-tone version of the texture 16 gray levels apart, so that
  // its FAST scores fall between min_fast_threshold (7) and ini_fast_threshold (20).
  const cv::Mat texture = test::texture_float(640, 480, 6);
  cv::Mat two_tone;
  cv::threshold(texture, two_tone, 128.0, 16.0, cv::THRESH_BINARY);
  cv::Mat image = texture.clone();
  cv::Mat(two_tone + 120.0)(cv::Rect(320, 0, 320, 480)).copyTo(image(cv::Rect(320, 0, 320, 480)));
  const auto weak_features = [&](int min_fast_threshold) {
    OrbExtractorConfig config;
    config.min_fast_threshold = min_fast_threshold;
    int weak = 0;
    for (const cv::KeyPoint& k : OrbExtractor(config).extract(test::to_8u(image)).keypoints) {
      if (k.pt.x <= 360.0f || k.octave != 0) continue;
      ++weak;
      EXPECT_LT(k.response, 20.0f);
    }
    return weak;
  };
  EXPECT_GT(weak_features(7), 15);
  EXPECT_EQ(weak_features(20), 0) << "without the fallback the low-contrast half has no level-0 features";
}

// Oracle: FAST over the whole image at the low threshold, then per cell the corners >= ini, or all of
// them in cells without such a corner (what FAST per cell with ORB-SLAM's fallback selects).
std::vector<cv::KeyPoint> per_cell_oracle(const cv::Mat& level, const OrbExtractorConfig& config) {
  std::vector<cv::KeyPoint> all;
  cv::FAST(level, all, config.min_fast_threshold, true, cv::FastFeatureDetector::TYPE_9_16);
  const int w = level.cols - 2 * kOrbEdgePx, h = level.rows - 2 * kOrbEdgePx;
  const int cols = std::max(1, w / config.cell_size_px), rows = std::max(1, h / config.cell_size_px);
  const int cell_w = (w + cols - 1) / cols, cell_h = (h + rows - 1) / rows;
  const auto cell = [&](const cv::KeyPoint& k) {
    return (static_cast<int>(k.pt.y) - kOrbEdgePx) / cell_h * cols + (static_cast<int>(k.pt.x) - kOrbEdgePx) / cell_w;
  };
  const auto inside = [&](const cv::KeyPoint& k) {
    return k.pt.x >= kOrbEdgePx && k.pt.y >= kOrbEdgePx && k.pt.x < level.cols - kOrbEdgePx &&
           k.pt.y < level.rows - kOrbEdgePx;
  };
  std::vector<bool> strong(static_cast<std::size_t>(cols * rows), false);
  for (const cv::KeyPoint& k : all) {
    if (inside(k) && k.response >= static_cast<float>(config.ini_fast_threshold)) strong[static_cast<std::size_t>(cell(k))] = true;
  }
  std::vector<cv::KeyPoint> kept;
  for (const cv::KeyPoint& k : all) {
    if (!inside(k)) continue;
    if (k.response >= static_cast<float>(config.ini_fast_threshold) || !strong[static_cast<std::size_t>(cell(k))]) {
      kept.push_back(k);
    }
  }
  return kept;
}

std::vector<std::tuple<float, float, float>> sorted_corners(const std::vector<cv::KeyPoint>& corners) {
  std::vector<std::tuple<float, float, float>> out;
  for (const cv::KeyPoint& k : corners) out.emplace_back(k.pt.y, k.pt.x, k.response);
  std::sort(out.begin(), out.end());
  return out;
}

TEST(OrbExtractor, CellCornersEqualPerCellFastWithFallback) {
  // A dense texture (no empty cell), one that is mostly flat (most cells empty: one low-threshold pass
  // over the level), and one with a two-tone low-contrast third (runs of empty cells searched apart).
  cv::Mat sparse(480, 640, CV_8UC1, cv::Scalar(100));
  test::textured_image(200, 150, 9).copyTo(sparse(cv::Rect(50, 60, 200, 150)));
  cv::Mat mixed = test::texture_float(640, 480, 10);
  cv::Mat two_tone;
  cv::threshold(mixed, two_tone, 128.0, 12.0, cv::THRESH_BINARY);
  cv::Mat(two_tone + 120.0)(cv::Rect(0, 0, 200, 480)).copyTo(mixed(cv::Rect(0, 0, 200, 480)));
  for (const cv::Mat& image : {test::textured_image(640, 480, 11), sparse, test::to_8u(mixed)}) {
    for (const int cell_size : {30, 45}) {
      OrbExtractorConfig config;
      config.cell_size_px = cell_size;
      const auto found = sorted_corners(detect_level_corners(image, config));
      EXPECT_EQ(found, sorted_corners(per_cell_oracle(image, config))) << "cell size " << cell_size;
      EXPECT_FALSE(found.empty());
    }
  }
}

TEST(OrbExtractor, LevelCoordinatesFollowCvResizePixelCentres) {
  const cv::Size size0(640, 480), half(320, 240);
  const cv::Point2d p = to_level(cv::Point2d(1.5, 3.5), size0, half);
  EXPECT_DOUBLE_EQ(p.x, 0.5);
  EXPECT_DOUBLE_EQ(p.y, 1.5);
  const cv::Point2d back = to_level0(cv::Point2d(123.25, 77.5), size0, cv::Size(179, 134));
  const cv::Point2d again = to_level(back, size0, cv::Size(179, 134));
  EXPECT_NEAR(again.x, 123.25, 1e-12);
  EXPECT_NEAR(again.y, 77.5, 1e-12);
}

TEST(OrbExtractor, QuarterTurnTurnsOrientationsByNinetyDegrees) {
  const cv::Mat image = test::textured_image(640, 480, 7);
  cv::Mat turned;
  cv::rotate(image, turned, cv::ROTATE_90_CLOCKWISE);  // (x, y) -> (479 - y, x)
  const OrbFeatures a = extract(image);
  const OrbFeatures b = extract(turned);
  int pairs = 0;
  std::vector<double> distances;
  for (std::size_t i = 0; i < a.keypoints.size(); ++i) {
    const cv::KeyPoint& ka = a.keypoints[i];
    if (ka.octave != 0) continue;
    const cv::Point2f expected(479.0f - ka.pt.y, ka.pt.x);
    for (std::size_t j = 0; j < b.keypoints.size(); ++j) {
      const cv::KeyPoint& kb = b.keypoints[j];
      if (kb.octave != 0 || cv::norm(kb.pt - expected) > 0.01) continue;
      ++pairs;
      // Image y points down: a clockwise quarter turn adds 90 degrees.
      EXPECT_NEAR(angle_difference_deg(kb.angle, ka.angle), 90.0, 1e-3);
      distances.push_back(static_cast<double>(hamming_distance(a.descriptors.ptr<std::uint8_t>(static_cast<int>(i)),
                                                               b.descriptors.ptr<std::uint8_t>(static_cast<int>(j)))));
    }
  }
  EXPECT_GE(pairs, 100);
  EXPECT_LT(median(distances), 20.0) << "rBRIEF steered by the angle is rotation invariant";
}

TEST(OrbExtractor, ArbitraryRotationShiftsOrientations) {
  const cv::Mat image = test::textured_image(640, 480, 8);
  const double angle_deg = 30.0;  // counter-clockwise on screen
  const cv::Mat M = cv::getRotationMatrix2D(cv::Point2f(319.5f, 239.5f), angle_deg, 1.0);
  cv::Mat turned;
  cv::warpAffine(image, turned, M, image.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT_101);
  const OrbFeatures a = extract(image);
  const OrbFeatures b = extract(turned);
  std::vector<double> shifts;
  for (const cv::KeyPoint& ka : a.keypoints) {
    const cv::Point2d q(ka.pt);
    const cv::Point2d p(M.at<double>(0, 0) * q.x + M.at<double>(0, 1) * q.y + M.at<double>(0, 2),
                        M.at<double>(1, 0) * q.x + M.at<double>(1, 1) * q.y + M.at<double>(1, 2));
    if (std::hypot(p.x - 319.5, p.y - 239.5) > 200.0) continue;  // away from the reflected corners
    for (const cv::KeyPoint& kb : b.keypoints) {
      if (kb.octave == ka.octave && cv::norm(cv::Point2d(kb.pt) - p) < 1.0) {
        shifts.push_back(angle_difference_deg(kb.angle, ka.angle));
      }
    }
  }
  ASSERT_GE(shifts.size(), 50u);
  // Counter-clockwise on screen is clockwise in image coordinates (y down): angles drop by 30 degrees.
  EXPECT_NEAR(median(shifts), -angle_deg, 2.0);
  const auto close = std::count_if(shifts.begin(), shifts.end(), [&](double s) { return std::abs(s + angle_deg) < 10.0; });
  EXPECT_GE(close, static_cast<long>(shifts.size() * 8 / 10));
}

TEST(OrbExtractor, RejectsInconsistentThresholds) {
  OrbExtractorConfig config;
  config.min_fast_threshold = 30;
  EXPECT_THROW(OrbExtractor{config}, InputError);
}

}  // namespace
}  // namespace fleetslam::slam
