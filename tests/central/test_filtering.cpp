#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <random>
#include <vector>

#include "fleetslam/central/filtering.hpp"
#include "fleetslam/core/error.hpp"

namespace fleetslam::central {
namespace {

// Points on the plane z = 0 (2 m x 2 m, about 2 cm apart as in a sampled map) with noise along z.
core::PointCloud noisy_plane(std::size_t n, float noise_m, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 2.0f);
  std::normal_distribution<float> noise(0.0f, noise_m);
  core::PointCloud cloud;
  for (std::size_t i = 0; i < n; ++i) {
    cloud.push_back({u(rng), u(rng), noise(rng)}, {static_cast<std::uint8_t>(i % 256), 7, 9});
  }
  return cloud;
}

double rms_z(const core::PointCloud& cloud) {
  double sum = 0.0;
  for (const Eigen::Vector3f& p : cloud.points) sum += static_cast<double>(p.z()) * static_cast<double>(p.z());
  return std::sqrt(sum / static_cast<double>(cloud.size()));
}

TEST(GaussianFilter, ReducesNoiseOnANoisyPlane) {
  const core::PointCloud cloud = noisy_plane(10000, 0.005f, 1);
  const FilterResult result = GaussianFilter(GaussianFilterConfig{}).filter(cloud);
  ASSERT_EQ(result.points, cloud.size());
  ASSERT_EQ(result.cloud.size(), cloud.size());
  EXPECT_EQ(result.cloud.colors, cloud.colors);  // colours unchanged, order kept
  const double before = rms_z(cloud);
  const double after = rms_z(result.cloud);
  EXPECT_LT(after, 0.6 * before) << "RMS distance to the plane " << before << " -> " << after;
  EXPECT_GT(result.mean_shift_m, 0.0);
  // In-plane positions barely move (the filter smooths, it does not shrink the plane).
  double in_plane = 0.0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    in_plane += static_cast<double>((result.cloud.points[i] - cloud.points[i]).head<2>().norm());
  }
  EXPECT_LT(in_plane / static_cast<double>(cloud.size()), 0.01);
}

TEST(GaussianFilter, MoreNeighboursSmoothMore) {
  const core::PointCloud cloud = noisy_plane(10000, 0.005f, 2);
  GaussianFilterConfig config;
  config.neighbours = 2;
  const double few = rms_z(GaussianFilter(config).filter(cloud).cloud);
  config.neighbours = 12;
  const double many = rms_z(GaussianFilter(config).filter(cloud).cloud);
  EXPECT_LT(many, few);
}

TEST(GaussianFilter, IsTheWeightedMeanOfTheNearestNeighbours) {
  // x0 at the origin; neighbours at 1, 2 and 3 cm along x; one neighbour used.
  core::PointCloud cloud;
  cloud.push_back({0.0f, 0.0f, 0.0f});
  cloud.push_back({0.01f, 0.0f, 0.0f});
  cloud.push_back({0.03f, 0.0f, 0.0f});
  cloud.push_back({5.0f, 5.0f, 5.0f});  // isolated: stays
  GaussianFilterConfig config;
  config.neighbours = 1;
  config.sigma_m = 0.01;
  config.radius_m = 0.05;
  const FilterResult result = GaussianFilter(config).filter(cloud);
  const double w = std::exp(-0.5);  // 1 cm at sigma 1 cm
  EXPECT_NEAR(result.cloud.points[0].x(), 0.01 * w / (1.0 + w), 1e-7);
  EXPECT_NEAR(result.cloud.points[1].x(), 0.01 / (1.0 + w), 1e-7);  // nearest of point 1 is point 0
  const double w2 = std::exp(-2.0);  // point 2's nearest is point 1, 2 cm away
  EXPECT_NEAR(result.cloud.points[2].x(), (0.03 + 0.01 * w2) / (1.0 + w2), 1e-7);
  EXPECT_EQ(result.cloud.points[3], Eigen::Vector3f(5.0f, 5.0f, 5.0f));
  EXPECT_EQ(result.isolated, 1u);
}

TEST(GaussianFilter, IsDeterministicAndIndependentOfPointOrder) {
  const core::PointCloud cloud = noisy_plane(5000, 0.005f, 3);
  const GaussianFilter filter(GaussianFilterConfig{});
  const FilterResult first = filter.filter(cloud);
  const FilterResult second = filter.filter(cloud);
  EXPECT_EQ(first.cloud.points, second.cloud.points);  // bit for bit

  std::vector<std::size_t> order(cloud.size());
  std::iota(order.begin(), order.end(), 0);
  std::mt19937 rng(4);
  std::shuffle(order.begin(), order.end(), rng);
  core::PointCloud shuffled;
  for (std::size_t i : order) shuffled.push_back(cloud.points[i], cloud.colors[i]);
  const FilterResult permuted = filter.filter(shuffled);
  // Equal-distance ties could pick other neighbours after a permutation; random floats have none, so
  // every point ends where it did (up to the summation order of the weights).
  for (std::size_t j = 0; j < order.size(); ++j) {
    EXPECT_LT((permuted.cloud.points[j] - first.cloud.points[order[j]]).norm(), 1e-6f) << j;
  }
}

TEST(GaussianFilter, DropsNonFinitePointsAndCanBeDisabled) {
  core::PointCloud cloud = noisy_plane(200, 0.005f, 5);
  cloud.points[3].y() = std::numeric_limits<float>::quiet_NaN();
  const FilterResult result = GaussianFilter(GaussianFilterConfig{}).filter(cloud);
  EXPECT_EQ(result.non_finite_dropped, 1u);
  EXPECT_EQ(result.points, 199u);
  for (const Eigen::Vector3f& p : result.cloud.points) EXPECT_TRUE(p.allFinite());

  GaussianFilterConfig off;
  off.enabled = false;
  const FilterResult passed = GaussianFilter(off).filter(cloud);
  EXPECT_EQ(passed.points, 199u);
  EXPECT_EQ(passed.cloud.points[3], cloud.points[4]);
  EXPECT_TRUE(GaussianFilter(GaussianFilterConfig{}).filter(core::PointCloud{}).cloud.empty());
}

TEST(GaussianFilter, RejectsBadSettings) {
  GaussianFilterConfig config;
  config.neighbours = 0;
  EXPECT_THROW(GaussianFilter{config}, InputError);
  config = GaussianFilterConfig{};
  config.sigma_m = -1.0;
  EXPECT_THROW(GaussianFilter{config}, InputError);
  config = GaussianFilterConfig{};
  config.radius_m = 0.0;
  EXPECT_THROW(GaussianFilter{config}, InputError);
}

}  // namespace
}  // namespace fleetslam::central
