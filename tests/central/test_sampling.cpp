#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <random>
#include <tuple>
#include <vector>

#include "fleetslam/central/sampling.hpp"
#include "fleetslam/core/error.hpp"

namespace fleetslam::central {
namespace {

core::PointCloud random_cloud(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-0.5f, 0.5f);
  std::normal_distribution<float> cluster(0.3f, 0.01f);
  std::uniform_int_distribution<int> channel(0, 255);
  core::PointCloud cloud;
  for (std::size_t i = 0; i < n; ++i) {
    // A uniform box, a dense cluster (many points per voxel) and points on voxel faces (0.1 m steps).
    Eigen::Vector3f p(u(rng), u(rng), u(rng));
    if (i % 3 == 1) p = Eigen::Vector3f(cluster(rng), cluster(rng), cluster(rng));
    if (i % 7 == 2) p = (p * 10.0f).array().round().matrix() / 10.0f;
    cloud.push_back(p, {static_cast<std::uint8_t>(channel(rng)), static_cast<std::uint8_t>(channel(rng)),
                        static_cast<std::uint8_t>(channel(rng))});
  }
  return cloud;
}

// Oracle: for each voxel (same float arithmetic as documented), the point nearest the centre, ties to
// the smaller index; returned as ascending input indices.
std::vector<std::uint32_t> brute_force_kept(const core::PointCloud& cloud, float size) {
  const float inverse = 1.0f / size;
  std::map<std::tuple<int, int, int>, std::pair<float, std::uint32_t>> best;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f& p = cloud.points[i];
    if (!p.allFinite()) continue;
    const Eigen::Vector3i v((p * inverse).array().floor().cast<int>());
    const Eigen::Vector3f centre = (v.cast<float>() + Eigen::Vector3f::Constant(0.5f)) * size;
    const float d = (p - centre).squaredNorm();
    const auto key = std::make_tuple(v.x(), v.y(), v.z());
    const auto it = best.find(key);
    if (it == best.end() || d < it->second.first) best[key] = {d, static_cast<std::uint32_t>(i)};
  }
  std::vector<std::uint32_t> kept;
  for (const auto& entry : best) kept.push_back(entry.second.second);
  std::sort(kept.begin(), kept.end());
  return kept;
}

TEST(UniformSampler, KeepsExactlyThePointNearestEachVoxelCentre) {
  for (const double voxel : {0.01, 0.05, 0.1, 0.3}) {
    SCOPED_TRACE(voxel);
    const core::PointCloud cloud = random_cloud(20000, 3);
    UniformSamplingConfig config;
    config.voxel_size_m = voxel;
    const SamplingResult result = UniformSampler(config).sample(cloud);
    const std::vector<std::uint32_t> expected = brute_force_kept(cloud, static_cast<float>(voxel));
    ASSERT_EQ(result.kept, expected);
    EXPECT_EQ(result.points_before, cloud.size());
    EXPECT_EQ(result.points_after, expected.size());
    ASSERT_EQ(result.cloud.size(), expected.size());
    ASSERT_TRUE(result.cloud.has_colors());
    for (std::size_t i = 0; i < expected.size(); ++i) {
      EXPECT_EQ(result.cloud.points[i], cloud.points[expected[i]]);
      EXPECT_EQ(result.cloud.colors[i], cloud.colors[expected[i]]);
    }
    EXPECT_LT(result.points_after, result.points_before);
  }
}

TEST(UniformSampler, TiesGoToTheSmallerIndexAndVoxelsAreAnchoredAtTheOrigin) {
  core::PointCloud cloud;  // values exact in binary, so the tie is exact
  cloud.push_back({0.125f, 0.25f, 0.25f});   // voxel (0,0,0), 0.125 m from its centre
  cloud.push_back({0.375f, 0.25f, 0.25f});   // same voxel, same distance: loses the tie
  cloud.push_back({0.5f, 0.25f, 0.25f});     // on the face x = 0.5: voxel (1,0,0)
  cloud.push_back({-0.25f, 0.25f, 0.25f});   // voxel (-1,0,0), at its centre
  UniformSamplingConfig config;
  config.voxel_size_m = 0.5;
  const SamplingResult result = UniformSampler(config).sample(cloud);
  EXPECT_EQ(result.kept, (std::vector<std::uint32_t>{0, 2, 3}));
  EXPECT_FALSE(result.cloud.has_colors());
}

TEST(UniformSampler, DropsNonFinitePointsAndCanBeDisabled) {
  core::PointCloud cloud = random_cloud(100, 4);
  cloud.points[5].x() = std::numeric_limits<float>::quiet_NaN();
  cloud.points[9].z() = std::numeric_limits<float>::infinity();
  UniformSamplingConfig config;
  const SamplingResult sampled = UniformSampler(config).sample(cloud);
  EXPECT_EQ(sampled.non_finite_dropped, 2u);
  for (const Eigen::Vector3f& p : sampled.cloud.points) EXPECT_TRUE(p.allFinite());

  config.enabled = false;
  const SamplingResult passed = UniformSampler(config).sample(cloud);
  EXPECT_EQ(passed.points_before, 100u);
  EXPECT_EQ(passed.points_after, 98u);
  EXPECT_EQ(passed.non_finite_dropped, 2u);
  EXPECT_EQ(passed.cloud.points[5], cloud.points[6]);

  EXPECT_EQ(UniformSampler(UniformSamplingConfig{}).sample(core::PointCloud{}).points_after, 0u);
}

TEST(UniformSampler, RejectsANonPositiveVoxelSize) {
  UniformSamplingConfig config;
  config.voxel_size_m = 0.0;
  EXPECT_THROW(UniformSampler{config}, InputError);
  config.voxel_size_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(UniformSampler{config}, InputError);
}

}  // namespace
}  // namespace fleetslam::central
