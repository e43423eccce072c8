// Writing a global BA back into a map that changed while it was solved (the agent's threaded mode): the
// solved keyframes and points take the result, and a keyframe inserted meanwhile, with the point it
// created, follows the correction of its covisible solved keyframe instead of staying where the old map
// put it. Keyframes of another map component are left alone.

#include <gtest/gtest.h>

#include <random>
#include <set>
#include <vector>

#include "fleetslam/core/log.hpp"
#include "fleetslam/slam/loop_closing.hpp"
#include "fleetslam/slam/map.hpp"
#include "map_test_util.hpp"

namespace fleetslam::slam {
namespace {

using test::make_frame;

Eigen::Isometry3d at(double x, double yaw_rad = 0.0) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, 0.0, 0.0);
  return T;
}

constexpr std::size_t kFeatures = 60;

// Keyframes 0..n-1 of component 0 at x = 0.1 k: points 0..19 seen by keyframes 0 and 1, points 20..39 by
// keyframes 1 to n-1 (so the root, keyframe 0, is not covisible with the later points).
Map make_map(int keyframes, std::vector<MapPointId>& points) {
  Map map;
  std::vector<KeyframeId> ids;
  for (int k = 0; k < keyframes; ++k) ids.push_back(map.add_keyframe(make_frame(kFeatures, 10 + k), at(0.1 * k), 0));
  for (std::size_t i = 0; i < 40; ++i) {
    const Eigen::Vector3d p(0.05 * static_cast<double>(i % 10) - 0.25, 0.05 * static_cast<double>(i / 10), 2.0);
    const std::size_t first = i < 20 ? 0 : 1, last = i < 20 ? 1 : ids.size() - 1;
    const MapPointId id = map.add_map_point(p, ids[first], static_cast<int>(i));
    for (std::size_t k = first + 1; k <= last; ++k) map.add_observation(id, ids[k], static_cast<int>(i));
    points.push_back(id);
  }
  for (KeyframeId id : ids) map.update_connections(id);
  return map;
}

// A solve that moves every free keyframe and every point of the problem by one known correction C.
BaResult moved_by(const GlobalBaProblem& problem, const Eigen::Isometry3d& C) {
  BaResult result;
  result.ok = true;
  for (const BaKeyframe& kf : problem.problem.keyframes) {
    const Eigen::Isometry3d T_world_cam = kf.T_cam_world.inverse();
    result.T_cam_world.push_back(kf.fixed ? kf.T_cam_world : (C * T_world_cam).inverse());
  }
  for (const Eigen::Vector3d& p : problem.problem.points_world) result.points_world.push_back(C * p);
  result.outlier.assign(problem.problem.observations.size(), false);
  return result;
}

bool near(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) { return a.isApprox(b, 1e-9); }

TEST(GlobalBaApply, KeyframesAndPointsAddedDuringTheSolveFollowTheCorrection) {
  std::vector<MapPointId> points;
  Map map = make_map(4, points);
  const LoopCloser closer(LoopClosingConfig{}, core::null_logger());
  const std::optional<GlobalBaProblem> problem = closer.prepare_global_ba(0, map);
  ASSERT_TRUE(problem.has_value());
  ASSERT_EQ(problem->keyframe_ids.size(), 4u);

  // While the BA "solves": a new keyframe of component 0 sharing points with the others and creating one
  // point of its own; a keyframe of another component.
  const KeyframeId added = map.add_keyframe(make_frame(kFeatures, 99), at(0.45), 0);
  for (std::size_t i = 20; i < 40; ++i) map.add_observation(points[i], added, static_cast<int>(i));
  const MapPointId new_point = map.add_map_point(Eigen::Vector3d(0.4, 0.1, 2.2), added, 50);
  map.update_connections(added);
  const KeyframeId other = map.add_keyframe(make_frame(kFeatures, 100), at(5.0), 1);
  const MapPointId other_point = map.add_map_point(Eigen::Vector3d(5.0, 0.0, 2.0), other, 0);
  const Eigen::Isometry3d added_before = map.keyframe(added)->T_world_cam;
  const Eigen::Vector3d new_point_before = map.point(new_point)->position;

  const Eigen::Isometry3d C = at(0.03, 0.02);
  const BaResult result = moved_by(*problem, C);

  std::set<KeyframeId> moved;
  ASSERT_TRUE(closer.apply_global_ba(*problem, result, map, moved));
  for (std::size_t k = 0; k < problem->keyframe_ids.size(); ++k) {
    if (problem->problem.keyframes[k].fixed) continue;
    EXPECT_TRUE(near(map.keyframe(problem->keyframe_ids[k])->T_world_cam, result.T_cam_world[k].inverse()));
  }
  EXPECT_TRUE(near(map.keyframe(added)->T_world_cam, C * added_before)) << "the added keyframe follows";
  EXPECT_EQ(moved.count(added), 1u);
  EXPECT_TRUE(map.point(new_point)->position.isApprox(C * new_point_before, 1e-9)) << "its point follows";
  EXPECT_TRUE(map.point(points[0])->position.isApprox(result.points_world[0], 1e-12));
  EXPECT_TRUE(near(map.keyframe(other)->T_world_cam, at(5.0))) << "another component is left alone";
  EXPECT_EQ(map.point(other_point)->position, Eigen::Vector3d(5.0, 0.0, 2.0));
  EXPECT_EQ(moved.count(other), 0u);
}

// A point created during the solve on a keyframe the problem held, while as many points were culled:
// the map's point count is what it was, and the new point must still follow its keyframe's correction.
TEST(GlobalBaApply, APointCreatedOnASolvedKeyframeFollowsItWhateverTheCount) {
  std::vector<MapPointId> points;
  Map map = make_map(3, points);
  const LoopCloser closer(LoopClosingConfig{}, core::null_logger());
  const std::optional<GlobalBaProblem> problem = closer.prepare_global_ba(0, map);
  ASSERT_TRUE(problem.has_value());
  const KeyframeId solved_kf = problem->keyframe_ids[2];
  ASSERT_FALSE(problem->problem.keyframes[2].fixed);
  const MapPointId new_point = map.add_map_point(Eigen::Vector3d(0.3, 0.2, 2.1), solved_kf, 55);
  map.erase_map_point(points[5]);
  ASSERT_EQ(map.point_count(), problem->point_ids.size());
  const Eigen::Vector3d new_point_before = map.point(new_point)->position;

  const Eigen::Isometry3d C = at(0.04, -0.03);
  const BaResult result = moved_by(*problem, C);
  std::set<KeyframeId> moved;
  ASSERT_TRUE(closer.apply_global_ba(*problem, result, map, moved));
  EXPECT_TRUE(map.point(new_point)->position.isApprox(C * new_point_before, 1e-9));
}

TEST(GlobalBaApply, AFailedSolveChangesNothing) {
  std::vector<MapPointId> points;
  Map map = make_map(3, points);
  const LoopCloser closer(LoopClosingConfig{}, core::null_logger());
  const std::optional<GlobalBaProblem> problem = closer.prepare_global_ba(0, map);
  ASSERT_TRUE(problem.has_value());
  BaResult failed;
  std::set<KeyframeId> moved;
  EXPECT_FALSE(closer.apply_global_ba(*problem, failed, map, moved));
  EXPECT_TRUE(moved.empty());
  EXPECT_TRUE(near(map.keyframe(problem->keyframe_ids[1])->T_world_cam, at(0.1)));
}

// Global BA classifies outliers with the agent's bundle-adjustment thresholds (mapping's `ba`, handed to
// the loop closer), not with defaults of its own: on a map whose points do not fit their observations,
// looser thresholds keep more observations.
TEST(GlobalBaSolve, UsesTheAgentsChiSquareThresholds) {
  std::vector<MapPointId> points;
  Map map = make_map(4, points);
  Frame& shifted = map.keyframe(2)->frame;  // six observations 8 px off the others
  for (std::size_t i = 20; i < 26; ++i) {
    shifted.uv[i].x() += 8.0;
    shifted.u_right[i] += 8.0;
  }
  const auto outliers = [&](double chi2) {
    LoopClosingConfig config;
    config.bundle_adjustment.chi2_mono = chi2;
    config.bundle_adjustment.chi2_stereo = chi2;
    const LoopCloser closer(config, core::null_logger());
    const std::optional<GlobalBaProblem> problem = closer.prepare_global_ba(0, map);
    EXPECT_TRUE(problem.has_value());
    if (!problem) return -1;
    const BaResult result = closer.solve_global_ba(*problem);
    EXPECT_TRUE(result.ok);
    int count = 0;
    for (const bool o : result.outlier) count += o ? 1 : 0;
    return count;
  };
  const int strict = outliers(0.1);
  const int loose = outliers(1000.0);
  EXPECT_GT(strict, loose);
}

}  // namespace
}  // namespace fleetslam::slam
