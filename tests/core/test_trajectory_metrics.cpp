#include <gtest/gtest.h>

#include <limits>

#include <algorithm>
#include <cmath>
#include <random>
#include <tuple>

#include "fleetslam/core/error.hpp"
#include "fleetslam/core/trajectory_metrics.hpp"

namespace fleetslam::core {
namespace {

constexpr double kPi = 3.14159265358979323846;

Eigen::Isometry3d pose(const Eigen::Vector3d& t, const Eigen::Vector3d& rotation_vector) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const double angle = rotation_vector.norm();
  if (angle > 0.0) T.linear() = Eigen::AngleAxisd(angle, rotation_vector / angle).toRotationMatrix();
  T.translation() = t;
  return T;
}

// A smooth 3D path (a helix with wobble) with turning orientation, at `period_ns`.
Trajectory synthetic_ground_truth(std::size_t n, TimeNs period_ns) {
  Trajectory gt;
  for (std::size_t i = 0; i < n; ++i) {
    const double s = 0.05 * static_cast<double>(i);
    const Eigen::Vector3d t(3.0 * std::cos(s), 2.0 * std::sin(s), 0.3 * s + 0.2 * std::sin(3.0 * s));
    gt.push_back({static_cast<TimeNs>(i) * period_ns + 1'000'000'000, pose(t, Eigen::Vector3d(0.1 * s, 0.2, s))});
  }
  return gt;
}

// The estimate of a mapping into another frame: p_est = (p_gt - t) R^T / scale, plus noise.
Trajectory transformed(const Trajectory& gt, const Eigen::Isometry3d& T_gt_est, double scale, double noise_m,
                       std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_m);
  Trajectory est = gt;
  const Eigen::Isometry3d T_est_gt = T_gt_est.inverse();
  for (StampedPose& p : est) {
    Eigen::Isometry3d T = T_est_gt * p.T_world_body;
    T.translation() = T_est_gt.linear() * p.T_world_body.translation() / scale +
                      T_est_gt.translation() / scale + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    p.T_world_body = T;
  }
  return est;
}

// ---- association ----

// The definition, implemented the slow way: repeatedly take the closest remaining candidate.
std::vector<PosePair> associate_oracle(const Trajectory& gt, const Trajectory& est, TimeNs max_ns, TimeNs offset_ns) {
  std::vector<bool> gt_used(gt.size()), est_used(est.size());
  std::vector<PosePair> pairs;
  while (true) {
    std::tuple<TimeNs, TimeNs, TimeNs> best{max_ns, 0, 0};
    std::optional<PosePair> best_pair;
    for (std::size_t g = 0; g < gt.size(); ++g) {
      for (std::size_t e = 0; e < est.size(); ++e) {
        if (gt_used[g] || est_used[e]) continue;
        const TimeNs d = std::abs(gt[g].t_ns - (est[e].t_ns + offset_ns));
        const auto key = std::make_tuple(d, gt[g].t_ns, est[e].t_ns);
        if (d < max_ns && (!best_pair || key < best)) {
          best = key;
          best_pair = PosePair{g, e};
        }
      }
    }
    if (!best_pair) break;
    gt_used[best_pair->gt_index] = est_used[best_pair->est_index] = true;
    pairs.push_back(*best_pair);
  }
  std::sort(pairs.begin(), pairs.end(), [](auto& a, auto& b) { return a.gt_index < b.gt_index; });
  return pairs;
}

// Stamps on a coarse 5 ms grid so that equal differences (ties) are common.
Trajectory random_stamps(std::size_t n, std::mt19937& rng) {
  std::uniform_int_distribution<int> step(1, 8);
  Trajectory t;
  TimeNs t_ns = 0;
  for (std::size_t i = 0; i < n; ++i) {
    t_ns += step(rng) * 5'000'000;
    t.push_back({t_ns, Eigen::Isometry3d::Identity()});
  }
  return t;
}

TEST(Association, MatchesBruteForceOracleWithTies) {
  std::mt19937 rng(1234);
  for (int trial = 0; trial < 30; ++trial) {
    const Trajectory gt = random_stamps(120, rng);
    const Trajectory est = random_stamps(90, rng);
    const TimeNs offset_ns = trial % 3 == 0 ? 5'000'000 : 0;
    const TimeAssociationConfig config{20'000'000, offset_ns};
    const auto pairs = associate_by_time(gt, est, config);
    EXPECT_EQ(pairs, associate_oracle(gt, est, config.max_difference_ns, offset_ns)) << "trial " << trial;
    EXPECT_FALSE(pairs.empty());
  }
}

TEST(Association, MaxDifferenceIsStrictAndOffsetShiftsTheEstimate) {
  const Trajectory gt{{100, {}}, {200, {}}};
  const Trajectory est{{80, {}}, {230, {}}};
  EXPECT_EQ(associate_by_time(gt, est, {20, 0}), (std::vector<PosePair>{}));  // |100-80| = 20 is not < 20
  EXPECT_EQ(associate_by_time(gt, est, {21, 0}), (std::vector<PosePair>{{0, 0}}));
  EXPECT_EQ(associate_by_time(gt, est, {5, 20}), (std::vector<PosePair>{{0, 0}}));     // 80 + 20 = 100
  EXPECT_EQ(associate_by_time(gt, est, {5, -30}), (std::vector<PosePair>{{1, 1}}));    // 230 - 30 = 200
}

// Stamps near the ends of int64: the search window is clamped, not wrapped (it wrapped negative and
// nothing was paired, by undefined behaviour).
TEST(Association, StampsNearTheEndsOfTheRangePair) {
  constexpr TimeNs kMax = std::numeric_limits<TimeNs>::max();
  constexpr TimeNs kMin = std::numeric_limits<TimeNs>::min();
  const Trajectory high_gt{{kMax - 10, {}}};
  const Trajectory high_est{{kMax - 5, {}}};
  EXPECT_EQ(associate_by_time(high_gt, high_est, {20'000'000, 0}), (std::vector<PosePair>{{0, 0}}));
  const Trajectory low_gt{{kMin + 10, {}}};
  const Trajectory low_est{{kMin + 5, {}}};
  EXPECT_EQ(associate_by_time(low_gt, low_est, {20'000'000, 0}), (std::vector<PosePair>{{0, 0}}));
  EXPECT_EQ(saturating_add(kMax - 1, 5), kMax);
  EXPECT_EQ(saturating_add(kMin + 1, -5), kMin);
  EXPECT_EQ(saturating_add(7, -5), 2);
}

TEST(Association, GreedyTakesTheClosestFirstAndResultIsInTimeOrder) {
  // Candidates: est 98 - gt 100 (2), est 105 - gt 100 (5), est 105 - gt 110 (5), est 98 - gt 90 (8).
  // The closest goes first, so est 105 loses gt 100 and takes gt 110 (the tie broken by gt time).
  const Trajectory gt{{90, {}}, {100, {}}, {110, {}}};
  const Trajectory est{{98, {}}, {105, {}}};
  EXPECT_EQ(associate_by_time(gt, est, {10, 0}), (std::vector<PosePair>{{1, 0}, {2, 1}}));
}

TEST(Association, ByIndexPairsTheCommonPrefix) {
  const Trajectory a(5), b(3);
  const auto pairs = associate_by_index(a, b);
  ASSERT_EQ(pairs.size(), 3u);
  EXPECT_EQ(pairs[2], (PosePair{2, 2}));
}

// ---- alignment and ATE ----

TEST(Alignment, Se3RecoversAKnownTransformAndAteIsTheNoise) {
  const Trajectory gt = synthetic_ground_truth(400, 50'000'000);
  const Eigen::Isometry3d T_gt_est = pose(Eigen::Vector3d(5.0, -2.0, 1.0), Eigen::Vector3d(0.3, -1.2, 2.0));
  const double noise_m = 0.01;
  const Trajectory est = transformed(gt, T_gt_est, 1.0, noise_m, 7);
  const AteResult ate = compute_ate(gt, est, associate_by_time(gt, est), AlignmentMode::kSe3);
  ASSERT_TRUE(ate.ok());
  EXPECT_EQ(ate.pairs.size(), gt.size());
  EXPECT_LT((ate.alignment.T_gt_est.matrix() - T_gt_est.matrix()).cwiseAbs().maxCoeff(), 5e-3);
  EXPECT_EQ(ate.alignment.scale, 1.0);
  // |3D Gaussian| has RMS sqrt(3) sigma.
  EXPECT_NEAR(ate.stats.rmse, std::sqrt(3.0) * noise_m, 0.1 * std::sqrt(3.0) * noise_m);
  ASSERT_EQ(ate.t_ns.size(), ate.errors_m.size());
  EXPECT_EQ(ate.t_ns.front(), gt.front().t_ns);
}

TEST(Alignment, Sim3RecoversScale) {
  const Trajectory gt = synthetic_ground_truth(300, 50'000'000);
  const Eigen::Isometry3d T_gt_est = pose(Eigen::Vector3d(-1.0, 0.5, 3.0), Eigen::Vector3d(2.5, 0.1, -0.4));
  const Trajectory est = transformed(gt, T_gt_est, 2.5, 0.002, 11);
  const AteResult sim3 = compute_ate(gt, est, associate_by_time(gt, est), AlignmentMode::kSim3);
  ASSERT_TRUE(sim3.ok());
  EXPECT_NEAR(sim3.alignment.scale, 2.5, 5e-3);
  EXPECT_LT((sim3.alignment.T_gt_est.matrix() - T_gt_est.matrix()).cwiseAbs().maxCoeff(), 5e-3);
  EXPECT_LT(sim3.stats.rmse, 0.02);
  const AteResult se3 = compute_ate(gt, est, associate_by_time(gt, est), AlignmentMode::kSe3);
  EXPECT_GT(se3.stats.rmse, 10.0 * sim3.stats.rmse);
}

TEST(Alignment, NoiseFreeIsExactAndAlignedTrajectoryLiesOnGroundTruth) {
  const Trajectory gt = synthetic_ground_truth(100, 10'000'000);
  const Eigen::Isometry3d T_gt_est = pose(Eigen::Vector3d(1.0, 2.0, 3.0), Eigen::Vector3d(0.0, 3.0, 0.0));
  for (auto mode : {AlignmentMode::kSe3, AlignmentMode::kSim3}) {
    const double scale = mode == AlignmentMode::kSim3 ? 0.4 : 1.0;
    const Trajectory est = transformed(gt, T_gt_est, scale, 0.0, 1);
    const AteResult ate = compute_ate(gt, est, associate_by_index(gt, est), mode);
    ASSERT_TRUE(ate.ok());
    EXPECT_LT(ate.stats.max, 1e-9);
    EXPECT_NEAR(ate.alignment.scale, scale, 1e-12);
    const Trajectory aligned = apply_alignment(ate.alignment, est);
    for (std::size_t i = 0; i < gt.size(); ++i) {
      EXPECT_LT((aligned[i].T_world_body.matrix() - gt[i].T_world_body.matrix()).cwiseAbs().maxCoeff(), 1e-9);
    }
  }
}

// A mirrored estimate (one axis flipped, then scaled) cannot be fitted by a rotation: the alignment must
// stay a proper rotation (det +1; the SVD alone would return the reflection and report a tiny error), and
// no other proper rotation, nor another scale, may fit better.
TEST(Alignment, AMirroredEstimateGetsTheBestProperRotationAndScale) {
  const Trajectory gt = synthetic_ground_truth(200, 10'000'000);
  Trajectory est = gt;
  for (StampedPose& p : est) p.T_world_body.translation() = Eigen::Vector3d(-0.7, 0.7, 0.7).cwiseProduct(p.T_world_body.translation());
  const auto pairs = associate_by_index(gt, est);
  const auto rmse_with = [&](const Eigen::Matrix3d& R, double scale) {
    Eigen::Vector3d mean_gt = Eigen::Vector3d::Zero(), mean_est = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < gt.size(); ++i) {
      mean_gt += gt[i].T_world_body.translation() / static_cast<double>(gt.size());
      mean_est += est[i].T_world_body.translation() / static_cast<double>(gt.size());
    }
    double sum = 0.0;
    for (std::size_t i = 0; i < gt.size(); ++i) {
      const Eigen::Vector3d e = mean_gt + scale * R * (est[i].T_world_body.translation() - mean_est) -
                                gt[i].T_world_body.translation();
      sum += e.squaredNorm();
    }
    return std::sqrt(sum / static_cast<double>(gt.size()));
  };
  std::mt19937 rng(5);
  std::normal_distribution<double> n01(0.0, 1.0);
  for (const AlignmentMode mode : {AlignmentMode::kSe3, AlignmentMode::kSim3}) {
    const AteResult ate = compute_ate(gt, est, pairs, mode);
    ASSERT_TRUE(ate.ok());
    const Eigen::Matrix3d R = ate.alignment.T_gt_est.linear();
    EXPECT_NEAR(R.determinant(), 1.0, 1e-9);
    EXPECT_GT(ate.stats.rmse, 0.2) << "a reflection cannot be fitted";
    const double scale = ate.alignment.scale;
    EXPECT_NEAR(rmse_with(R, scale), ate.stats.rmse, 1e-9);
    for (int k = 0; k < 2000; ++k) {  // random proper rotations, and the alignment's own nudged
      const Eigen::Quaterniond q(n01(rng), n01(rng), n01(rng), n01(rng));
      EXPECT_GE(rmse_with(q.normalized().toRotationMatrix(), scale), ate.stats.rmse - 1e-12);
      const Eigen::Matrix3d nudged = Eigen::AngleAxisd(0.01, Eigen::Vector3d(n01(rng), n01(rng), n01(rng)).normalized()) * R;
      EXPECT_GE(rmse_with(nudged, scale), ate.stats.rmse - 1e-12);
    }
    if (mode == AlignmentMode::kSim3) {
      EXPECT_GT(rmse_with(R, scale * 1.01), ate.stats.rmse);
      EXPECT_GT(rmse_with(R, scale * 0.99), ate.stats.rmse);
    }
  }
}

TEST(Alignment, NoneKeepsTheFrames) {
  const Trajectory gt{{0, pose({0, 0, 0}, {0, 0, 0})}, {1, pose({1, 0, 0}, {0, 0, 0})}};
  const Trajectory est{{0, pose({0, 3, 4}, {0, 0, 0})}, {1, pose({1, 0, 0}, {0, 0, 0})}};
  const AteResult ate = compute_ate(gt, est, associate_by_index(gt, est), AlignmentMode::kNone);
  ASSERT_TRUE(ate.ok());  // two pairs are enough without alignment
  EXPECT_TRUE(ate.alignment.T_gt_est.matrix().isIdentity());
  EXPECT_EQ(ate.errors_m, (std::vector<double>{5.0, 0.0}));
}

TEST(Alignment, DegenerateInputsReportAStatus) {
  const Trajectory gt = synthetic_ground_truth(10, 1);
  // Too few pairs.
  const std::vector<PosePair> two{{0, 0}, {1, 1}};
  const AteResult few = compute_ate(gt, gt, two, AlignmentMode::kSe3);
  EXPECT_EQ(few.alignment.status, AlignmentStatus::kTooFewPairs);
  EXPECT_FALSE(few.ok());
  EXPECT_FALSE(few.measured());
  EXPECT_TRUE(few.alignment.T_gt_est.matrix().isIdentity());
  // Collinear positions: a minimiser exists (the error is still right) but it is not unique.
  Trajectory line;
  for (int i = 0; i < 20; ++i) line.push_back({i, pose(Eigen::Vector3d(i, 2.0 * i, -i), {0, 0, 0})});
  for (auto mode : {AlignmentMode::kSe3, AlignmentMode::kSim3}) {
    const AteResult collinear = compute_ate(line, line, associate_by_index(line, line), mode);
    EXPECT_EQ(collinear.alignment.status, AlignmentStatus::kDegenerate);
    EXPECT_LT(collinear.stats.max, 1e-9);
    EXPECT_FALSE(collinear.ok());
    EXPECT_TRUE(collinear.measured());  // the errors do not depend on the free rotation
  }
  // A straight drive against a wavy ground truth: the ATE of the collinear estimate is the limit of the
  // ATE of estimates bent ever less off the line.
  Trajectory wavy;
  Trajectory along_x;
  Trajectory bent;
  for (int i = 0; i < 20; ++i) {
    along_x.push_back({i, pose(Eigen::Vector3d(i, 0, 0), {0, 0, 0})});
    wavy.push_back({i, pose(Eigen::Vector3d(i, 0.1 * std::sin(i), 0.05 * std::cos(1.3 * i)), {0, 0, 0})});
    bent.push_back({i, pose(Eigen::Vector3d(i, 1e-3 * (i % 3), 1e-3 * (i % 2)), {0, 0, 0})});
  }
  const AteResult straight = compute_ate(wavy, along_x, associate_by_index(wavy, along_x), AlignmentMode::kSe3);
  const AteResult nearly = compute_ate(wavy, bent, associate_by_index(wavy, bent), AlignmentMode::kSe3);
  ASSERT_TRUE(straight.measured());
  ASSERT_TRUE(nearly.ok());
  EXPECT_GT(straight.stats.rmse, 0.01);
  EXPECT_NEAR(straight.stats.rmse, nearly.stats.rmse, 2e-3);
  // Coincident positions: scale is undetermined and left at 1.
  const Alignment coincident = align_positions(std::vector<Eigen::Vector3d>(5, Eigen::Vector3d(1, 1, 1)),
                                               std::vector<Eigen::Vector3d>(5, Eigen::Vector3d(2, 2, 2)),
                                               AlignmentMode::kSim3);
  EXPECT_EQ(coincident.status, AlignmentStatus::kDegenerate);
  EXPECT_EQ(coincident.scale, 1.0);
  EXPECT_TRUE(coincident.apply(Eigen::Vector3d(1, 1, 1)).isApprox(Eigen::Vector3d(2, 2, 2)));
  // No pairs at all.
  const AteResult none = compute_ate(gt, gt, {}, AlignmentMode::kNone);
  EXPECT_FALSE(none.ok());
  EXPECT_FALSE(none.measured());
  EXPECT_EQ(none.stats.count, 0u);
  EXPECT_TRUE(std::isnan(none.stats.rmse));
}

TEST(Alignment, ModeNames) {
  for (auto mode : {AlignmentMode::kNone, AlignmentMode::kSe3, AlignmentMode::kSim3}) {
    EXPECT_EQ(alignment_mode_from_string(to_string(mode)), mode);
  }
  EXPECT_FALSE(alignment_mode_from_string("se2").has_value());
  for (auto unit : {RpeUnit::kFrames, RpeUnit::kMeters, RpeUnit::kSeconds}) {
    EXPECT_EQ(rpe_unit_from_string(to_string(unit)), unit);
  }
}

// ---- statistics ----

TEST(Stats, MedianOfOddAndEvenCountsAndPopulationStd) {
  const ErrorStats odd = compute_stats({3.0, 1.0, 2.0});
  EXPECT_EQ(odd.median, 2.0);
  const ErrorStats even = compute_stats({4.0, 1.0, 3.0, 2.0});
  EXPECT_EQ(even.median, 2.5);  // numpy.median: mean of the two middle values
  EXPECT_EQ(even.mean, 2.5);
  EXPECT_DOUBLE_EQ(even.std, std::sqrt(1.25));
  EXPECT_DOUBLE_EQ(even.rmse, std::sqrt(7.5));
  EXPECT_EQ(even.min, 1.0);
  EXPECT_EQ(even.max, 4.0);
  EXPECT_EQ(even.count, 4u);
  const ErrorStats one = compute_stats({0.5});
  EXPECT_EQ(one.median, 0.5);
  EXPECT_EQ(one.std, 0.0);
}

// ---- relative pose error ----

TEST(Rpe, PerfectEstimateInAnyFrameHasZeroError) {
  const Trajectory gt = synthetic_ground_truth(200, 100'000'000);
  const Trajectory est = transformed(gt, pose({4, 5, 6}, {1, 2, 3}), 3.0, 0.0, 1);
  const auto pairs = associate_by_time(gt, est);
  for (const RpeConfig config : {RpeConfig{1, RpeUnit::kFrames}, RpeConfig{7, RpeUnit::kFrames},
                                 RpeConfig{0.5, RpeUnit::kMeters}, RpeConfig{1.0, RpeUnit::kSeconds}}) {
    const RpeResult rpe = compute_rpe(gt, est, pairs, config, 3.0);
    ASSERT_GT(rpe.translation_m.count, 100u);
    EXPECT_LT(rpe.translation_m.max, 1e-9) << to_string(config.unit);
    EXPECT_LT(rpe.rotation_rad.max, 1e-9) << to_string(config.unit);
  }
  // Without the scale, the relative translations are off by the factor 3.
  EXPECT_GT(compute_rpe(gt, est, pairs, {1, RpeUnit::kFrames}).translation_m.mean, 1e-3);
}

TEST(Rpe, ConstantDriftPerStepIsMeasuredExactly) {
  const Trajectory gt = synthetic_ground_truth(100, 100'000'000);
  const Eigen::Isometry3d drift = pose(Eigen::Vector3d(0.01, -0.02, 0.005), Eigen::Vector3d(0.0, 0.0, 0.003));
  Trajectory est = gt;
  for (std::size_t k = 1; k < est.size(); ++k) {
    // P_k = P_{k-1} D (Q_{k-1}^-1 Q_k), so that evaluate_rpe.py's (P_{k-1}^-1 P_k) (Q_{k-1}^-1 Q_k)^-1 = D
    // (the other order, (Q_{k-1}^-1 Q_k)^-1 (P_{k-1}^-1 P_k), would be D turned by each step's rotation).
    est[k].T_world_body = est[k - 1].T_world_body * drift * gt[k - 1].T_world_body.inverse() * gt[k].T_world_body;
  }
  const RpeResult rpe = compute_rpe(gt, est, associate_by_index(gt, est), {1, RpeUnit::kFrames});
  ASSERT_EQ(rpe.translation_m.count, gt.size() - 1);
  EXPECT_NEAR(rpe.translation_m.min, drift.translation().norm(), 1e-12);
  EXPECT_NEAR(rpe.translation_m.max, drift.translation().norm(), 1e-12);
  EXPECT_NEAR(rpe.rotation_rad.mean, 0.003, 1e-12);
  EXPECT_NEAR(rpe.rotation_rad.std, 0.0, 1e-12);
}

TEST(Rpe, DeltaInMetresAndSecondsPicksTheFirstPoseReachingIt) {
  // Straight line at 0.5 m per 100 ms step: 1 m and 0.2 s are both two steps (exact in binary).
  Trajectory gt;
  for (int i = 0; i < 10; ++i) gt.push_back({i * 100'000'000, pose(Eigen::Vector3d(0.5 * i, 0, 0), {0, 0, 0})});
  const auto pairs = associate_by_index(gt, gt);
  for (const RpeConfig config : {RpeConfig{1.0, RpeUnit::kMeters}, RpeConfig{0.2, RpeUnit::kSeconds},
                                 RpeConfig{2, RpeUnit::kFrames}, RpeConfig{0.9, RpeUnit::kMeters},
                                 RpeConfig{0.15, RpeUnit::kSeconds}}) {
    const RpeResult rpe = compute_rpe(gt, gt, pairs, config);
    ASSERT_EQ(rpe.from_pair.size(), 8u) << to_string(config.unit);
    for (std::size_t k = 0; k < 8; ++k) {
      EXPECT_EQ(rpe.from_pair[k], k);
      EXPECT_EQ(rpe.to_pair[k], k + 2);
      EXPECT_EQ(rpe.t_ns[k], gt[k].t_ns);
    }
  }
}

// A drop-out of the ground truth (2 s to 5 s) over an estimate that jumps 0.5 m across it: each segment
// is exact, so every pair compared within a segment has zero error, and none may reach across the gap
// (the old pairing compared the last pose before it with the first after, an error of 0.5 m).
TEST(Rpe, PairsAcrossAGapInTheStampsAreLeftOut) {
  Trajectory gt, est;
  for (int i = 0; i <= 70; ++i) {  // 10 Hz, 0 .. 7 s
    const TimeNs t_ns = 1'000'000'000 + static_cast<TimeNs>(i) * 100'000'000;
    const Eigen::Isometry3d T = pose(Eigen::Vector3d(0.1 * i, 0.02 * i * i * 0.01, 0.0), Eigen::Vector3d(0.0, 0.0, 0.01 * i));
    Eigen::Isometry3d T_est = T;
    if (i > 25) T_est.translation().y() += 0.5;  // the jump, inside the gap
    est.push_back({t_ns, T_est});
    if (i <= 20 || i >= 50) gt.push_back({t_ns, T});
  }
  const auto pairs = associate_by_time(gt, est);
  ASSERT_EQ(pairs.size(), 42u);
  for (const RpeConfig config : {RpeConfig{1, RpeUnit::kFrames}, RpeConfig{3, RpeUnit::kFrames},
                                 RpeConfig{0.5, RpeUnit::kSeconds}, RpeConfig{0.3, RpeUnit::kMeters}}) {
    const RpeResult rpe = compute_rpe(gt, est, pairs, config);
    ASSERT_GT(rpe.translation_m.count, 20u) << to_string(config.unit);
    EXPECT_LT(rpe.translation_m.max, 1e-9) << to_string(config.unit) << " " << config.delta;
    for (std::size_t k = 0; k < rpe.from_pair.size(); ++k) {
      EXPECT_EQ(pairs[rpe.from_pair[k]].est_index <= 20, pairs[rpe.to_pair[k]].est_index <= 20);
    }
  }
  // In frames, the estimate's pose a frame later is in the gap (not paired): no partner, not counted as
  // skipped; in seconds and metres the first pose reaching the delta lies across the gap: skipped.
  EXPECT_EQ(compute_rpe(gt, est, pairs, {1, RpeUnit::kFrames}).skipped_across_gaps, 0u);
  EXPECT_EQ(compute_rpe(gt, est, pairs, {1, RpeUnit::kFrames}).translation_m.count, 40u);
  EXPECT_EQ(compute_rpe(gt, est, pairs, {0.5, RpeUnit::kSeconds}).skipped_across_gaps, 5u);
  EXPECT_GT(compute_rpe(gt, est, pairs, {0.3, RpeUnit::kMeters}).skipped_across_gaps, 0u);
}

TEST(Rpe, RotationErrorNearPiAndBadDeltas) {
  const Trajectory gt{{0, pose({0, 0, 0}, {0, 0, 0})}, {1, pose({0, 0, 0}, {0, 0, 0})}};
  const Trajectory est{{0, pose({0, 0, 0}, {0, 0, 0})}, {1, pose({0, 0, 0}, {0, kPi, 0})}};
  const RpeResult rpe = compute_rpe(gt, est, associate_by_index(gt, est), {1, RpeUnit::kFrames});
  ASSERT_EQ(rpe.rotation_errors_rad.size(), 1u);
  EXPECT_NEAR(rpe.rotation_errors_rad[0], kPi, 1e-12);
  EXPECT_THROW(compute_rpe(gt, est, associate_by_index(gt, est), {1.5, RpeUnit::kFrames}), InvariantError);
  EXPECT_THROW(compute_rpe(gt, est, associate_by_index(gt, est), {0.0, RpeUnit::kSeconds}), InvariantError);
  // A delta longer than the trajectory gives no pairs, not an error.
  EXPECT_EQ(compute_rpe(gt, est, associate_by_index(gt, est), {5, RpeUnit::kFrames}).translation_m.count, 0u);
}

}  // namespace
}  // namespace fleetslam::core
