// Place recognition with the shipped vocabulary (data/vocabulary/orb_default.fsvoc, k = 10, L = 4,
// 9973 words): loading it, turning one frame's ORB descriptors into a BoW vector (500 / 1000 / 2000
// descriptors; the vector alone, and with the direct index keyframes get), indexing 100 / 1000 / 5000
// keyframes in a keyframe database, and a query for all candidates (as relocalisation asks) of each.
// peak_MiB (memory_counter.hpp) of the build is the database's size; of the query, the query's own.
//
// Descriptors are real: TUM fr1_rpy frames under FLEETSLAM_DATA_DIR (synthetic textures from the slam
// tests' helper when the data is absent; the label says which). The database holds keyframes made from
// the even frames 0..198, each added many times with its descriptors perturbed (a few bits flipped per
// descriptor, seeded by the keyframe's index), like a long run revisiting the room; queries cycle over
// the odd frames, which are not in the database. Everything is seeded: the same build gives the same work.
//
// Usage: bench_place_recognition [google-benchmark flags]; the first database benchmark spends a few
// seconds extracting 100 frames and transforming 5000 keyframes (once, cached).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "fleetslam/core/dataset.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/slam/keyframe_database.hpp"
#include "fleetslam/slam/orb_extractor.hpp"
#include "fleetslam/slam/place_recognition.hpp"
#include "fleetslam/slam/vocabulary.hpp"
#include "front_end_test_util.hpp"
#include "memory_counter.hpp"

namespace {

using namespace fleetslam;

const std::filesystem::path kTum = std::filesystem::path(FLEETSLAM_DATA_DIR) / "tum" / "rgbd_dataset_freiburg1_rpy_200";
constexpr int kFrames = 200;          // frames of the source: even ones make keyframes, odd ones query
constexpr int kBitsFlipped = 4;       // per descriptor of a revisiting keyframe (of 256)
constexpr int kLevelsUp = 2;          // PlaceRecognitionConfig's default direct-index depth

double min_of(const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); }

const slam::Vocabulary& vocabulary() {
  static const slam::Vocabulary loaded = slam::Vocabulary::load(slam::default_vocabulary_path());
  return loaded;
}

// The source images: the TUM frames, or synthetic textures (seeded by the index) without the data.
struct Images {
  std::vector<cv::Mat> images;
  std::string label;
};

const Images& images() {
  static const Images loaded = [] {
    Images out;
    if (std::filesystem::is_directory(kTum)) {
      core::DatasetConfig config;
      config.stop_index = kFrames;
      config.load_imu = false;
      const auto source = core::open_dataset(kTum, std::nullopt, config, core::null_logger());
      while (std::optional<core::SensorFrame> frame = source->next()) out.images.push_back(frame->image);
      out.label = "TUM fr1_rpy";
    }
    if (out.images.empty()) {
      for (int i = 0; i < kFrames; ++i) out.images.push_back(slam::test::textured_image(640, 480, 100 + i));
      out.label = "synthetic texture";
    }
    return out;
  }();
  return loaded;
}

// The ORB descriptors of a source image with a feature budget (cached per image and budget).
const cv::Mat& descriptors(std::size_t image, int features) {
  static std::map<std::pair<std::size_t, int>, cv::Mat> cache;
  cv::Mat& d = cache[{image, features}];
  if (d.empty()) {
    slam::OrbExtractorConfig config;
    config.num_features = features;
    d = slam::OrbExtractor(config).extract(images().images.at(image)).descriptors;
  }
  return d;
}

cv::Mat perturbed(const cv::Mat& d, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> bit(0, slam::kDescriptorBytes * 8 - 1);
  cv::Mat out = d.clone();
  for (int r = 0; r < out.rows; ++r) {
    for (int i = 0; i < kBitsFlipped; ++i) {
      const int b = bit(rng);
      out.at<std::uint8_t>(r, b / 8) = static_cast<std::uint8_t>(out.at<std::uint8_t>(r, b / 8) ^ (1u << (b % 8)));
    }
  }
  return out;
}

// The BoW vectors of keyframes 0..n-1 (1000 features each), shared by all database sizes.
const std::vector<slam::BowVector>& keyframe_bows(std::size_t n) {
  static std::vector<slam::BowVector> bows;
  const std::size_t sources = images().images.size() / 2;
  while (bows.size() < n) {
    const std::size_t k = bows.size();
    const cv::Mat& d = descriptors(2 * (k % sources), 1000);
    bows.push_back(vocabulary().bow(k < sources ? d : perturbed(d, static_cast<std::uint32_t>(k))));
  }
  return bows;
}

// The query vectors: the odd frames, 1000 features each.
const std::vector<slam::BowVector>& query_bows() {
  static const std::vector<slam::BowVector> bows = [] {
    std::vector<slam::BowVector> out;
    for (std::size_t i = 1; i < images().images.size(); i += 2) out.push_back(vocabulary().bow(descriptors(i, 1000)));
    return out;
  }();
  return bows;
}

void BM_VocabularyLoad(benchmark::State& state) {
  std::size_t words = 0;
  for (auto _ : state) {
    const slam::Vocabulary v = slam::Vocabulary::load(slam::default_vocabulary_path());
    words = v.words();
    benchmark::DoNotOptimize(words);
  }
  state.counters["words"] = static_cast<double>(words);
  state.counters["file_MiB"] =
      static_cast<double>(std::filesystem::file_size(slam::default_vocabulary_path())) / (1024.0 * 1024.0);
}
BENCHMARK(BM_VocabularyLoad)->Unit(benchmark::kMillisecond)->ComputeStatistics("min", min_of);

// One frame (source image 10) with a feature budget of range(0) descriptors.
void BM_BowVector(benchmark::State& state) {
  const cv::Mat& d = descriptors(10, static_cast<int>(state.range(0)));
  const slam::Vocabulary& v = vocabulary();
  std::size_t words = 0;
  for (auto _ : state) {
    const slam::BowVector bow = v.bow(d);
    words = bow.size();
    benchmark::DoNotOptimize(bow.entries.data());
  }
  state.SetLabel(images().label);
  state.counters["descriptors"] = d.rows;
  state.counters["words"] = static_cast<double>(words);
}
BENCHMARK(BM_BowVector)->Arg(500)->Arg(1000)->Arg(2000)->Unit(benchmark::kMicrosecond)->ComputeStatistics("min", min_of);

// The same with the direct index (FeatureVector) that keyframes and BoW matching use.
void BM_BowTransform(benchmark::State& state) {
  const cv::Mat& d = descriptors(10, static_cast<int>(state.range(0)));
  const slam::Vocabulary& v = vocabulary();
  std::size_t nodes = 0;
  for (auto _ : state) {
    const slam::BowTransform t = v.transform(d, kLevelsUp);
    nodes = t.features.size();
    benchmark::DoNotOptimize(t.bow.entries.data());
  }
  state.SetLabel(images().label);
  state.counters["descriptors"] = d.rows;
  state.counters["index_nodes"] = static_cast<double>(nodes);
}
BENCHMARK(BM_BowTransform)->Arg(500)->Arg(1000)->Arg(2000)->Unit(benchmark::kMicrosecond)->ComputeStatistics("min", min_of);

slam::KeyframeDatabase make_database(std::size_t n) {
  const std::vector<slam::BowVector>& bows = keyframe_bows(n);
  slam::KeyframeDatabase database;
  for (std::size_t k = 0; k < n; ++k) database.add(static_cast<slam::KeyframeId>(k), bows[k]);
  return database;
}

// Indexing range(0) keyframes into an empty database: its peak_MiB is the database's size (with the
// vectors it copies).
void BM_KeyframeDatabaseBuild(benchmark::State& state) {
  const auto n = static_cast<std::size_t>(state.range(0));
  keyframe_bows(n);  // made before the timed loop
  for (auto _ : state) {
    const slam::KeyframeDatabase database = make_database(n);
    benchmark::DoNotOptimize(database.size());
  }
  state.counters["keyframes"] = static_cast<double>(n);
}
BENCHMARK(BM_KeyframeDatabaseBuild)->Arg(100)->Arg(1000)->Arg(5000)->Unit(benchmark::kMillisecond)->ComputeStatistics("min", min_of);

// One query per iteration (cycling over the query frames) against range(0) keyframes, all candidates.
// The database is built once per size and kept, so peak_MiB is the query's own.
void BM_KeyframeDatabaseQuery(benchmark::State& state) {
  const auto n = static_cast<std::size_t>(state.range(0));
  static std::map<std::size_t, slam::KeyframeDatabase> databases;
  if (databases.count(n) == 0) databases.emplace(n, make_database(n));
  const slam::KeyframeDatabase& database = databases.at(n);
  const std::vector<slam::BowVector>& queries = query_bows();
  slam::PlaceQuery options;
  options.max_results = 0;
  std::size_t q = 0;
  std::int64_t candidates = 0;
  for (auto _ : state) {
    const std::vector<slam::PlaceCandidate> found = database.query(queries[q], options);
    candidates += static_cast<std::int64_t>(found.size());
    q = (q + 1) % queries.size();
  }
  state.SetLabel(images().label);
  state.counters["keyframes"] = static_cast<double>(database.size());
  state.counters["candidates"] =
      benchmark::Counter(static_cast<double>(candidates), benchmark::Counter::kAvgIterations);
}
BENCHMARK(BM_KeyframeDatabaseQuery)->Arg(100)->Arg(1000)->Arg(5000)->Unit(benchmark::kMicrosecond)->ComputeStatistics("min", min_of);

}  // namespace

int main(int argc, char** argv) { return fleetslam::bench::run_benchmarks(argc, argv); }
