// Front-end timings: ORB extraction (synthetic 640x480 texture and a real TUM frame) at several
// feature counts, stereo matching of a synthetic rectified pair, and whole FrameBuilder::build calls
// on real RGB-D (TUM fr1_rpy) and stereo (EuRoC V1_01, rectified on the fly) frames.
// Run with repetitions on one core: taskset -c 1 bench_orb --benchmark_repetitions=10. On a shared
// machine the "_min" row (added to every benchmark) is the best estimate of the undisturbed cost.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "fleetslam/core/dataset.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/slam/frame_builder.hpp"
#include "fleetslam/slam/matcher.hpp"
#include "fleetslam/slam/orb_extractor.hpp"
#include "front_end_test_util.hpp"
#include "memory_counter.hpp"

namespace {

using namespace fleetslam;

const std::filesystem::path kData = FLEETSLAM_DATA_DIR;
const std::filesystem::path kTum = kData / "tum" / "rgbd_dataset_freiburg1_rpy_200";
const std::filesystem::path kEuroc = kData / "euroc" / "V1_01_easy_micro";

struct RealFrame {
  core::SensorRig rig;
  core::SensorFrame frame;
};

// The frame `index` of a dataset, or nullopt when the data is absent.
std::optional<RealFrame> real_frame(const std::filesystem::path& root, std::int64_t index) {
  if (!std::filesystem::is_directory(root)) return std::nullopt;
  core::DatasetConfig config;
  config.start_index = index;
  config.stop_index = index + 1;
  config.load_imu = false;
  const auto source = core::open_dataset(root, std::nullopt, config, core::null_logger());
  std::optional<core::SensorFrame> frame = source->next();
  if (!frame) return std::nullopt;
  return RealFrame{source->rig(), *frame};
}

double min_of(const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); }

void BM_OrbSynthetic(benchmark::State& state) {
  slam::OrbExtractorConfig config;
  config.num_features = static_cast<int>(state.range(0));
  const slam::OrbExtractor extractor(config);
  const cv::Mat image = slam::test::textured_image(640, 480, 1);
  std::size_t features = 0;
  for (auto _ : state) {
    const slam::OrbFeatures f = extractor.extract(image);
    features = f.keypoints.size();
    benchmark::DoNotOptimize(f.descriptors.data);
  }
  state.counters["features"] = static_cast<double>(features);
}
BENCHMARK(BM_OrbSynthetic)->Arg(500)->Arg(1000)->Arg(2000)->Unit(benchmark::kMillisecond)->ComputeStatistics("min", min_of);

void BM_OrbTum(benchmark::State& state) {
  const std::optional<RealFrame> real = real_frame(kTum, 0);
  if (!real) {
    state.SkipWithError("TUM fr1_rpy not found under FLEETSLAM_DATA_DIR");
    return;
  }
  slam::OrbExtractorConfig config;
  config.num_features = static_cast<int>(state.range(0));
  const slam::OrbExtractor extractor(config);
  std::size_t features = 0;
  for (auto _ : state) {
    const slam::OrbFeatures f = extractor.extract(real->frame.image);  // BGR, converted inside
    features = f.keypoints.size();
    benchmark::DoNotOptimize(f.descriptors.data);
  }
  state.counters["features"] = static_cast<double>(features);
}
BENCHMARK(BM_OrbTum)->Arg(1000)->Arg(2000)->Unit(benchmark::kMillisecond)->ComputeStatistics("min", min_of);

void BM_MatchStereoSynthetic(benchmark::State& state) {
  const slam::test::StereoScene scene =
      slam::test::make_stereo_scene(640, 480, 48.75, cv::Rect(200, 120, 240, 240), 1.0, 2.5, 3);
  const slam::OrbExtractor extractor{slam::OrbExtractorConfig{}};
  const slam::OrbFeatures left = extractor.extract(scene.left);
  const slam::OrbFeatures right = extractor.extract(scene.right);
  slam::Frame frame;
  frame.pyramid = extractor.pyramid();
  frame.bf = 48.75;
  frame.keypoints = left.keypoints;
  frame.descriptors = left.descriptors;
  int matched = 0;
  for (auto _ : state) {
    matched = slam::match_stereo_levels(frame, left.levels, right.keypoints, right.descriptors, right.levels,
                                        slam::StereoMatchConfig{});
  }
  state.counters["matched"] = matched;
}
BENCHMARK(BM_MatchStereoSynthetic)->Unit(benchmark::kMillisecond)->ComputeStatistics("min", min_of);

void build_frames(benchmark::State& state, const std::filesystem::path& root, const char* name) {
  const std::optional<RealFrame> real = real_frame(root, 10);
  if (!real) {
    state.SkipWithError((std::string(name) + " not found under FLEETSLAM_DATA_DIR").c_str());
    return;
  }
  const slam::FrameBuilder builder(slam::FrameBuilderConfig{}, real->rig);
  int features = 0, with_depth = 0;
  for (auto _ : state) {
    const slam::FrameBuildResult result = builder.build(real->frame);
    features = static_cast<int>(result.frame.size());
    with_depth = result.features_with_depth;
  }
  state.counters["features"] = features;
  state.counters["with_depth"] = with_depth;
}

void BM_FrameBuilderTumRgbd(benchmark::State& state) { build_frames(state, kTum, "TUM fr1_rpy"); }
BENCHMARK(BM_FrameBuilderTumRgbd)->Unit(benchmark::kMillisecond)->ComputeStatistics("min", min_of);

void BM_FrameBuilderEurocStereo(benchmark::State& state) { build_frames(state, kEuroc, "EuRoC V1_01 micro"); }
BENCHMARK(BM_FrameBuilderEurocStereo)->Unit(benchmark::kMillisecond)->ComputeStatistics("min", min_of);

}  // namespace

int main(int argc, char** argv) { return fleetslam::bench::run_benchmarks(argc, argv); }
