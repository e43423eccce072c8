#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "fleetslam/central/registration.hpp"
#include "fleetslam/core/error.hpp"
#include "synthetic_clouds.hpp"

namespace fleetslam::central {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

class GicpBackends : public ::testing::TestWithParam<RegistrationBackend> {};

// Two independent noisy samplings of the room; the source is displaced by the prior error
// (10 cm, 5 degrees), so the true T_target_source is that error.
TEST_P(GicpBackends, RecoversA10cm5DegreePerturbationOnARoom) {
  const core::PointCloud target = synthetic::room_cloud(40000, 0.0f, 6.0f, 0.003f, 1);
  const Eigen::Isometry3d E = synthetic::prior_error();
  // Source points are in a frame where T_target_source = E: p_source = E^-1 p_target.
  const core::PointCloud source = core::transformed(synthetic::room_cloud(40000, 0.0f, 6.0f, 0.003f, 2), E.inverse());
  RegistrationConfig config;
  config.backend = GetParam();
  const RegistrationResult result = GicpRegistration(config).align(source, target);
  const auto [translation_m, rotation_rad] = synthetic::pose_error(result.T_target_source, E);
  EXPECT_TRUE(result.converged) << result.status;
  EXPECT_LT(translation_m, 0.01);
  EXPECT_LT(rotation_rad, 0.5 * kDeg);
  EXPECT_GT(result.iterations, 1);
  // Two independent samplings, thinned to 5 cm: nearest neighbours are a few centimetres apart.
  EXPECT_LT(result.fitness_m2, 0.05 * 0.05);
  EXPECT_GT(result.inlier_ratio, 0.95);
  EXPECT_GT(result.source_points, 1000u);  // sampled at 5 cm from 40k
  EXPECT_LT(result.source_points, 40000u);
}

INSTANTIATE_TEST_SUITE_P(Backends, GicpBackends,
                         ::testing::Values(RegistrationBackend::kNative, RegistrationBackend::kPcl),
                         [](const ::testing::TestParamInfo<RegistrationBackend>& param_info) {
                           return std::string(param_info.param == RegistrationBackend::kNative ? "native" : "pcl");
                         });

TEST(GicpRegistration, NativeIsAccurateWithoutSamplingAndFromAGuess) {
  const core::PointCloud target = synthetic::room_cloud(8000, 0.0f, 6.0f, 0.002f, 3);
  const Eigen::Isometry3d E = synthetic::pose(2.0, -1.0, 4.0, Eigen::Vector3d(0.05, -0.08, 0.03));
  const core::PointCloud source = core::transformed(synthetic::room_cloud(8000, 0.0f, 6.0f, 0.002f, 4), E.inverse());
  RegistrationConfig config;
  config.voxel_size_m = 0.0;
  const Eigen::Isometry3d guess = synthetic::pose(1.0, 0.0, 3.0, Eigen::Vector3d(0.03, -0.05, 0.0));
  const RegistrationResult result = GicpRegistration(config).align(source, target, guess);
  EXPECT_EQ(result.source_points, 8000u);
  const auto [translation_m, rotation_rad] = synthetic::pose_error(result.T_target_source, E);
  EXPECT_LT(translation_m, 0.01);
  EXPECT_LT(rotation_rad, 0.5 * kDeg);
}

// Planes from the points' own normals (covariance: normals) on the two rooms seen from both sides of the
// doorway, a few centimetres off; where no point has a normal they fall back to the neighbours' planes,
// exactly.
TEST(GicpRegistration, PlanesFromNormalsAndTheirFallback) {
  const core::PointCloud target = synthetic::two_room_cloud(40000, {1.5f, 2.5f, 1.2f}, 0.003f, 31);
  const Eigen::Isometry3d E = synthetic::pose(0.5, -0.3, 1.0, Eigen::Vector3d(0.03, -0.02, 0.01));
  const core::PointCloud source =
      core::transformed(synthetic::two_room_cloud(40000, {1.8f, 2.2f, 1.2f}, 0.003f, 32), E.inverse());
  ASSERT_TRUE(source.has_normals() && target.has_normals());
  RegistrationConfig config;
  config.covariance = PlaneCovariance::kNormals;
  config.max_correspondence_distance_m = 0.1;
  config.voxel_size_m = 0.03;
  const RegistrationResult result = GicpRegistration(config).align(source, target);
  EXPECT_TRUE(result.converged) << result.status;
  const auto [translation_m, rotation_rad] = synthetic::pose_error(result.T_target_source, E);
  EXPECT_LT(translation_m, 0.005);
  EXPECT_LT(rotation_rad, 0.2 * kDeg);

  core::PointCloud source_bare = source, target_bare = target;
  source_bare.normals.clear();
  target_bare.normals.clear();
  const RegistrationResult from_normals = GicpRegistration(config).align(source_bare, target_bare);
  config.covariance = PlaneCovariance::kNeighbours;
  const RegistrationResult from_neighbours = GicpRegistration(config).align(source_bare, target_bare);
  EXPECT_TRUE(from_normals.T_target_source.isApprox(from_neighbours.T_target_source, 0.0));
  EXPECT_EQ(from_normals.iterations, from_neighbours.iterations);
}

TEST(GicpRegistration, IdenticalCloudsGiveTheIdentity) {
  const core::PointCloud cloud = synthetic::room_cloud(5000, 0.0f, 6.0f, 0.0f, 5);
  const RegistrationResult result = GicpRegistration(RegistrationConfig{}).align(cloud, cloud);
  EXPECT_TRUE(result.converged);
  const auto [translation_m, rotation_rad] = synthetic::pose_error(result.T_target_source, Eigen::Isometry3d::Identity());
  EXPECT_LT(translation_m, 1e-4);
  EXPECT_LT(rotation_rad, 1e-4);
  EXPECT_LT(result.fitness_m2, 1e-10);
  EXPECT_EQ(result.inlier_ratio, 1.0);
}

TEST(GicpRegistration, FailuresAreInTheResult) {
  const core::PointCloud room = synthetic::room_cloud(2000, 0.0f, 6.0f, 0.003f, 6);
  core::PointCloud few;
  few.push_back({0, 0, 0});
  few.push_back({std::numeric_limits<float>::quiet_NaN(), 0, 0});
  const Eigen::Isometry3d guess = synthetic::pose(0.0, 0.0, 10.0, Eigen::Vector3d(1, 2, 3));
  const GicpRegistration gicp(RegistrationConfig{});
  RegistrationResult result = gicp.align(few, room, guess);
  EXPECT_FALSE(result.converged);
  EXPECT_EQ(result.status, "too few points");
  EXPECT_TRUE(result.T_target_source.isApprox(guess));
  EXPECT_EQ(result.source_points, 1u);
  EXPECT_EQ(gicp.align(room, core::PointCloud{}).status, "too few points");

  // PCL's backend needs covariance_neighbours points in each set (with fewer it read covariances it never
  // computed): 15 points against k = 20 are too few there, not for the native one.
  core::PointCloud fifteen;
  for (int i = 0; i < 15; ++i) fifteen.push_back({0.1f * static_cast<float>(i % 5), 0.1f * static_cast<float>(i / 5), 0.0f});
  RegistrationConfig pcl;
  pcl.backend = RegistrationBackend::kPcl;
  pcl.voxel_size_m = 0.0;
  EXPECT_EQ(GicpRegistration(pcl).align(fifteen, fifteen).status, "too few points");
  pcl.backend = RegistrationBackend::kNative;
  EXPECT_NE(GicpRegistration(pcl).align(fifteen, fifteen).status, "too few points");
  // Out of iterations is no convergence, whatever PCL's own flag says.
  RegistrationConfig one_step;
  one_step.backend = RegistrationBackend::kPcl;
  one_step.max_iterations = 1;
  const core::PointCloud moved = core::transformed(room, synthetic::pose(0.0, 0.0, 5.0, Eigen::Vector3d(0.1, 0, 0)));
  result = GicpRegistration(one_step).align(moved, room);
  EXPECT_FALSE(result.converged);
  EXPECT_EQ(result.status, "max iterations");

  // Far apart: no correspondence within the distance.
  const core::PointCloud far = core::transformed(room, synthetic::pose(0, 0, 0, Eigen::Vector3d(50, 0, 0)));
  result = gicp.align(far, room);
  EXPECT_FALSE(result.converged);
  EXPECT_EQ(result.status, "degenerate");
  EXPECT_EQ(result.inlier_ratio, 0.0);

  RegistrationConfig off;
  off.enabled = false;
  result = GicpRegistration(off).align(room, room, guess);
  EXPECT_EQ(result.status, "disabled");
  EXPECT_TRUE(result.T_target_source.isApprox(guess));
}

TEST(GicpRegistration, RejectsBadSettings) {
  const auto rejects = [](auto change) {
    RegistrationConfig config;
    change(config);
    EXPECT_THROW(GicpRegistration{config}, InputError);
  };
  rejects([](RegistrationConfig& c) { c.max_iterations = 0; });
  rejects([](RegistrationConfig& c) { c.max_correspondence_distance_m = 0.0; });
  rejects([](RegistrationConfig& c) { c.voxel_size_m = -0.1; });
  rejects([](RegistrationConfig& c) { c.covariance_neighbours = 2; });
  rejects([](RegistrationConfig& c) { c.plane_epsilon = 0.0; });
  rejects([](RegistrationConfig& c) { c.translation_epsilon_m = -1.0; });
}

}  // namespace
}  // namespace fleetslam::central
