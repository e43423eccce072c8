#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "fleetslam/central/kdtree.hpp"
#include "fleetslam/core/error.hpp"

namespace fleetslam::central {
namespace {

// Random points; half of them on a 5 cm lattice so that many queries meet equal distances.
std::vector<Eigen::Vector3f> random_points(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::uniform_int_distribution<int> lattice(-20, 20);
  std::vector<Eigen::Vector3f> points;
  for (std::size_t i = 0; i < n; ++i) {
    if (i % 2 == 0) {
      points.emplace_back(u(rng), u(rng), u(rng));
    } else {
      points.emplace_back(0.05f * static_cast<float>(lattice(rng)), 0.05f * static_cast<float>(lattice(rng)),
                          0.05f * static_cast<float>(lattice(rng)));
    }
  }
  points.push_back(points[7]);  // an exact duplicate
  return points;
}

// Brute force: every point within max distance, by (distance, index).
std::vector<Neighbour> brute_force(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3f& query,
                                   float max_distance) {
  std::vector<Neighbour> all;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const float d = (points[i] - query).squaredNorm();
    if (d <= max_distance * max_distance) all.push_back(Neighbour{static_cast<std::uint32_t>(i), d});
  }
  std::sort(all.begin(), all.end(), [](const Neighbour& a, const Neighbour& b) {
    return a.distance_sq_m2 < b.distance_sq_m2 || (a.distance_sq_m2 == b.distance_sq_m2 && a.index < b.index);
  });
  return all;
}

class KdTreeOracle : public ::testing::TestWithParam<int> {};  // leaf size

TEST_P(KdTreeOracle, NearestKnnAndRadiusEqualBruteForce) {
  const std::vector<Eigen::Vector3f> points = random_points(3000, 1);
  KdTreeConfig config;
  config.leaf_size = GetParam();
  const KdTree tree(points, config);
  ASSERT_EQ(tree.size(), points.size());
  std::vector<Eigen::Vector3f> queries = random_points(300, 2);
  queries.push_back(points[7]);                           // on a duplicated point: the smaller index wins
  queries.push_back(Eigen::Vector3f(0.025f, 0.0f, 0.0f));  // halfway between lattice points
  std::vector<Neighbour> knn;
  std::vector<Neighbour> radius;
  for (const float max_distance : {0.02f, 0.1f, std::numeric_limits<float>::infinity()}) {
    for (const Eigen::Vector3f& q : queries) {
      const std::vector<Neighbour> expected = brute_force(points, q, max_distance);
      const Neighbour nearest = tree.nearest(q, max_distance);
      if (expected.empty()) {
        EXPECT_FALSE(nearest.found());
      } else {
        EXPECT_EQ(nearest.index, expected[0].index);
        EXPECT_EQ(nearest.distance_sq_m2, expected[0].distance_sq_m2);
      }
      for (const std::size_t k : {std::size_t{1}, std::size_t{7}, std::size_t{20}}) {
        tree.knn(q, k, max_distance, knn);
        ASSERT_EQ(knn.size(), std::min(k, expected.size()));
        for (std::size_t i = 0; i < knn.size(); ++i) {
          EXPECT_EQ(knn[i].index, expected[i].index) << "k " << k << " rank " << i;
          EXPECT_EQ(knn[i].distance_sq_m2, expected[i].distance_sq_m2);
        }
      }
      if (std::isfinite(max_distance)) {
        tree.radius(q, max_distance, radius);
        std::sort(radius.begin(), radius.end(),
                  [](const Neighbour& a, const Neighbour& b) { return a.index < b.index; });
        std::vector<Neighbour> by_index = expected;
        std::sort(by_index.begin(), by_index.end(),
                  [](const Neighbour& a, const Neighbour& b) { return a.index < b.index; });
        ASSERT_EQ(radius.size(), by_index.size());
        for (std::size_t i = 0; i < radius.size(); ++i) EXPECT_EQ(radius[i].index, by_index[i].index);
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(LeafSizes, KdTreeOracle, ::testing::Values(1, 4, 16, 64));

TEST(KdTree, EdgeCases) {
  const KdTree empty(std::vector<Eigen::Vector3f>{});
  EXPECT_TRUE(empty.empty());
  EXPECT_FALSE(empty.nearest(Eigen::Vector3f::Zero(), 1.0f).found());
  std::vector<Neighbour> out = {Neighbour{3, 1.0f}};
  empty.knn(Eigen::Vector3f::Zero(), 3, 1.0f, out);
  EXPECT_TRUE(out.empty());

  const std::vector<Eigen::Vector3f> points = {{0, 0, 0}, {1, 0, 0}, {1, 0, 0}};
  const KdTree tree(points);
  // The bound is inclusive; k larger than the cloud returns every point.
  EXPECT_EQ(tree.nearest({2, 0, 0}, 1.0f).index, 1u);
  EXPECT_FALSE(tree.nearest({2, 0, 0}, 0.999f).found());
  EXPECT_EQ(tree.nearest({0, 0, 0}, 0.0f).index, 0u);
  tree.knn({0.9f, 0, 0}, 10, std::numeric_limits<float>::infinity(), out);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(out[0].index, 1u);
  EXPECT_EQ(out[1].index, 2u);
  EXPECT_EQ(out[2].index, 0u);
  tree.knn({0.9f, 0, 0}, 0, 1.0f, out);
  EXPECT_TRUE(out.empty());
  EXPECT_FALSE(tree.nearest({0, 0, 0}, -1.0f).found());

  KdTreeConfig bad;
  bad.leaf_size = 0;
  EXPECT_THROW(KdTree(points, bad), InputError);
}

}  // namespace
}  // namespace fleetslam::central
