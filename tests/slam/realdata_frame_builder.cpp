// FrameBuilder on the real sequences under FLEETSLAM_DATA_DIR (skipped when the folder is absent):
// TUM RGB-D freiburg1_rpy (Kinect depth) and the EuRoC V1_01_easy micro excerpt (raw stereo pair,
// rectified by the builder). Prints the shares it checks.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <vector>

#include "fleetslam/core/dataset.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/slam/frame_builder.hpp"

namespace fleetslam::slam {
namespace {

const std::filesystem::path kData = FLEETSLAM_DATA_DIR;
const std::filesystem::path kTum = kData / "tum" / "rgbd_dataset_freiburg1_rpy_200";
const std::filesystem::path kEuroc = kData / "euroc" / "V1_01_easy_micro";

#define SKIP_WITHOUT(folder)                                                                                 \
  if (!std::filesystem::is_directory(folder)) {                                                              \
    GTEST_SKIP() << "real data not found at " << (folder) << " (set FLEETSLAM_DATA_DIR to the shared data)"; \
  }

struct Totals {
  int frames = 0;
  std::size_t features = 0;
  std::size_t min_features = 1u << 30;
  std::size_t with_depth = 0;
  double min_depth_share = 1.0;
  std::size_t plausible = 0;  // with depth in [0.5, 10] m
  std::vector<double> depths;
};

void add(Totals& totals, const FrameBuildResult& result) {
  const Frame& f = result.frame;
  ++totals.frames;
  totals.features += f.size();
  totals.min_features = std::min(totals.min_features, f.size());
  totals.with_depth += static_cast<std::size_t>(result.features_with_depth);
  if (f.size() > 0) {
    totals.min_depth_share =
        std::min(totals.min_depth_share, static_cast<double>(result.features_with_depth) / static_cast<double>(f.size()));
  }
  for (std::size_t i = 0; i < f.size(); ++i) {
    if (!f.has_depth(i)) continue;
    totals.depths.push_back(f.depth_m[i]);
    if (f.depth_m[i] >= 0.5 && f.depth_m[i] <= 10.0) ++totals.plausible;
  }
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

Totals build_every(const std::filesystem::path& root, std::int64_t stride) {
  core::DatasetConfig config;
  config.stride = stride;
  config.load_imu = false;
  const auto source = core::open_dataset(root, std::nullopt, config, core::null_logger());
  const FrameBuilder builder(FrameBuilderConfig{}, source->rig());
  Totals totals;
  while (const auto sensor = source->next()) {
    const FrameBuildResult result = builder.build(*sensor);
    EXPECT_TRUE(result.ok()) << result.reason;
    add(totals, result);
  }
  std::printf("%s: %d frames, %.1f features/frame (min %zu), %.1f %% with depth (frame min %.1f %%), "
              "%.1f %% of those in [0.5, 10] m, median depth %.2f m\n",
              root.filename().c_str(), totals.frames, static_cast<double>(totals.features) / totals.frames,
              totals.min_features, 100.0 * static_cast<double>(totals.with_depth) / static_cast<double>(totals.features),
              100.0 * totals.min_depth_share,
              100.0 * static_cast<double>(totals.plausible) / static_cast<double>(std::max<std::size_t>(1, totals.with_depth)),
              median(totals.depths));
  return totals;
}

TEST(RealDataFrameBuilder, TumFr1RpyRgbdFramesHaveAThousandFeaturesMostlyWithDepth) {
  SKIP_WITHOUT(kTum);
  const Totals t = build_every(kTum, 10);  // 20 frames spread over the 200
  ASSERT_EQ(t.frames, 20);
  EXPECT_GE(t.min_features, 900u);
  EXPECT_GT(static_cast<double>(t.with_depth) / static_cast<double>(t.features), 0.7);
  EXPECT_GT(t.min_depth_share, 0.5);
  EXPECT_GT(median(t.depths), 0.5);
  EXPECT_LT(median(t.depths), 3.0);  // a desk scene
}

TEST(RealDataFrameBuilder, EurocV101StereoFramesHavePlausibleStereoDepth) {
  SKIP_WITHOUT(kEuroc);
  const auto source = core::open_dataset(kEuroc, std::nullopt, {}, core::null_logger());
  EXPECT_TRUE(FrameBuilder(FrameBuilderConfig{}, source->rig()).rectifies()) << "EuRoC's raw cameras need rectifying";
  const Totals t = build_every(kEuroc, 10);  // 10 frames spread over the 95
  ASSERT_GE(t.frames, 9);
  EXPECT_GE(t.min_features, 900u);
  EXPECT_GT(static_cast<double>(t.with_depth) / static_cast<double>(t.features), 0.4);
  EXPECT_GT(static_cast<double>(t.plausible) / static_cast<double>(t.with_depth), 0.9);
  EXPECT_GT(median(t.depths), 1.0);  // a room a few metres across
  EXPECT_LT(median(t.depths), 6.0);
}

}  // namespace
}  // namespace fleetslam::slam
