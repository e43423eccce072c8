// Map evaluation against known surfaces: exact maps score zero, a known offset is measured exactly
// despite the truth's sampling, a point past a surface's edge is off it, half a map gives half completeness, and outliers count as far points.

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "fleetslam/central/map_evaluation.hpp"

namespace fleetslam::central {
namespace {

// The floor z = 0 over [0, 4] x [0, 3] sampled every `spacing_m`.
std::vector<Eigen::Vector3f> floor_truth(double spacing_m) {
  std::vector<Eigen::Vector3f> out;
  for (double x = 0.0; x <= 4.0 + 1e-9; x += spacing_m) {
    for (double y = 0.0; y <= 3.0 + 1e-9; y += spacing_m) out.emplace_back(static_cast<float>(x), static_cast<float>(y), 0.0f);
  }
  return out;
}

core::PointCloud random_floor_map(std::size_t n, double x_max, double z, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(0.2, x_max - 0.2), uy(0.2, 2.8);
  core::PointCloud map;
  for (std::size_t i = 0; i < n; ++i) {
    map.push_back(Eigen::Vector3f(static_cast<float>(ux(rng)), static_cast<float>(uy(rng)), static_cast<float>(z)));
  }
  return map;
}

TEST(MapEvaluation, OffsetFromThePlaneIsMeasuredNotTheSampleSpacing) {
  const std::vector<Eigen::Vector3f> truth = floor_truth(0.02);
  const MapAccuracy exact = evaluate_map(random_floor_map(5000, 4.0, 0.0, 1), truth);
  EXPECT_LT(exact.mean_m, 1e-6) << "points between samples lie on the plane";
  const MapAccuracy offset = evaluate_map(random_floor_map(5000, 4.0, 0.013, 1), truth);
  EXPECT_NEAR(offset.mean_m, 0.013, 1e-5);
  EXPECT_NEAR(offset.p95_m, 0.013, 1e-5);
  EXPECT_EQ(offset.map_points, 5000u);
  EXPECT_EQ(offset.far_points, 0u);
}

// A point in the plane's extension, 0.3 m past the floor's edge (a phantom wall across a doorway, floor
// points slid past the floor's end), is 0.3 m off the surface, less the patch the nearest samples span;
// the plane alone scored it 0.
TEST(MapEvaluation, APointPastTheSurfacesEdgeIsOffIt) {
  const std::vector<Eigen::Vector3f> truth = floor_truth(0.02);
  core::PointCloud beyond;
  beyond.push_back(Eigen::Vector3f(4.3f, 1.5f, 0.0f));
  const MapAccuracy result = evaluate_map(beyond, truth);
  EXPECT_GT(result.mean_m, 0.25);
  EXPECT_LE(result.mean_m, 0.3 + 1e-6);
  // Just inside the edge and 1 cm above it, the plane still measures the offset.
  core::PointCloud inside;
  inside.push_back(Eigen::Vector3f(3.995f, 1.505f, 0.01f));
  EXPECT_NEAR(evaluate_map(inside, truth).mean_m, 0.01, 1e-5);
}

TEST(MapEvaluation, CompletenessIsTheShareOfSurfaceNearTheMap) {
  const std::vector<Eigen::Vector3f> truth = floor_truth(0.05);
  // A dense map of the half x < 2 m: about half the floor is within 5 cm of it.
  core::PointCloud half;
  for (double x = 0.0; x < 2.0; x += 0.03) {
    for (double y = 0.0; y <= 3.0; y += 0.03) half.push_back(Eigen::Vector3f(static_cast<float>(x), static_cast<float>(y), 0.0f));
  }
  const MapAccuracy result = evaluate_map(half, truth);
  EXPECT_NEAR(result.completeness, 0.5, 0.03);
  EXPECT_EQ(result.truth_points, truth.size());
}

TEST(MapEvaluation, OutliersAndEmptyInputs) {
  const std::vector<Eigen::Vector3f> truth = floor_truth(0.05);
  core::PointCloud map = random_floor_map(99, 4.0, 0.0, 2);
  map.push_back(Eigen::Vector3f(2.0f, 1.0f, 3.0f));  // 3 m above the floor
  map.push_back(Eigen::Vector3f(NAN, 0.0f, 0.0f));
  const MapAccuracy result = evaluate_map(map, truth);
  EXPECT_EQ(result.map_points, 100u);
  EXPECT_EQ(result.far_points, 1u);
  EXPECT_NEAR(result.mean_m, 0.5 / 100.0, 1e-4) << "the outlier counts as max_distance_m";
  // An empty map has no error to measure (not an error of 0, which would pass any accuracy bound) and
  // covers nothing; without truth nothing is measured.
  const MapAccuracy empty = evaluate_map(core::PointCloud{}, truth);
  EXPECT_EQ(empty.map_points, 0u);
  EXPECT_TRUE(std::isnan(empty.mean_m) && std::isnan(empty.median_m) && std::isnan(empty.p95_m));
  EXPECT_EQ(empty.completeness, 0.0);
  const MapAccuracy no_truth = evaluate_map(map, {});
  EXPECT_TRUE(std::isnan(no_truth.mean_m) && std::isnan(no_truth.p95_m) && std::isnan(no_truth.completeness));
}

}  // namespace
}  // namespace fleetslam::central
