// Paper Table 1 in kind (PAPER.md section 2): time of one match between adjacent frames for OpenCV's
// brute force (BFMatcher, NORM_HAMMING, knn 2 + ratio), FLANN (LSH index, knn 2 + ratio), the
// single-stage projection matcher (ORB-SLAM style) and the paper's cross-validation, at 250, 1000 and
// 2000 features; fleetslam's own brute-force reference is timed too. Precision (share of matches whose
// A feature lies within 3 px of the B feature's ground-truth point projected with the true pose) and
// recall (correct matches / points with a feature in both frames) are printed as counters.
//
// Synthetic adjacent frames (TUM-like 640x480 camera at 30 Hz): random points spread over the image at
// 0.8-5 m, 85 % seen in both frames, ORB's share of features per pyramid level, pixel noise growing with
// the level, 1 % depth noise, descriptors a random 256-bit string per point with 3-18 bits flipped per
// view, and 20 % of points repeating the previous point's texture 8-25 px beside it (a copy of its
// descriptor with 6 bits flipped, about its depth): locally ambiguous, as on shelves and tiled floors. The projection
// matchers get a motion-model prediction that is off by about 1 px. A second, ambiguous scene
// (ambiguous:1) has 40 % of points in one frame only and 50 % repeated texture: more chances for the
// single-stage matcher to pair a feature with a look-alike neighbour whose own match is missing. OpenCV
// runs on one thread, like the projection matchers.
//
// Usage: bench_matching [--iterations=N] [google-benchmark flags]. With --benchmark_repetitions on a shared
// machine the "_min" row (added to every benchmark) is the best estimate of the undisturbed cost.
// --iterations=N runs every selected benchmark exactly N iterations (no calibration runs): repeatable
// instruction counts under callgrind, counting only the matcher (scene generation and precision counters
// excluded), e.g.
//   valgrind --tool=callgrind --toggle-collect='fleetslam::slam::match_by_projection*'
//            bench_matching --iterations=20 --benchmark_filter='BM_CrossValidation/features:1000/ambiguous:0/'
// and total Ir / 20 is one match.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <map>
#include <utility>
#include <random>
#include <vector>

#include <opencv2/core/utility.hpp>

#include "fleetslam/experiments/matchers.hpp"
#include "fleetslam/slam/matcher.hpp"
#include "memory_counter.hpp"

namespace {

using fleetslam::slam::FeaturePoints;
using fleetslam::slam::Frame;
using fleetslam::slam::Match;
using fleetslam::slam::MatchResult;
using fleetslam::slam::MatcherConfig;

constexpr double kCorrectPx = 3.0;  // PAPER.md: consistent with the true pose and depth within 3 px

fleetslam::core::PinholeCamera tum_camera() { return {640, 480, 517.3, 516.5, 318.6, 255.3}; }

// The frames, points and transforms as `fleetslam experiment matching` takes them (a, b, p_a, p_b,
// T_a_b_true, T_a_b_predicted), with the synthetic scene's truth.
struct Pair : fleetslam::experiments::MatchPair {
  std::vector<Eigen::Vector3d> truth_b;  // ground-truth point of each B feature, B's camera frame
  std::vector<int> id_a;                 // ground-truth point index of each feature
  std::vector<int> id_b;
  int covisible = 0;
};

using Descriptor = std::array<std::uint8_t, 32>;

Descriptor random_descriptor(std::mt19937& rng) {
  Descriptor d{};
  std::uniform_int_distribution<int> byte(0, 255);
  for (auto& x : d) x = static_cast<std::uint8_t>(byte(rng));
  return d;
}

Descriptor flipped(Descriptor d, int count, std::mt19937& rng) {
  std::uniform_int_distribution<int> bit(0, 255);
  for (int i = 0; i < count; ++i) {
    const int b = bit(rng);
    d[static_cast<std::size_t>(b / 8)] ^= static_cast<std::uint8_t>(1U << (b % 8));
  }
  return d;
}

struct FeatureSpec {
  Eigen::Vector2d uv;
  int level;
  float angle_deg;
  Descriptor descriptor;
  double depth_m;
};

void add_feature(Frame& frame, const FeatureSpec& f, std::vector<Descriptor>& rows) {
  frame.uv.push_back(f.uv);
  frame.level.push_back(f.level);
  frame.keypoints.emplace_back(static_cast<float>(f.uv.x()), static_cast<float>(f.uv.y()), 31.0F, f.angle_deg, 0.0F,
                               f.level);
  frame.depth_m.push_back(f.depth_m);
  frame.u_right.push_back(-1.0);
  rows.push_back(f.descriptor);
}

void finish_frame(Frame& frame, const std::vector<Descriptor>& rows) {
  frame.descriptors = cv::Mat(static_cast<int>(rows.size()), 32, CV_8UC1);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    std::copy(rows[i].begin(), rows[i].end(), frame.descriptors.ptr<std::uint8_t>(static_cast<int>(i)));
  }
  frame.finalize();
}

Frame empty_frame() {
  Frame frame;
  frame.camera = tum_camera();
  frame.pyramid = fleetslam::slam::ScalePyramid::make(8, 1.2);
  return frame;
}

// How much of the scene is ambiguous: points seen in one frame only and repeated texture.
struct Ambiguity {
  double one_view = 0.15;  // share of points seen in A only or B only (half each)
  double repeated = 0.2;   // share of points repeating the previous point's texture nearby
};
constexpr Ambiguity kAdjacent{};
constexpr Ambiguity kAmbiguous{0.4, 0.5};

// `features` features per frame; points are drawn until both frames hold that many.
Pair make_adjacent_pair(int features, const Ambiguity& ambiguity, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 639.0), v(0.0, 479.0), depth(0.8, 5.0), unit(0.0, 1.0);
  std::uniform_real_distribution<double> angle(0.0, 360.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_int_distribution<int> flips(3, 18);
  std::discrete_distribution<int> level({1.0, 0.833, 0.694, 0.579, 0.482, 0.402, 0.335, 0.279});
  Pair pair;
  pair.a = empty_frame();
  pair.b = empty_frame();
  pair.T_a_b_true = Eigen::Translation3d(0.015, -0.005, 0.01) *
                    Eigen::AngleAxisd(0.012, Eigen::Vector3d(0.3, 1.0, 0.1).normalized());
  pair.T_a_b_predicted = pair.T_a_b_true * Eigen::Translation3d(0.002, 0.001, -0.002) *
                         Eigen::AngleAxisd(0.002, Eigen::Vector3d(1.0, 0.2, 0.0).normalized());
  const Eigen::Isometry3d T_b_a = pair.T_a_b_true.inverse();
  const auto camera = tum_camera();
  std::vector<Descriptor> rows_a, rows_b;
  const auto pixel_noise = [&](int l) -> Eigen::Vector2d { return 0.5 * std::pow(1.2, l) * Eigen::Vector2d(gauss(rng), gauss(rng)); };
  Eigen::Vector2d last_uv(320.0, 240.0);
  double last_z = 2.0;
  Descriptor last_base{};
  while (static_cast<int>(rows_a.size()) < features || static_cast<int>(rows_b.size()) < features) {
    // Repeated texture: a copy of the previous point's descriptor 8-25 px beside it at about its depth.
    const bool repeated = !rows_a.empty() && unit(rng) < ambiguity.repeated;
    const double offset_px = 8.0 + 17.0 * unit(rng), offset_dir = 6.283185307179586 * unit(rng);
    const Eigen::Vector2d uv_a =
        repeated ? Eigen::Vector2d(last_uv + offset_px * Eigen::Vector2d(std::cos(offset_dir), std::sin(offset_dir)))
                 : Eigen::Vector2d(u(rng), v(rng));
    const double z = repeated ? last_z * (1.0 + 0.05 * gauss(rng)) : depth(rng);
    const Descriptor base = repeated ? flipped(last_base, 6, rng) : random_descriptor(rng);
    last_uv = uv_a;
    last_z = z;
    last_base = base;
    if (!camera.in_image(uv_a)) continue;
    const Eigen::Vector3d p_a((uv_a.x() - camera.cx()) / camera.fx() * z, (uv_a.y() - camera.cy()) / camera.fy() * z, z);
    const Eigen::Vector3d p_b = T_b_a * p_a;
    const auto uv_b = camera.project(p_b);
    const int l = level(rng);
    const auto a_deg = static_cast<float>(angle(rng));
    const double share = unit(rng);
    const bool in_a = share < 1.0 - ambiguity.one_view / 2.0 && static_cast<int>(rows_a.size()) < features;
    const bool in_b = share >= ambiguity.one_view / 2.0 && uv_b && camera.in_image(*uv_b) && static_cast<int>(rows_b.size()) < features;
    const int id = static_cast<int>(pair.id_a.size() + pair.id_b.size());  // unique per point
    if (in_a) pair.id_a.push_back(id);
    if (in_a) add_feature(pair.a, {uv_a + pixel_noise(l), l, a_deg, flipped(base, flips(rng), rng), z * (1.0 + 0.01 * gauss(rng))}, rows_a);
    if (in_b) {
      add_feature(pair.b, {*uv_b + pixel_noise(l), l, static_cast<float>(static_cast<double>(a_deg) + 3.0 * gauss(rng)), flipped(base, flips(rng), rng),
                           p_b.z() * (1.0 + 0.01 * gauss(rng))}, rows_b);
      pair.truth_b.push_back(p_b);
      pair.id_b.push_back(id);
    }
    pair.covisible += (in_a && in_b) ? 1 : 0;
  }
  finish_frame(pair.a, rows_a);
  finish_frame(pair.b, rows_b);
  pair.p_a = fleetslam::slam::points_from_depth(pair.a);
  pair.p_b = fleetslam::slam::points_from_depth(pair.b);
  return pair;
}

// Benchmark arguments: features per frame, and 1 for the ambiguous scene.
const Pair& pair_for(const benchmark::State& state) {
  static std::map<std::pair<int, int>, Pair> pairs;  // one scene per argument pair, built outside the timed loops
  const auto key = std::make_pair(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  auto it = pairs.find(key);
  if (it == pairs.end()) {
    const Ambiguity& ambiguity = key.second == 0 ? kAdjacent : kAmbiguous;
    it = pairs.emplace(key, make_adjacent_pair(key.first, ambiguity, 2024U + static_cast<unsigned>(key.first))).first;
  }
  return it->second;
}

bool correct(const Pair& pair, const Match& m) {
  const auto uv = pair.a.camera.project(pair.T_a_b_true * pair.truth_b[static_cast<std::size_t>(m.b)]);
  return uv && (*uv - pair.a.uv[static_cast<std::size_t>(m.a)]).norm() <= kCorrectPx;
}

void report(benchmark::State& state, const Pair& pair, const std::vector<Match>& matches) {
  const auto good = std::count_if(matches.begin(), matches.end(), [&](const Match& m) { return correct(pair, m); });
  state.counters["matches"] = static_cast<double>(matches.size());
  state.counters["precision"] = matches.empty() ? 0.0 : static_cast<double>(good) / static_cast<double>(matches.size());
  state.counters["recall"] = static_cast<double>(good) / static_cast<double>(std::max(1, pair.covisible));
  const auto same_point = std::count_if(matches.begin(), matches.end(), [&](const Match& m) {
    return pair.id_a[static_cast<std::size_t>(m.a)] == pair.id_b[static_cast<std::size_t>(m.b)];
  });
  state.counters["id_precision"] = matches.empty() ? 0.0 : static_cast<double>(same_point) / static_cast<double>(matches.size());
}

// The OpenCV matchers as the experiment runs them (tools/experiments/matchers.hpp): B's descriptors against
// A's, two nearest neighbours, Lowe's ratio 0.8; FLANN builds its LSH index over A in every match, as between
// two new frames.
void run_opencv(benchmark::State& state, fleetslam::experiments::MatcherKind kind) {
  const Pair& pair = pair_for(state);
  const fleetslam::experiments::MatchSettings settings;
  std::vector<Match> matches;
  for (auto _ : state) {
    matches = fleetslam::experiments::run_matcher(kind, pair, settings);
    benchmark::DoNotOptimize(matches.data());
  }
  report(state, pair, matches);
}

void BM_BruteForceOpenCV(benchmark::State& state) { run_opencv(state, fleetslam::experiments::MatcherKind::kBruteForceOpenCv); }
void BM_FlannLsh(benchmark::State& state) { run_opencv(state, fleetslam::experiments::MatcherKind::kFlannLsh); }

void BM_BruteForceFleetslam(benchmark::State& state) {
  const Pair& pair = pair_for(state);
  MatchResult result;
  for (auto _ : state) {
    result = fleetslam::slam::match_brute_force(pair.a, pair.b, MatcherConfig{});
    benchmark::DoNotOptimize(result.matches.data());
  }
  report(state, pair, result.matches);
}

void run_projection(benchmark::State& state, bool cross_validation) {
  const Pair& pair = pair_for(state);
  MatcherConfig config;
  config.cross_validation = cross_validation;
  MatchResult result;
  for (auto _ : state) {
    result = fleetslam::slam::match_by_projection(pair.a, pair.p_a, pair.b, pair.p_b, pair.T_a_b_predicted, config);
    benchmark::DoNotOptimize(result.matches.data());
  }
  report(state, pair, result.matches);
  state.counters["rejected"] = result.rejected_by_cross_check;
}

void BM_ProjectionSingleStage(benchmark::State& state) { run_projection(state, false); }
void BM_CrossValidation(benchmark::State& state) { run_projection(state, true); }

void sizes(benchmark::internal::Benchmark* b) {
  b->ArgNames({"features", "ambiguous"});
  for (const int ambiguous : {0, 1}) {
    for (const int features : {250, 1000, 2000}) b->Args({features, ambiguous});
  }
}

double min_of(const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); }

// iterations > 0: exactly that many per benchmark (see the usage above); 0: Google Benchmark decides.
void register_benchmarks(benchmark::IterationCount iterations) {
  const std::pair<const char*, void (*)(benchmark::State&)> benchmarks[] = {
      {"BM_BruteForceOpenCV", BM_BruteForceOpenCV},
      {"BM_FlannLsh", BM_FlannLsh},
      {"BM_ProjectionSingleStage", BM_ProjectionSingleStage},
      {"BM_CrossValidation", BM_CrossValidation},
      {"BM_BruteForceFleetslam", BM_BruteForceFleetslam},
  };
  for (const auto& [name, function] : benchmarks) {
    auto* b = benchmark::RegisterBenchmark(name, function)->Apply(sizes)->Unit(benchmark::kMillisecond)->ComputeStatistics("min", min_of);
    if (iterations > 0) b->Iterations(iterations);
  }
}

// Removes --iterations=N from argv (Google Benchmark rejects flags it does not know); 0 when absent.
benchmark::IterationCount take_iterations_flag(int& argc, char** argv) {
  constexpr const char* kFlag = "--iterations=";
  benchmark::IterationCount iterations = 0;
  int kept = 1;
  for (int i = 1; i < argc; ++i) {
    if (std::strncmp(argv[i], kFlag, std::strlen(kFlag)) == 0) {
      iterations = std::max<benchmark::IterationCount>(1, std::atoll(argv[i] + std::strlen(kFlag)));
    } else {
      argv[kept++] = argv[i];
    }
  }
  argc = kept;
  return iterations;
}

}  // namespace

int main(int argc, char** argv) {
  cv::setNumThreads(1);  // the projection matchers are single-threaded; compare per core
  register_benchmarks(take_iterations_flag(argc, argv));
  return fleetslam::bench::run_benchmarks(argc, argv);
}
