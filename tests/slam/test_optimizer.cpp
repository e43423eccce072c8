// Pose-only optimisation and local BA on synthetic scenes with known truth (seeded): exact recovery
// without noise, accuracy within the Cramer-Rao bound with pixel noise, injected outliers flagged.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "fleetslam/core/camera.hpp"
#include "fleetslam/core/se3.hpp"
#include "fleetslam/slam/optimizer.hpp"

namespace fleetslam::slam {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;
constexpr double kBf = 40.0;  // 8 cm baseline at fx 500
// chi-square quantile 0.999 with 6 degrees of freedom: a pose error beyond it (in the metric of the
// information matrix) is a failure, not bad luck.
constexpr double kChi2Pose999 = 22.458;

const core::PinholeCamera& test_camera() {
  static const core::PinholeCamera camera(640, 480, 500.0, 500.0, 319.5, 239.5);
  return camera;
}

Eigen::Isometry3d pose_from(const Eigen::Vector3d& t, const Eigen::Vector3d& rotation_vector) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = core::so3_exp(rotation_vector);
  T.translation() = t;
  return T;
}

// Pose error as the twist xi with T_estimate = exp(xi) T_truth.
core::Vector6d pose_error(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth) {
  return core::se3_log(estimate * truth.inverse());
}
double translation_error_m(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.inverse().translation() - b.inverse().translation()).norm();  // camera centres
}
double rotation_error_rad(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return core::rotation_angle_rad(a.rotation() * b.rotation().transpose());
}

// 5 cm and 3 degrees away from T, along fixed directions.
Eigen::Isometry3d perturbed(const Eigen::Isometry3d& T, double t_m = 0.05, double angle_rad = 3.0 * kDeg) {
  const Eigen::Vector3d t_dir = Eigen::Vector3d(1.0, -2.0, 0.5).normalized();
  const Eigen::Vector3d r_dir = Eigen::Vector3d(0.3, 1.0, -0.6).normalized();
  return pose_from(t_m * t_dir, angle_rad * r_dir) * T;
}

struct SceneOptions {
  int points = 300;
  double pixel_sigma = 0.0;  // at level 0; level l has sigma * 1.2^l
  double stereo_share = 1.0;
  double outlier_share = 0.0;
  unsigned seed = 1;
};

// Observation of a camera-frame point with noise at a pyramid level, mono or stereo.
Observation observe(const Eigen::Vector3d& p_cam, int level, bool stereo, double sigma0, std::mt19937& rng) {
  const double sigma = sigma0 * std::pow(1.2, level);
  std::normal_distribution<double> noise(0.0, 1.0);
  Observation obs;
  const Eigen::Vector2d uv = *test_camera().project(p_cam);
  obs.uv = uv + sigma * Eigen::Vector2d(noise(rng), noise(rng));
  if (stereo) obs.u_right = uv.x() - kBf / p_cam.z() + sigma * noise(rng);
  obs.inv_sigma2 = 1.0 / (std::pow(1.2, 2 * level));
  return obs;
}

// A gross error: somewhere else in the image, with an unrelated disparity.
void corrupt(Observation& obs, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.0, 639.0), v(0.0, 479.0), disparity(2.0, 40.0);
  obs.uv = Eigen::Vector2d(u(rng), v(rng));
  if (obs.u_right) obs.u_right = obs.uv.x() - disparity(rng);
}

struct PoseScene {
  Eigen::Isometry3d T_cam_world;
  std::vector<PoseObservation> observations;
  std::vector<bool> corrupted;
};

PoseScene make_pose_scene(const SceneOptions& options) {
  std::mt19937 rng(options.seed);
  std::uniform_real_distribution<double> u(20.0, 620.0), v(20.0, 460.0), depth(1.0, 6.0), unit(0.0, 1.0);
  std::uniform_int_distribution<int> level(0, 3);
  PoseScene scene;
  scene.T_cam_world = pose_from(Eigen::Vector3d(0.4, -0.2, 1.1), Eigen::Vector3d(0.1, -0.3, 0.2));
  const Eigen::Isometry3d T_world_cam = scene.T_cam_world.inverse();
  for (int i = 0; i < options.points; ++i) {
    const Eigen::Vector3d p_cam = *test_camera().unproject(Eigen::Vector2d(u(rng), v(rng)), depth(rng));
    PoseObservation o;
    o.p_world = T_world_cam * p_cam;
    o.obs = observe(p_cam, level(rng), unit(rng) < options.stereo_share, options.pixel_sigma, rng);
    const bool bad = unit(rng) < options.outlier_share;
    if (bad) corrupt(o.obs, rng);
    scene.observations.push_back(o);
    scene.corrupted.push_back(bad);
  }
  return scene;
}

// Information matrix (per unit pixel variance) of the pose at the truth, by central differences on
// T = exp(xi) T_truth, over the clean observations: the Cramer-Rao bound is its inverse times sigma^2.
core::Matrix6d pose_information(const PoseScene& scene) {
  core::Matrix6d information = core::Matrix6d::Zero();
  for (std::size_t i = 0; i < scene.observations.size(); ++i) {
    if (scene.corrupted[i]) continue;
    const PoseObservation& o = scene.observations[i];
    const bool stereo = o.obs.u_right.has_value();
    const auto h = [&](const core::Vector6d& xi) {
      const Eigen::Vector3d p_cam = core::se3_exp(xi) * scene.T_cam_world * o.p_world;
      const Eigen::Vector2d uv = *test_camera().project(p_cam);
      return Eigen::Vector3d(uv.x(), uv.y(), stereo ? uv.x() - kBf / p_cam.z() : 0.0);
    };
    Eigen::Matrix<double, 3, 6> J;
    for (int k = 0; k < 6; ++k) {
      core::Vector6d step = core::Vector6d::Zero();
      step(k) = 1e-6;
      J.col(k) = (h(step) - h(-step)) / 2e-6;
    }
    information += o.obs.inv_sigma2 * J.transpose() * J;
  }
  return information;
}

double mahalanobis2(const core::Vector6d& error, const core::Matrix6d& information, double sigma) {
  return error.dot(information * error) / (sigma * sigma);
}

int count(const std::vector<bool>& flags) { return static_cast<int>(std::count(flags.begin(), flags.end(), true)); }

// ---- pose-only ----------------------------------------------------------------------------------------

TEST(OptimizePose, RecoversAPerturbedPoseExactlyWithoutNoise) {
  for (double stereo_share : {1.0, 0.0, 0.5}) {
    SceneOptions options;
    options.stereo_share = stereo_share;
    const PoseScene scene = make_pose_scene(options);
    const PoseResult r = optimize_pose(test_camera(), kBf, scene.observations, perturbed(scene.T_cam_world), {});
    ASSERT_TRUE(r.ok) << "stereo share " << stereo_share;
    EXPECT_LT(translation_error_m(r.T_cam_world, scene.T_cam_world), 1e-6) << "stereo share " << stereo_share;
    EXPECT_LT(rotation_error_rad(r.T_cam_world, scene.T_cam_world), 1e-6) << "stereo share " << stereo_share;
    EXPECT_EQ(r.inliers, options.points);
    EXPECT_EQ(count(r.outlier), 0);
    EXPECT_EQ(r.outlier.size(), scene.observations.size());
  }
}

// A close point near the left edge has a negative virtual right coordinate (u - bf / z < 0): still a depth
// constraint, so a right coordinate that disagrees with the point's depth makes it an outlier, and one
// that agrees keeps it.
TEST(OptimizePose, ANegativeRightCoordinateIsStillADepthConstraint) {
  SceneOptions options;
  options.points = 60;
  PoseScene scene = make_pose_scene(options);
  const Eigen::Isometry3d T_world_cam = scene.T_cam_world.inverse();
  const Eigen::Vector3d p_cam = *test_camera().unproject(Eigen::Vector2d(10.0, 200.0), 0.5);
  std::mt19937 rng(7);
  for (const double wrong_px : {0.0, 15.0}) {
    PoseObservation o;
    o.p_world = T_world_cam * p_cam;
    o.obs = observe(p_cam, 0, true, 0.0, rng);
    ASSERT_LT(*o.obs.u_right, -60.0);  // 10 - 40 / 0.5
    *o.obs.u_right += wrong_px;
    scene.observations.push_back(o);
  }
  const PoseResult r = optimize_pose(test_camera(), kBf, scene.observations, perturbed(scene.T_cam_world), {});
  ASSERT_TRUE(r.ok);
  EXPECT_FALSE(r.outlier[r.outlier.size() - 2]);  // agrees with the depth
  EXPECT_TRUE(r.outlier.back());                   // 15 px off on the right image only
  EXPECT_EQ(r.inliers, options.points + 1);
  EXPECT_LT(translation_error_m(r.T_cam_world, scene.T_cam_world), 1e-6);
}

TEST(OptimizePose, AccuracyWithOnePixelNoiseMatchesTheCramerRaoBound) {
  double sum_m2 = 0.0;
  const int runs = 10;
  for (int run = 0; run < runs; ++run) {
    for (double stereo_share : {1.0, 0.0}) {
      SceneOptions options;
      options.pixel_sigma = 1.0;
      options.stereo_share = stereo_share;
      options.seed = 100 + static_cast<unsigned>(run);
      const PoseScene scene = make_pose_scene(options);
      const PoseResult r = optimize_pose(test_camera(), kBf, scene.observations, perturbed(scene.T_cam_world), {});
      ASSERT_TRUE(r.ok);
      const double m2 = mahalanobis2(pose_error(r.T_cam_world, scene.T_cam_world), pose_information(scene), 1.0);
      EXPECT_LT(m2, kChi2Pose999) << "run " << run << " stereo share " << stereo_share;
      sum_m2 += m2;
      // In plain numbers: millimetres and hundredths of a degree at 1-6 m.
      EXPECT_LT(translation_error_m(r.T_cam_world, scene.T_cam_world), 0.005);
      EXPECT_LT(rotation_error_rad(r.T_cam_world, scene.T_cam_world), 0.1 * kDeg);
      // About 5 % of clean observations exceed the 95 % chi-square threshold.
      EXPECT_LT(count(r.outlier), options.points / 10);
    }
  }
  // The mean of a chi-square with 6 dof is 6: an efficient estimator lands near it.
  const double mean_m2 = sum_m2 / (2 * runs);
  EXPECT_GT(mean_m2, 2.0);
  EXPECT_LT(mean_m2, 12.0);
}

TEST(OptimizePose, FlagsInjectedOutliersAndStillRecoversThePose) {
  for (double stereo_share : {1.0, 0.0}) {
    SceneOptions options;
    options.pixel_sigma = 1.0;
    options.outlier_share = 0.2;
    options.stereo_share = stereo_share;
    options.seed = 7;
    const PoseScene scene = make_pose_scene(options);
    const PoseResult r = optimize_pose(test_camera(), kBf, scene.observations, perturbed(scene.T_cam_world), {});
    ASSERT_TRUE(r.ok);
    int corrupted = 0, caught = 0, false_alarms = 0;
    for (std::size_t i = 0; i < scene.observations.size(); ++i) {
      corrupted += scene.corrupted[i];
      caught += scene.corrupted[i] && r.outlier[i];
      false_alarms += !scene.corrupted[i] && r.outlier[i];
    }
    EXPECT_GT(corrupted, 40);
    EXPECT_EQ(caught, corrupted) << "stereo share " << stereo_share;
    EXPECT_LT(false_alarms, (options.points - corrupted) / 10);
    EXPECT_EQ(r.inliers, options.points - caught - false_alarms);
    const double m2 = mahalanobis2(pose_error(r.T_cam_world, scene.T_cam_world), pose_information(scene), 1.0);
    EXPECT_LT(m2, kChi2Pose999) << "stereo share " << stereo_share;
    EXPECT_LT(translation_error_m(r.T_cam_world, scene.T_cam_world), 0.005);
    EXPECT_LT(rotation_error_rad(r.T_cam_world, scene.T_cam_world), 0.1 * kDeg);
  }
}

// Huber cost of every observation in front of the camera at pose T: sum of rho(chi2) with ORB-SLAM's
// delta^2 = chi2 threshold (rho(s) = s up to delta^2, 2 delta sqrt(s) - delta^2 beyond), written plainly.
double huber_cost(const PoseScene& scene, const Eigen::Isometry3d& T_cam_world, const OptimizerConfig& config) {
  double cost = 0.0;
  for (const PoseObservation& o : scene.observations) {
    const bool stereo = o.obs.u_right.has_value();
    const Eigen::Vector3d p_cam = T_cam_world * o.p_world;
    if (p_cam.z() <= 0.0) continue;
    const Eigen::Vector2d uv = *test_camera().project(p_cam);
    double s = (o.obs.uv - uv).squaredNorm();
    if (stereo) s += std::pow(*o.obs.u_right - (uv.x() - kBf / p_cam.z()), 2);
    s *= o.obs.inv_sigma2;
    const double delta2 = stereo ? config.chi2_stereo : config.chi2_mono;
    cost += s <= delta2 ? s : 2.0 * std::sqrt(delta2 * s) - delta2;
  }
  return cost;
}

// One robust round minimises the Huber cost over all observations (many far beyond delta here): no
// small step of the pose along any of its six directions lowers the plainly computed cost.
TEST(OptimizePose, ARobustRoundMinimisesTheHuberCost) {
  for (double stereo_share : {0.5, 0.0}) {
    SceneOptions options;
    options.pixel_sigma = 1.0;
    options.outlier_share = 0.3;
    options.stereo_share = stereo_share;
    options.seed = 12;
    const PoseScene scene = make_pose_scene(options);
    OptimizerConfig config;
    config.rounds = 1;  // a single round keeps the kernel
    config.pose_robust_iterations = 100;
    const PoseResult r = optimize_pose(test_camera(), kBf, scene.observations, perturbed(scene.T_cam_world), config);
    ASSERT_TRUE(r.ok);
    const double at_minimum = huber_cost(scene, r.T_cam_world, config);
    int beyond_delta = 0;
    for (std::size_t i = 0; i < r.outlier.size(); ++i) beyond_delta += r.outlier[i] ? 1 : 0;
    EXPECT_GT(beyond_delta, options.points / 5) << "the test needs residuals in Huber's linear part";
    for (int k = 0; k < 6; ++k) {
      for (double step : {1e-4, -1e-4}) {
        core::Vector6d xi = core::Vector6d::Zero();
        xi(k) = step;
        const double moved = huber_cost(scene, core::se3_exp(xi) * r.T_cam_world, config);
        EXPECT_GE(moved, at_minimum - 1e-9 * at_minimum)
            << "direction " << k << ", step " << step << ", stereo share " << stereo_share;
      }
    }
  }
}

TEST(OptimizePose, FewerThanThreeObservationsAreNotEnough) {
  SceneOptions options;
  options.points = 3;
  const PoseScene scene = make_pose_scene(options);
  const Eigen::Isometry3d initial = perturbed(scene.T_cam_world);
  for (std::size_t n = 0; n < 3; ++n) {
    const std::vector<PoseObservation> few(scene.observations.begin(), scene.observations.begin() + n);
    const PoseResult r = optimize_pose(test_camera(), kBf, few, initial, {});
    EXPECT_FALSE(r.ok) << n;
    EXPECT_EQ(r.outlier.size(), n);
    EXPECT_TRUE(r.T_cam_world.isApprox(initial)) << n;
  }
  EXPECT_TRUE(optimize_pose(test_camera(), kBf, scene.observations, initial, {}).ok);
}

TEST(OptimizePose, PointsBehindTheCameraAreOutliersNotFailures) {
  SceneOptions options;
  options.points = 100;
  PoseScene scene = make_pose_scene(options);
  const Eigen::Isometry3d T_world_cam = scene.T_cam_world.inverse();
  for (int i = 0; i < 5; ++i) {  // mirror a few points behind the camera
    PoseObservation& o = scene.observations[static_cast<std::size_t>(i)];
    Eigen::Vector3d p_cam = scene.T_cam_world * o.p_world;
    p_cam.z() = -p_cam.z();
    o.p_world = T_world_cam * p_cam;
  }
  const PoseResult r = optimize_pose(test_camera(), kBf, scene.observations, perturbed(scene.T_cam_world), {});
  ASSERT_TRUE(r.ok);
  for (int i = 0; i < 5; ++i) EXPECT_TRUE(r.outlier[static_cast<std::size_t>(i)]) << i;
  EXPECT_EQ(r.inliers, 95);
  EXPECT_LT(translation_error_m(r.T_cam_world, scene.T_cam_world), 1e-6);
}

TEST(OptimizePose, IsDeterministic) {
  SceneOptions options;
  options.pixel_sigma = 1.0;
  options.outlier_share = 0.2;
  const PoseScene scene = make_pose_scene(options);
  const PoseResult a = optimize_pose(test_camera(), kBf, scene.observations, perturbed(scene.T_cam_world), {});
  const PoseResult b = optimize_pose(test_camera(), kBf, scene.observations, perturbed(scene.T_cam_world), {});
  EXPECT_EQ(a.T_cam_world.matrix(), b.T_cam_world.matrix());
  EXPECT_EQ(a.outlier, b.outlier);
}

// Timing is measured by tests/bench/bench_optimizer.cpp, never asserted here (shared, noisy machine).

// ---- local bundle adjustment --------------------------------------------------------------------------

struct BaScene {
  BaProblem truth;
  BaProblem problem;  // perturbed poses (non-fixed) and points
  std::vector<bool> corrupted;
};

struct BaOptions {
  int keyframes = 6;
  int fixed = 2;  // the first `fixed` keyframes are held
  int points = 400;
  double pixel_sigma = 1.0;
  double stereo_share = 0.7;
  double outlier_share = 0.0;
  unsigned seed = 3;
};

// Keyframes along a 1.2 m arc looking at points 2-5 m in front of the middle keyframe (most are seen
// from every keyframe); each point observed by every keyframe that sees it in the image.
BaScene make_ba_scene(const BaOptions& options) {
  std::mt19937 rng(options.seed);
  std::uniform_real_distribution<double> u(40.0, 600.0), v(40.0, 440.0), depth(2.0, 5.0), unit(0.0, 1.0);
  std::uniform_int_distribution<int> level(0, 2);
  std::normal_distribution<double> normal(0.0, 1.0);
  BaScene scene;
  for (int k = 0; k < options.keyframes; ++k) {
    const double s = k / static_cast<double>(options.keyframes - 1);
    const Eigen::Isometry3d T_world_cam = pose_from(Eigen::Vector3d(-0.6 + 1.2 * s, 0.1 * std::sin(3.0 * s), 0.3 * s),
                                                    Eigen::Vector3d(0.0, 0.15 - 0.3 * s, 0.02));
    scene.truth.keyframes.push_back({T_world_cam.inverse(), k < options.fixed});
  }
  const Eigen::Isometry3d T_world_middle =
      scene.truth.keyframes[static_cast<std::size_t>(options.keyframes / 2)].T_cam_world.inverse();
  for (int i = 0; i < options.points; ++i) {
    scene.truth.points_world.push_back(T_world_middle *
                                       *test_camera().unproject(Eigen::Vector2d(u(rng), v(rng)), depth(rng)));
  }
  scene.problem = scene.truth;
  for (int k = 0; k < options.keyframes; ++k) {
    for (int i = 0; i < options.points; ++i) {
      const Eigen::Vector3d p_cam = scene.truth.keyframes[static_cast<std::size_t>(k)].T_cam_world *
                                    scene.truth.points_world[static_cast<std::size_t>(i)];
      const auto uv = test_camera().project(p_cam);
      if (!uv || !test_camera().in_image(*uv, 10.0)) continue;
      BaObservation o{k, i, observe(p_cam, level(rng), unit(rng) < options.stereo_share, options.pixel_sigma, rng)};
      const bool bad = unit(rng) < options.outlier_share;
      if (bad) corrupt(o.obs, rng);
      scene.problem.observations.push_back(o);
      scene.corrupted.push_back(bad);
    }
  }
  scene.truth.observations = scene.problem.observations;
  for (std::size_t k = 0; k < scene.problem.keyframes.size(); ++k) {
    BaKeyframe& kf = scene.problem.keyframes[k];
    if (kf.fixed) continue;
    const Eigen::Vector3d dt(normal(rng), normal(rng), normal(rng));
    const Eigen::Vector3d dr(normal(rng), normal(rng), normal(rng));
    kf.T_cam_world = pose_from(0.03 * dt.normalized(), 1.0 * kDeg * dr.normalized()) * kf.T_cam_world;
  }
  for (Eigen::Vector3d& p : scene.problem.points_world)
    p += 0.05 * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
  return scene;
}

double max_pose_error_m(const BaResult& r, const BaProblem& truth) {
  double worst = 0.0;
  for (std::size_t k = 0; k < truth.keyframes.size(); ++k) {
    worst = std::max(worst, translation_error_m(r.T_cam_world[k], truth.keyframes[k].T_cam_world));
  }
  return worst;
}
double max_rotation_error_rad(const BaResult& r, const BaProblem& truth) {
  double worst = 0.0;
  for (std::size_t k = 0; k < truth.keyframes.size(); ++k) {
    worst = std::max(worst, rotation_error_rad(r.T_cam_world[k], truth.keyframes[k].T_cam_world));
  }
  return worst;
}
double median_point_error_m(const std::vector<Eigen::Vector3d>& points, const BaProblem& truth) {
  std::vector<double> errors;
  for (std::size_t i = 0; i < truth.points_world.size(); ++i) {
    errors.push_back((points[i] - truth.points_world[i]).norm());
  }
  std::nth_element(errors.begin(), errors.begin() + static_cast<long>(errors.size() / 2), errors.end());
  return errors[errors.size() / 2];
}

TEST(BundleAdjust, RecoversTheSceneExactlyWithoutNoise) {
  BaOptions options;
  options.pixel_sigma = 0.0;
  const BaScene scene = make_ba_scene(options);
  const BaResult r = bundle_adjust(test_camera(), kBf, scene.problem, {});
  ASSERT_TRUE(r.ok);
  EXPECT_GT(r.initial_rms_px, 5.0);
  EXPECT_LT(r.final_rms_px, 1e-6);
  EXPECT_LT(max_pose_error_m(r, scene.truth), 1e-6);
  EXPECT_LT(max_rotation_error_rad(r, scene.truth), 1e-6);
  EXPECT_LT(median_point_error_m(r.points_world, scene.truth), 1e-6);
  EXPECT_EQ(count(r.outlier), 0);
}

TEST(BundleAdjust, ReducesReprojectionErrorToTheNoiseLevel) {
  const BaScene scene = make_ba_scene({});
  const auto start = std::chrono::steady_clock::now();
  const BaResult r = bundle_adjust(test_camera(), kBf, scene.problem, {});
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  std::printf("local BA: %zu keyframes, %zu points, %zu observations: %.1f ms, RMS %.3f -> %.3f px\n",
              scene.problem.keyframes.size(), scene.problem.points_world.size(), scene.problem.observations.size(), ms,
              r.initial_rms_px, r.final_rms_px);
  ASSERT_TRUE(r.ok);
  // uv noise of sigma 1.2^level per axis, levels 0-2 alike: E|e|^2 = 2 (1 + 1.44 + 2.07) / 3 = 3.0 px^2,
  // an RMS of 1.73 px at the truth. The fit absorbs p / m of it (1224 unknowns, ~6500 residuals: 19 %),
  // giving ~1.56 px, and the chi-square cut trims the tail a little more.
  EXPECT_GT(r.initial_rms_px, 10.0);
  EXPECT_GT(r.final_rms_px, 1.3);
  EXPECT_LT(r.final_rms_px, 1.65);
  EXPECT_LT(count(r.outlier), static_cast<int>(scene.problem.observations.size()) / 10);

  // Converged: started from the truth, with the same noisy observations, BA lands on the same minimum.
  BaProblem from_truth = scene.truth;
  from_truth.observations = scene.problem.observations;
  const BaResult reference = bundle_adjust(test_camera(), kBf, from_truth, {});
  ASSERT_TRUE(reference.ok);
  EXPECT_EQ(reference.outlier, r.outlier);
  for (std::size_t k = 0; k < scene.problem.keyframes.size(); ++k) {
    EXPECT_LT(translation_error_m(r.T_cam_world[k], reference.T_cam_world[k]), 1e-6) << k;
    EXPECT_LT(rotation_error_rad(r.T_cam_world[k], reference.T_cam_world[k]), 1e-6) << k;
  }
  EXPECT_NEAR(r.final_rms_px, reference.final_rms_px, 1e-6);

  // Fixed keyframes stay where they are, to the bit; the others come back to a few millimetres and
  // hundredths of a degree (measured: up to 3 mm and 0.065 deg).
  for (std::size_t k = 0; k < scene.problem.keyframes.size(); ++k) {
    if (scene.problem.keyframes[k].fixed) {
      EXPECT_EQ(r.T_cam_world[k].matrix(), scene.problem.keyframes[k].T_cam_world.matrix());
    }
    const Eigen::Isometry3d relative = r.T_cam_world[k] * r.T_cam_world[0].inverse();
    const Eigen::Isometry3d relative_truth =
        scene.truth.keyframes[k].T_cam_world * scene.truth.keyframes[0].T_cam_world.inverse();
    EXPECT_LT(translation_error_m(relative, relative_truth), 0.008) << k;
    EXPECT_LT(rotation_error_rad(relative, relative_truth), 0.15 * kDeg) << k;
  }
  // Points start 5 cm off per axis (median 8 cm) and come back to about 2 cm, the stereo/parallax limit.
  EXPECT_LT(median_point_error_m(r.points_world, scene.truth), 0.03);
}

// Observations of points seen at least three times: one outlier among them cannot hide (with fewer,
// a point can move to fit it).
std::vector<bool> well_observed(const BaProblem& problem) {
  std::vector<int> per_point(problem.points_world.size(), 0);
  for (const BaObservation& o : problem.observations) ++per_point[static_cast<std::size_t>(o.point)];
  std::vector<bool> well;
  for (const BaObservation& o : problem.observations) well.push_back(per_point[static_cast<std::size_t>(o.point)] >= 3);
  return well;
}

TEST(BundleAdjust, FlagsInjectedOutliers) {
  BaOptions options;
  options.outlier_share = 0.1;
  const BaScene scene = make_ba_scene(options);
  const BaResult r = bundle_adjust(test_camera(), kBf, scene.problem, {});
  ASSERT_TRUE(r.ok);
  const std::vector<bool> well = well_observed(scene.problem);
  int corrupted = 0, caught = 0, false_alarms = 0;
  for (std::size_t i = 0; i < scene.corrupted.size(); ++i) {
    if (!well[i]) continue;
    corrupted += scene.corrupted[i];
    caught += scene.corrupted[i] && r.outlier[i];
    false_alarms += !scene.corrupted[i] && r.outlier[i];
  }
  EXPECT_GT(corrupted, 100);
  EXPECT_EQ(caught, corrupted);
  EXPECT_LT(false_alarms, static_cast<int>(scene.corrupted.size()) / 10);
  EXPECT_LT(r.final_rms_px, 1.65);
  EXPECT_LT(max_pose_error_m(r, scene.truth), 0.01);
  EXPECT_LT(max_rotation_error_rad(r, scene.truth), 0.15 * kDeg);
}

TEST(BundleAdjust, MonocularObservationsOnly) {
  BaOptions options;
  options.stereo_share = 0.0;
  options.pixel_sigma = 0.0;
  const BaScene scene = make_ba_scene(options);
  const BaResult r = bundle_adjust(test_camera(), kBf, scene.problem, {});
  ASSERT_TRUE(r.ok);
  // Two fixed keyframes fix the gauge and the scale.
  EXPECT_LT(r.final_rms_px, 1e-6);
  EXPECT_LT(max_pose_error_m(r, scene.truth), 1e-5);
  EXPECT_LT(median_point_error_m(r.points_world, scene.truth), 1e-5);
}

TEST(BundleAdjust, NeedsAFixedKeyframe) {
  BaOptions options;
  options.fixed = 0;
  const BaScene scene = make_ba_scene(options);
  const BaResult r = bundle_adjust(test_camera(), kBf, scene.problem, {});
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.T_cam_world.size(), scene.problem.keyframes.size());
  EXPECT_EQ(r.points_world, scene.problem.points_world);
}

TEST(BundleAdjust, IsDeterministic) {
  BaOptions options;
  options.outlier_share = 0.05;
  const BaScene scene = make_ba_scene(options);
  const BaResult a = bundle_adjust(test_camera(), kBf, scene.problem, {});
  const BaResult b = bundle_adjust(test_camera(), kBf, scene.problem, {});
  for (std::size_t k = 0; k < a.T_cam_world.size(); ++k)
    EXPECT_EQ(a.T_cam_world[k].matrix(), b.T_cam_world[k].matrix());
  EXPECT_EQ(a.points_world, b.points_world);
  EXPECT_EQ(a.outlier, b.outlier);
}

// The PnP inlier gate scales with each feature's level: coarse-level matches whose error is sigma-sized
// pass (a fixed 4 px gate would drop about 40 % of them at level 6), and a 3 px error at level 0 fails.
TEST(ReprojectionInliers, TheGateFollowsEachLevelsSigma) {
  const core::PinholeCamera& camera = test_camera();
  const Eigen::Isometry3d T_cw = pose_from(Eigen::Vector3d(0.1, -0.05, 0.2), Eigen::Vector3d(0.02, 0.01, -0.03));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> pixel(20.0, 600.0);
  std::uniform_real_distribution<double> depth(1.0, 6.0);
  const double sigma6 = std::pow(1.2, 6);  // 2.99 px
  std::normal_distribution<double> noise(0.0, sigma6);
  std::vector<PoseObservation> observations;
  int fixed_gate = 0;
  for (int k = 0; k < 400; ++k) {
    const Eigen::Vector2d uv_true(pixel(rng), pixel(rng) * 0.75);
    const Eigen::Vector3d p_cam = *camera.unproject(uv_true, depth(rng));
    PoseObservation o;
    o.p_world = T_cw.inverse() * p_cam;
    o.obs.uv = uv_true + Eigen::Vector2d(noise(rng), noise(rng));
    o.obs.inv_sigma2 = 1.0 / (sigma6 * sigma6);
    fixed_gate += (o.obs.uv - uv_true).norm() <= 4.0 ? 1 : 0;
    observations.push_back(o);
  }
  const std::vector<int> inliers = reprojection_inliers(camera, observations, T_cw, 5.991);
  EXPECT_GT(static_cast<int>(inliers.size()), 400 * 90 / 100);  // 95 % expected
  EXPECT_LT(fixed_gate, 400 * 70 / 100);                         // 59 % expected
  // Level 0 (sigma 1 px): 3 px off fails (9 > 5.991), 2 px passes; behind the camera fails.
  PoseObservation off;
  off.p_world = T_cw.inverse() * Eigen::Vector3d(0.1, 0.2, 2.0);
  off.obs.uv = *camera.project(Eigen::Vector3d(0.1, 0.2, 2.0)) + Eigen::Vector2d(3.0, 0.0);
  PoseObservation near = off;
  near.obs.uv.x() -= 1.0;
  PoseObservation behind = near;
  behind.p_world = T_cw.inverse() * Eigen::Vector3d(0.1, 0.2, -2.0);
  EXPECT_EQ(reprojection_inliers(camera, {off, near, behind}, T_cw, 5.991), std::vector<int>{1});
}

}  // namespace
}  // namespace fleetslam::slam
