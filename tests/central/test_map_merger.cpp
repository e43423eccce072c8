#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "fleetslam/central/map_merger.hpp"
#include "fleetslam/core/config.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/core/se3.hpp"
#include "synthetic_clouds.hpp"

namespace fleetslam::central {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// A robot seeing the room where x is in [x_min, x_max]: its cloud in its own frame (true pose
// T_world_robot), and a prior that is the truth times `error` (an error in the robot's frame).
RobotCloud robot(int id, float x_min, float x_max, const Eigen::Isometry3d& T_world_robot, const Eigen::Isometry3d& error,
                 std::size_t points = 30000) {
  RobotCloud r;
  r.robot_id = id;
  r.cloud_robot = core::transformed(synthetic::room_cloud(points, x_min, x_max, 0.003f, 100 + static_cast<std::uint32_t>(id)),
                                    T_world_robot.inverse());
  r.T_world_robot_prior = T_world_robot * error;
  return r;
}

const Eigen::Isometry3d kPoseA = synthetic::pose(0.0, 0.0, 20.0, Eigen::Vector3d(1.5, 2.5, 1.2));
const Eigen::Isometry3d kPoseB = synthetic::pose(0.0, 0.0, 160.0, Eigen::Vector3d(4.5, 2.5, 1.2));
const Eigen::Isometry3d kPoseC = synthetic::pose(0.0, 0.0, -90.0, Eigen::Vector3d(5.0, 1.0, 1.0));

void expect_pose_near(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth, double max_m, double max_deg) {
  const auto [translation_m, rotation_rad] = synthetic::pose_error(estimate, truth);
  EXPECT_LT(translation_m, max_m);
  EXPECT_LT(rotation_rad, max_deg * kDeg);
}

TEST(MapMerger, RefinesAWrongPriorAndMergesSamplesAndFilters) {
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
  const std::vector<RobotCloud> robots = {robot(0, 0.0f, 4.0f, kPoseA, identity),
                                          robot(1, 2.0f, 6.0f, kPoseB, synthetic::prior_error())};
  const MergeResult result = MapMerger(MapMergerConfig{}).merge(robots);
  ASSERT_EQ(result.robots.size(), 2u);
  const RobotMergeReport& a = result.robots[0];
  const RobotMergeReport& b = result.robots[1];
  EXPECT_EQ(a.status, "reference");
  EXPECT_TRUE(a.placed);
  EXPECT_TRUE(a.T_world_robot.isApprox(kPoseA));
  EXPECT_EQ(b.status, "fine matched");
  EXPECT_TRUE(b.fine_matched);
  EXPECT_GT(b.overlap_points, 1000u);
  ASSERT_EQ(b.overlap_with.size(), 1u);
  EXPECT_EQ(b.overlap_with[0].first, 0);
  EXPECT_EQ(b.overlap_with[0].second, b.overlap_points);
  EXPECT_TRUE(b.registration.converged);
  EXPECT_LT(b.registration.fitness_m2, 0.1 * 0.1);  // 30k points sampled at 5 cm: neighbours cm apart
  // The prior was 10 cm and 5 degrees off.
  const auto [prior_m, prior_rad] = synthetic::pose_error(b.T_world_robot_prior, kPoseB);
  EXPECT_GT(prior_m, 0.05);
  EXPECT_GT(prior_rad, 4.0 * kDeg);
  expect_pose_near(b.T_world_robot, kPoseB, 0.01, 0.5);
  // Only the wide hypothesis pulls in a prior that far off, and it fits better.
  EXPECT_EQ(b.hypothesis, "wide");
  EXPECT_GT(b.consistency_wide, b.consistency_local);

  EXPECT_EQ(result.points_before_sampling, 60000u);
  EXPECT_LT(result.points_after_sampling, result.points_before_sampling);
  EXPECT_EQ(result.points_after_filter, result.points_after_sampling);
  EXPECT_EQ(result.cloud_world.size(), result.points_after_filter);
  EXPECT_TRUE(result.cloud_world.has_colors());
  EXPECT_GE(result.timings.total_ms, result.timings.coarse_ms + result.timings.registration_ms);
  EXPECT_GT(result.timings.coarse_ms, 0.0);
  EXPECT_GT(result.timings.registration_ms, 0.0);

  // The merged cloud lies on the room's surfaces: every point is close to a wall, floor, ceiling or box.
  const core::Bounds3f box = core::bounds(result.cloud_world);
  EXPECT_GT(box.min.x(), -0.05f);
  EXPECT_LT(box.max.x(), 6.05f);
}

TEST(MapMerger, ASecondRoundOnTheRefinedOverlapIsMoreAccurate) {
  const std::vector<RobotCloud> robots = {robot(0, 0.0f, 4.0f, kPoseA, Eigen::Isometry3d::Identity(), 60000),
                                          robot(1, 2.0f, 6.0f, kPoseB, synthetic::prior_error(), 60000)};
  MapMergerConfig config;
  config.sampling.enabled = false;
  config.filter.enabled = false;
  config.refinement_rounds = 1;
  const MergeResult one = MapMerger(config).merge(robots);
  config.refinement_rounds = 2;
  const MergeResult two = MapMerger(config).merge(robots);
  EXPECT_EQ(one.robots[1].refinement_rounds, 1);
  EXPECT_EQ(two.robots[1].refinement_rounds, 2);
  EXPECT_GT(two.robots[1].refined_overlap_points, two.robots[1].overlap_points);
  const auto [one_m, one_rad] = synthetic::pose_error(one.robots[1].T_world_robot, kPoseB);
  const auto [two_m, two_rad] = synthetic::pose_error(two.robots[1].T_world_robot, kPoseB);
  EXPECT_LT(two_m, one_m);
  EXPECT_LT(two_rad, one_rad);
  EXPECT_LT(two_m, 0.005);
  EXPECT_LT(two_rad, 0.2 * kDeg);
}

// A corridor along x (floor and two walls, no ends) seen by a robot where x is in [x_min, x_max], in
// the world frame.
core::PointCloud corridor(float x_min, float x_max, std::uint32_t seed, std::size_t n = 30000) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::normal_distribution<float> noise(0.0f, 0.003f);
  core::PointCloud cloud;
  for (std::size_t i = 0; i < n; ++i) {
    const float x = x_min + (x_max - x_min) * u(rng);
    const float a = u(rng), b = u(rng);
    const int surface = static_cast<int>(i % 3);
    if (surface == 0) cloud.push_back({x, 2.0f * a, noise(rng)});         // floor
    if (surface == 1) cloud.push_back({x, noise(rng), 2.5f * b});         // wall y = 0
    if (surface == 2) cloud.push_back({x, 2.0f + noise(rng), 2.5f * b});  // wall y = 2
  }
  return cloud;
}

// Along a corridor the overlap says nothing about x: with degeneracy_ratio set, x keeps the prior and the
// five constrained directions (y, z and all three rotations, about the overlap) are refined; without it
// GICP slides along the corridor.
TEST(MapMerger, ACorridorOverlapKeepsThePriorAlongTheCorridor) {
  const Eigen::Isometry3d error = synthetic::pose(0.5, -0.4, 2.0, Eigen::Vector3d(0.06, 0.05, -0.03));
  RobotCloud a{0, corridor(0.0f, 4.0f, 7), Eigen::Isometry3d::Identity()};
  RobotCloud b{1, corridor(2.0f, 6.0f, 8), error};  // b's frame is the world's; its prior is off
  MapMergerConfig config;
  config.sampling.enabled = false;
  config.filter.enabled = false;
  config.registration.degeneracy_ratio = 0.01;
  const MergeResult kept = MapMerger(config).merge({a, b});
  const RobotMergeReport& r = kept.robots[1];
  ASSERT_TRUE(r.fine_matched) << r.status;
  EXPECT_EQ(r.registration.degenerate_directions, 1);
  EXPECT_LT(r.registration.information_ratio, 5e-3);
  // The corridor's axis through the overlap stays where the prior put it, the rest is corrected.
  const Eigen::Vector3d centre(3.0, 1.0, 1.25);
  const Eigen::Vector3d moved = r.T_world_robot * centre;
  const Eigen::Vector3d prior = error * centre;
  // (within the small rotation's effect about the overlap's own centroid, a few mm here)
  EXPECT_NEAR(moved.x(), prior.x(), 0.01) << "x keeps the prior: " << moved.transpose() << " vs " << prior.transpose();
  EXPECT_LT(std::abs(moved.y() - centre.y()), 0.005) << "y is refined";
  EXPECT_LT(std::abs(moved.z() - centre.z()), 0.005) << "z is refined";
  EXPECT_LT(core::rotation_angle_rad(r.T_world_robot.linear()), 0.1 * kDeg) << "rotation is refined";
  // Without the check GICP slides along x on the noise (11 cm here).
  config.registration.degeneracy_ratio = 0.0;
  const MergeResult free = MapMerger(config).merge({a, b});
  EXPECT_EQ(free.robots[1].registration.degenerate_directions, 0);
  EXPECT_GT(std::abs((free.robots[1].T_world_robot * centre).x() - prior.x()), 0.05);
}

TEST(MapMerger, AnOverlapOfAWholeRoomHasNoDegenerateDirection) {
  MapMergerConfig config;
  config.registration.degeneracy_ratio = 0.01;
  const MergeResult merged = MapMerger(config).merge({robot(0, 0.0f, 4.0f, kPoseA, Eigen::Isometry3d::Identity()),
                                                      robot(1, 2.0f, 6.0f, kPoseB, synthetic::prior_error())});
  ASSERT_TRUE(merged.robots[1].fine_matched);
  EXPECT_EQ(merged.robots[1].registration.degenerate_directions, 0);
  EXPECT_GT(merged.robots[1].registration.information_ratio, 0.01);
  expect_pose_near(merged.robots[1].T_world_robot, kPoseB, 0.005, 0.1);
}

// Two rooms parted by a 12 cm wall, one robot in each, seeing the other room through the doorway. The
// wall's faces are 12 cm apart and face away from each other: pairing them pulls the robots together.
// With the dense maps' normals only the surfaces both see (through the doorway) align them.
TEST(MapMerger, OppositeFacesOfAThinWallDoNotPair) {
  const Eigen::Isometry3d error = synthetic::pose(0.4, -0.3, 1.0, Eigen::Vector3d(0.02, -0.015, 0.01));
  const RobotCloud a{0, synthetic::two_room_cloud(60000, {1.5f, 2.5f, 1.2f}, 0.003f, 21), Eigen::Isometry3d::Identity()};
  const RobotCloud b{1, synthetic::two_room_cloud(60000, {4.5f, 2.5f, 1.2f}, 0.003f, 22), error};
  ASSERT_TRUE(a.cloud_robot.has_normals());
  const MergeResult merged = MapMerger(MapMergerConfig{}).merge({a, b});
  const RobotMergeReport& r = merged.robots[1];
  ASSERT_TRUE(r.fine_matched) << r.status;
  EXPECT_GT(r.overlap_normal_rejected, 1000u) << "the wall's faces are mutual nearest neighbours";
  expect_pose_near(r.T_world_robot, Eigen::Isometry3d::Identity(), 0.005, 0.2);
  EXPECT_TRUE(merged.cloud_world.has_normals()) << "the normals survive merging, sampling and filtering";

  // The oracle: without normals the faces pair and the wide GICP alone (the paper's fine matching) pulls B
  // centimetres towards A.
  RobotCloud a_bare = a, b_bare = b;
  a_bare.cloud_robot.normals.clear();
  b_bare.cloud_robot.normals.clear();
  MapMergerConfig wide_only;
  wide_only.local_hypothesis = false;
  const MergeResult pulled = MapMerger(wide_only).merge({a_bare, b_bare});
  EXPECT_EQ(pulled.robots[1].overlap_normal_rejected, 0u);
  EXPECT_EQ(pulled.robots[1].hypothesis, "wide");
  EXPECT_EQ(pulled.robots[1].consistency_local, -1.0);
  const double pulled_m = synthetic::pose_error(pulled.robots[1].T_world_robot, Eigen::Isometry3d::Identity()).first;
  EXPECT_GT(pulled_m, 0.02);
  // Weighed against the local hypothesis (the prior, 2.7 cm off, polished with 5 cm correspondences), the
  // pulled result is the less consistent one, even without normals.
  const MergeResult weighed = MapMerger(MapMergerConfig{}).merge({a_bare, b_bare});
  const RobotMergeReport& w = weighed.robots[1];
  EXPECT_EQ(w.hypothesis, "local");
  EXPECT_GT(w.consistency_local, w.consistency_wide);
  EXPECT_LT(synthetic::pose_error(w.T_world_robot, Eigen::Isometry3d::Identity()).first, 0.25 * pulled_m);
}

// Exact priors: neither GICP result fits clearly better than the prior, which stays as it is (confirmed);
// unweighed, the paper's fine matching moves it.
TEST(MapMerger, AnExactPriorThatNothingFitsBetterStays) {
  const RobotCloud a{0, synthetic::two_room_cloud(60000, {1.5f, 2.5f, 1.2f}, 0.003f, 41), Eigen::Isometry3d::Identity()};
  const RobotCloud b{1, synthetic::two_room_cloud(60000, {4.5f, 2.5f, 1.2f}, 0.003f, 42), Eigen::Isometry3d::Identity()};
  const MergeResult merged = MapMerger(MapMergerConfig{}).merge({a, b});
  const RobotMergeReport& r = merged.robots[1];
  EXPECT_EQ(r.status, "fine matched");
  EXPECT_TRUE(r.fine_matched);
  EXPECT_EQ(r.hypothesis, "prior");
  EXPECT_EQ(r.refinement_rounds, 0);
  EXPECT_GT(r.consistency_local, 0.0);
  EXPECT_GT(r.consistency_wide, 0.0);
  EXPECT_TRUE(r.T_world_robot.isApprox(Eigen::Isometry3d::Identity(), 0.0));

  MapMergerConfig unweighed;
  unweighed.local_hypothesis = false;
  const RobotMergeReport& moved = MapMerger(unweighed).merge({a, b}).robots[1];
  EXPECT_EQ(moved.hypothesis, "wide");
  EXPECT_GT(moved.refinement_rounds, 0);
  EXPECT_FALSE(moved.T_world_robot.isApprox(Eigen::Isometry3d::Identity(), 0.0));
}

// A fit must put at least min_consistency of the cloud on the merged map: with the bar above anything the
// prior or a hypothesis reaches, the overlap's pairs count as no common surface, as if there were no
// overlap: the robot keeps its prior without being fine matched, or is left out when it must overlap.
TEST(MapMerger, PairsOnNoCommonSurfaceCountAsNoOverlap) {
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
  std::vector<RobotCloud> robots = {robot(0, 0.0f, 4.0f, kPoseA, identity),
                                    robot(1, 2.0f, 6.0f, kPoseB, synthetic::prior_error())};
  const RobotMergeReport applied = MapMerger(MapMergerConfig{}).merge(robots).robots[1];
  ASSERT_EQ(applied.hypothesis, "wide");
  // Above the default bar of 0.05 (0.14 here): the default applies this fit.
  ASSERT_GT(applied.consistency_wide, MapMergerConfig{}.min_consistency) << applied.consistency_wide;
  MapMergerConfig strict;
  strict.min_consistency = 1.0;
  const RobotMergeReport kept = MapMerger(strict).merge(robots).robots[1];
  EXPECT_TRUE(kept.no_common_surface);
  EXPECT_FALSE(kept.fine_matched);
  EXPECT_TRUE(kept.placed);
  EXPECT_EQ(kept.hypothesis, "");
  EXPECT_EQ(kept.status, "no common surface on " + std::to_string(kept.overlap_points) + " pairs: prior kept");
  EXPECT_TRUE(kept.T_world_robot.isApprox(kept.T_world_robot_prior));
  EXPECT_DOUBLE_EQ(kept.consistency_wide, applied.consistency_wide);  // scored alike, only the bar moved

  robots[1].keep_prior_without_overlap = false;
  const RobotMergeReport left_out = MapMerger(strict).merge(robots).robots[1];
  EXPECT_FALSE(left_out.placed);
  EXPECT_NE(left_out.status.find("no common surface"), std::string::npos) << left_out.status;
  EXPECT_NE(left_out.status.find("left out"), std::string::npos) << left_out.status;
}

TEST(MapMerger, ARobotThatOverlapsOnlyALaterOneWaitsForIt) {
  // C sees x in [4.5, 6], which only B (x in [2, 5.2]) overlaps; C comes before B.
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
  const Eigen::Isometry3d small_error = synthetic::pose(0.5, -0.5, 2.0, Eigen::Vector3d(0.05, 0.03, -0.02));
  const std::vector<RobotCloud> robots = {robot(0, 0.0f, 3.0f, kPoseA, identity),
                                          robot(2, 4.5f, 6.0f, kPoseC, small_error, 15000),
                                          robot(1, 2.0f, 5.2f, kPoseB, synthetic::prior_error())};
  const MergeResult result = MapMerger(MapMergerConfig{}).merge(robots);
  ASSERT_EQ(result.robots.size(), 3u);
  EXPECT_EQ(result.robots[2].status, "fine matched");
  expect_pose_near(result.robots[2].T_world_robot, kPoseB, 0.01, 0.5);
  const RobotMergeReport& c = result.robots[1];
  EXPECT_EQ(c.status, "fine matched");
  expect_pose_near(c.T_world_robot, kPoseC, 0.01, 0.5);
  // C's last coarse matching saw A and B, and its overlap is with B.
  ASSERT_EQ(c.overlap_with.size(), 2u);
  EXPECT_EQ(c.overlap_with[0].first, 0);
  EXPECT_EQ(c.overlap_with[1].first, 1);
  EXPECT_GT(c.overlap_with[1].second, c.overlap_with[0].second);
}

// B (exact prior) sees only x in [4.5, 6], which A does not overlap; B2, a later map component of B
// (after_id), overlaps both. B2 waits for B: B keeps its prior (nothing else overlaps it yet) and B2 is
// matched against A and B. Without the order B2 is placed first and B is then matched against it.
TEST(MapMerger, ALaterComponentWaitsForTheInputItContinues) {
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
  const Eigen::Isometry3d small_error = synthetic::pose(0.5, -0.5, 2.0, Eigen::Vector3d(0.05, 0.03, -0.02));
  std::vector<RobotCloud> robots = {robot(0, 0.0f, 3.0f, kPoseA, identity), robot(1, 4.5f, 6.0f, kPoseC, identity, 15000),
                                    robot(2, 2.0f, 5.2f, kPoseB, small_error)};
  robots[2].keep_prior_without_overlap = false;
  const MergeResult unordered = MapMerger(MapMergerConfig{}).merge(robots);
  ASSERT_EQ(unordered.robots[1].overlap_with.size(), 2u);
  EXPECT_GT(unordered.robots[1].overlap_with[1].second, 0u) << "B was matched against B2";
  EXPECT_EQ(unordered.robots[1].status, "fine matched");

  robots[2].after_id = 1;
  const MergeResult ordered = MapMerger(MapMergerConfig{}).merge(robots);
  const RobotMergeReport& b = ordered.robots[1];
  EXPECT_EQ(b.status, "no overlap: prior kept");
  EXPECT_TRUE(b.T_world_robot.isApprox(kPoseC, 0.0));
  const RobotMergeReport& b2 = ordered.robots[2];
  EXPECT_EQ(b2.status, "fine matched");
  expect_pose_near(b2.T_world_robot, kPoseB, 0.01, 0.5);
  ASSERT_EQ(b2.overlap_with.size(), 2u);  // A and B
  EXPECT_GT(b2.overlap_with[1].second, 0u);

  // What B2 waits for cannot join by itself (no overlap, and no prior to keep): the order is let go, B2
  // is matched against A, and B then against B2.
  robots[1].keep_prior_without_overlap = false;
  const MergeResult stranded = MapMerger(MapMergerConfig{}).merge(robots);
  EXPECT_EQ(stranded.robots[2].status, "fine matched");
  EXPECT_EQ(stranded.robots[1].status, "fine matched");
  EXPECT_TRUE(stranded.robots[1].placed);
}

// A prior 30 km from the world origin puts the cloud beyond the 2 cm sampling grid's reach (21 km): it
// would be folded into the border voxels, so the robot is left out and the others merge as before.
TEST(MapMerger, ACloudBeyondTheVoxelGridsReachIsLeftOut) {
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
  std::vector<RobotCloud> robots = {robot(0, 0.0f, 4.0f, kPoseA, identity),
                                    robot(1, 2.0f, 6.0f, kPoseB, synthetic::prior_error()),
                                    robot(2, 0.0f, 3.0f, kPoseC, identity, 5000)};
  robots[2].T_world_robot_prior.translation().x() += 30000.0;
  const MergeResult result = MapMerger(MapMergerConfig{}).merge(robots);
  EXPECT_EQ(result.robots[1].status, "fine matched");
  const RobotMergeReport& far = result.robots[2];
  EXPECT_FALSE(far.placed);
  EXPECT_NE(far.status.find("too far from the world origin"), std::string::npos) << far.status;
  EXPECT_NE(far.status.find("reach 20971 m"), std::string::npos) << far.status;
  for (const Eigen::Vector3f& p : result.cloud_world.points) EXPECT_LT(p.norm(), 100.0f);
  // Within reach (10 km) it is merged, by its prior (no overlap).
  robots[2].T_world_robot_prior.translation().x() -= 20000.0;
  EXPECT_TRUE(MapMerger(MapMergerConfig{}).merge(robots).robots[2].placed);
}

// Nobody overlaps anybody, and B2 (continuing B) comes before B: when no robot is placed by matching,
// the fallback that keeps a prior takes B, not B2, which waits for it; B2 then starts from B's placement
// (exact) instead of its own wrong prior.
TEST(MapMerger, TheNoOverlapFallbackKeepsAWaitingComponentWaiting) {
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
  std::vector<RobotCloud> robots = {robot(0, 0.0f, 2.5f, kPoseA, identity),
                                    robot(2, 5.0f, 6.0f, kPoseB, synthetic::prior_error(), 8000),
                                    robot(1, 3.2f, 4.3f, kPoseB, identity, 8000)};
  robots[1].after_id = 1;
  robots[1].T_after_robot = identity;
  const MergeResult result = MapMerger(MapMergerConfig{}).merge(robots);
  const RobotMergeReport& b2 = result.robots[1];
  const RobotMergeReport& b = result.robots[2];
  EXPECT_EQ(b.status, "no overlap: prior kept");
  EXPECT_TRUE(b.T_world_robot.isApprox(kPoseB));
  EXPECT_EQ(b2.status, "no overlap: prior kept");
  EXPECT_TRUE(b2.T_world_robot_prior.isApprox(kPoseB)) << "B2 kept its own prior instead of B's placement";
  EXPECT_TRUE(b2.T_world_robot.isApprox(kPoseB));
}

// B2 continues B in B's own map frame (T_after_robot identity) and overlaps nobody, so it keeps its
// prior. Its prior was B's wrong prior (10 cm, 5 degrees off); once this merge corrects B, B2 starts from
// B's corrected placement and keeps that.
TEST(MapMerger, ALaterComponentStartsFromThePlacementOfTheInputItContinues) {
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
  std::vector<RobotCloud> robots = {robot(0, 0.0f, 3.0f, kPoseA, identity),
                                    robot(1, 2.0f, 4.5f, kPoseB, synthetic::prior_error()),
                                    robot(2, 5.4f, 6.0f, kPoseB, synthetic::prior_error(), 8000)};
  robots[2].after_id = 1;
  const MergeResult without = MapMerger(MapMergerConfig{}).merge(robots);
  ASSERT_EQ(without.robots[1].status, "fine matched");
  EXPECT_EQ(without.robots[2].status, "no overlap: prior kept");
  EXPECT_GT(synthetic::pose_error(without.robots[2].T_world_robot, kPoseB).first, 0.05);

  robots[2].T_after_robot = identity;
  const MergeResult chained = MapMerger(MapMergerConfig{}).merge(robots);
  const RobotMergeReport& b = chained.robots[1];
  const RobotMergeReport& b2 = chained.robots[2];
  ASSERT_EQ(b.status, "fine matched");
  expect_pose_near(b.T_world_robot, kPoseB, 0.01, 0.5);
  EXPECT_EQ(b2.status, "no overlap: prior kept");
  EXPECT_TRUE(b2.T_world_robot_prior.isApprox(b.T_world_robot));
  EXPECT_TRUE(b2.T_world_robot.isApprox(b.T_world_robot));
  // Its points moved with it: the merged cloud holds them where B's correction puts them.
  EXPECT_EQ(chained.points_before_sampling, without.points_before_sampling);
  const Eigen::Vector3d corner = kPoseB * robots[2].cloud_robot.points.front().cast<double>();  // where it truly is
  const auto nearest_m = [&](const MergeResult& r) {
    double best = std::numeric_limits<double>::infinity();
    for (const Eigen::Vector3f& p : r.cloud_world.points) best = std::min(best, (p.cast<double>() - corner).norm());
    return best;
  };
  EXPECT_LT(nearest_m(chained), 0.02);
  EXPECT_GT(nearest_m(without), 0.05);

  // A relative transform that is not rigid leaves the cloud out.
  robots[2].T_after_robot->matrix()(0, 0) = 2.0;
  const MergeResult bad = MapMerger(MapMergerConfig{}).merge(robots);
  EXPECT_EQ(bad.robots[2].status, "bad prior (T_after_robot not a finite rigid transform): left out");
  EXPECT_FALSE(bad.robots[2].placed);
  EXPECT_EQ(bad.robots[1].status, "fine matched");
}

TEST(MapMerger, EmptyNaNAndNeverOverlappingRobotsLeaveTheOthersUnaffected) {
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
  std::vector<RobotCloud> robots = {robot(0, 0.0f, 4.0f, kPoseA, identity),
                                    robot(1, 2.0f, 6.0f, kPoseB, synthetic::prior_error())};
  // NaN points in B.
  for (std::size_t i = 0; i < robots[1].cloud_robot.size(); i += 100) {
    robots[1].cloud_robot.points[i].y() = std::numeric_limits<float>::quiet_NaN();
  }
  // An empty robot, a robot in another building (100 m away) and one with a broken prior.
  RobotCloud empty;
  empty.robot_id = 7;
  robots.push_back(empty);
  RobotCloud elsewhere;  // a room like this one, but its prior puts it 100 m away
  elsewhere.robot_id = 8;
  elsewhere.cloud_robot = synthetic::room_cloud(5000, 0.0f, 6.0f, 0.003f, 8);
  elsewhere.T_world_robot_prior = synthetic::pose(0, 0, 0, Eigen::Vector3d(100, 0, 0));
  robots.push_back(elsewhere);
  RobotCloud broken = robot(9, 0.0f, 6.0f, kPoseA, identity, 1000);
  broken.T_world_robot_prior.matrix()(0, 3) = std::numeric_limits<double>::quiet_NaN();
  robots.push_back(broken);

  const MergeResult result = MapMerger(MapMergerConfig{}).merge(robots);
  ASSERT_EQ(result.robots.size(), 5u);
  const RobotMergeReport& b = result.robots[1];
  EXPECT_EQ(b.non_finite_removed, 300u);
  EXPECT_EQ(b.points, 29700u);
  EXPECT_EQ(b.status, "fine matched");
  expect_pose_near(b.T_world_robot, kPoseB, 0.01, 0.5);

  const RobotMergeReport& e = result.robots[2];
  EXPECT_EQ(e.points, 0u);
  EXPECT_TRUE(e.placed);
  EXPECT_FALSE(e.fine_matched);
  EXPECT_NE(e.status.find("empty"), std::string::npos);

  const RobotMergeReport& far = result.robots[3];
  EXPECT_TRUE(far.placed);
  EXPECT_FALSE(far.fine_matched);
  EXPECT_EQ(far.overlap_points, 0u);
  EXPECT_EQ(far.status, "no overlap: prior kept");
  EXPECT_TRUE(far.T_world_robot.isApprox(far.T_world_robot_prior));

  const RobotMergeReport& bad = result.robots[4];
  EXPECT_FALSE(bad.placed);
  EXPECT_NE(bad.status.find("bad prior"), std::string::npos);

  EXPECT_EQ(result.points_before_sampling, 30000u + 29700u + 5000u);
  // The far robot's points are in the map, where its prior put them.
  EXPECT_GT(core::bounds(result.cloud_world).max.x(), 100.0f);
}

// A cloud whose prior is only a guess (a robot's later map component) joins by overlap or not at all;
// the same cloud that does overlap is matched as usual.
TEST(MapMerger, ACloudThatMustOverlapIsLeftOutWithoutOverlap) {
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
  std::vector<RobotCloud> robots = {robot(0, 0.0f, 4.0f, kPoseA, identity)};
  RobotCloud elsewhere;
  elsewhere.robot_id = 8;
  elsewhere.cloud_robot = synthetic::room_cloud(5000, 0.0f, 6.0f, 0.003f, 8);
  elsewhere.T_world_robot_prior = synthetic::pose(0, 0, 0, Eigen::Vector3d(100, 0, 0));
  elsewhere.keep_prior_without_overlap = false;
  robots.push_back(elsewhere);
  RobotCloud overlapping = robot(9, 2.0f, 6.0f, kPoseB, synthetic::prior_error());
  overlapping.keep_prior_without_overlap = false;
  robots.push_back(overlapping);

  const MergeResult result = MapMerger(MapMergerConfig{}).merge(robots);
  ASSERT_EQ(result.robots.size(), 3u);
  const RobotMergeReport& far = result.robots[1];
  EXPECT_FALSE(far.placed);
  EXPECT_EQ(far.status, "no overlap: left out");
  EXPECT_TRUE(far.T_world_robot.isApprox(far.T_world_robot_prior));
  EXPECT_TRUE(result.robots[2].placed);
  EXPECT_TRUE(result.robots[2].fine_matched) << result.robots[2].status;
  EXPECT_EQ(result.points_before_sampling, result.robots[0].points + result.robots[2].points);
  EXPECT_LT(core::bounds(result.cloud_world).max.x(), 50.0f);
}

// The same 10 cm / 5 degree prior error as above, with the corrections allowed below it: GICP's answer
// is refused and the prior kept; with the limits above it (the defaults), accepted.
TEST(MapMerger, ACorrectionBeyondTheLimitsIsDiscarded) {
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
  const std::vector<RobotCloud> robots = {robot(0, 0.0f, 4.0f, kPoseA, identity),
                                          robot(1, 2.0f, 6.0f, kPoseB, synthetic::prior_error())};
  for (const double limit_m : {0.03, 0.5}) {
    MapMergerConfig config;
    config.max_correction_m = limit_m;
    const MergeResult result = MapMerger(config).merge(robots);
    const RobotMergeReport& b = result.robots[1];
    if (limit_m < 0.1) {
      EXPECT_FALSE(b.fine_matched);
      EXPECT_NE(b.status.find("beyond the limits"), std::string::npos) << b.status;
      EXPECT_TRUE(b.T_world_robot.isApprox(b.T_world_robot_prior));
    } else {
      EXPECT_TRUE(b.fine_matched) << b.status;
      expect_pose_near(b.T_world_robot, kPoseB, 0.01, 0.5);
    }
  }
  MapMergerConfig degrees;
  degrees.max_correction_deg = 1.0;
  EXPECT_FALSE(MapMerger(degrees).merge(robots).robots[1].fine_matched);
}

TEST(MapMerger, CoarseOnlyAndNothingToMerge) {
  MapMergerConfig config;
  config.registration.enabled = false;
  config.sampling.enabled = false;
  config.filter.enabled = false;
  const std::vector<RobotCloud> robots = {
      robot(0, 0.0f, 4.0f, kPoseA, Eigen::Isometry3d::Identity(), 5000),
      robot(1, 2.0f, 6.0f, kPoseB, synthetic::prior_error(), 5000)};
  const MergeResult result = MapMerger(config).merge(robots);
  EXPECT_EQ(result.robots[1].status, "coarse only (registration disabled)");
  EXPECT_TRUE(result.robots[1].T_world_robot.isApprox(robots[1].T_world_robot_prior));
  EXPECT_EQ(result.cloud_world.size(), 10000u);
  EXPECT_EQ(result.points_after_sampling, 10000u);

  const MergeResult nothing = MapMerger(MapMergerConfig{}).merge({});
  EXPECT_TRUE(nothing.cloud_world.empty());
  EXPECT_TRUE(nothing.robots.empty());
}

TEST(MapMerger, DuplicateRobotIdsAreAnInputError) {
  RobotCloud a;
  a.robot_id = 3;
  EXPECT_THROW(MapMerger(MapMergerConfig{}).merge({a, a}), InputError);
}

TEST(MapMerger, ConfigReadsFromYamlAndRejectsUnknownKeys) {
  const std::string yaml =
      "merge:\n"
      "  coarse: {coarse_radius_m: 0.4}\n"
      "  registration: {backend: pcl, max_iterations: 12, voxel_size_m: 0.1}\n"
      "  min_overlap_points: 50\n"
      "  sampling: {voxel_size_m: 0.03}\n"
      "  filter: {enabled: false, neighbours: 8}\n";
  const MapMergerConfig config =
      core::load_config<MapMergerConfig>(core::ConfigReader::from_string(yaml, "merge.yaml"), "merge");
  EXPECT_EQ(config.coarse.coarse_radius_m, 0.4);
  EXPECT_EQ(config.registration.backend, RegistrationBackend::kPcl);
  EXPECT_EQ(config.registration.max_iterations, 12);
  EXPECT_EQ(config.min_overlap_points, 50);
  EXPECT_EQ(config.sampling.voxel_size_m, 0.03);
  EXPECT_FALSE(config.filter.enabled);
  EXPECT_EQ(config.filter.neighbours, 8);
  const std::string written = core::config_to_yaml(config);
  EXPECT_NE(written.find("coarse_radius_m: 0.4"), std::string::npos) << written;
  EXPECT_THROW(core::load_config<MapMergerConfig>(
                   core::ConfigReader::from_string("merge: {sampling: {voxel: 1}}\n", "bad.yaml"), "merge"),
               InputError);
  EXPECT_THROW(core::load_config<MapMergerConfig>(
                   core::ConfigReader::from_string("merge: {filter: {sigma_m: -1}}\n", "bad.yaml"), "merge"),
               InputError);
}

}  // namespace
}  // namespace fleetslam::central
