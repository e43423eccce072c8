#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "fleetslam/central/overlap.hpp"
#include "fleetslam/core/error.hpp"
#include "synthetic_clouds.hpp"

namespace fleetslam::central {
namespace {

// Brute-force mutual nearest neighbours within the radius (ties to the smaller index).
Overlap brute_force(const core::PointCloud& a, const core::PointCloud& b, float radius) {
  const auto nearest = [radius](const Eigen::Vector3f& q, const core::PointCloud& cloud) {
    std::uint32_t best = std::numeric_limits<std::uint32_t>::max();
    float best_d = radius * radius;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      if (!cloud.points[i].allFinite()) continue;
      const float d = (cloud.points[i] - q).squaredNorm();
      if (d < best_d || (d == best_d && best == std::numeric_limits<std::uint32_t>::max())) {
        best_d = d;
        best = static_cast<std::uint32_t>(i);
      }
    }
    return best;
  };
  Overlap overlap;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (!a.points[i].allFinite()) continue;
    const std::uint32_t j = nearest(a.points[i], b);
    if (j == std::numeric_limits<std::uint32_t>::max()) continue;
    if (nearest(b.points[j], a) != i) continue;
    overlap.indices_a.push_back(static_cast<std::uint32_t>(i));
    overlap.indices_b.push_back(j);
  }
  return overlap;
}

// A grid of points on a plane z = height, x in [x0, x1], y in [0, 1], every `step` metres.
core::PointCloud plane(float x0, float x1, float height, float step) {
  core::PointCloud cloud;
  const int nx = static_cast<int>(std::lround((x1 - x0) / step));
  const int ny = static_cast<int>(std::lround(1.0f / step));
  for (int i = 0; i <= nx; ++i) {
    for (int j = 0; j <= ny; ++j) {
      cloud.push_back({x0 + step * static_cast<float>(i), step * static_cast<float>(j), height});
    }
  }
  return cloud;
}

TEST(OverlapFinder, TwoOverlappingPlanesPairOnlyWhereTheyOverlap) {
  const core::PointCloud a = plane(0.0f, 2.0f, 0.0f, 0.05f);
  const core::PointCloud b = plane(1.0f, 3.0f, 0.04f, 0.05f);  // 4 cm above, overlapping on x in [1, 2]
  OverlapConfig config;
  config.coarse_radius_m = 0.1;
  const Overlap overlap = OverlapFinder(config).find(a, b);
  ASSERT_FALSE(overlap.empty());
  EXPECT_EQ(overlap.indices_a.size(), overlap.indices_b.size());
  for (std::size_t i = 0; i < overlap.size(); ++i) {
    const Eigen::Vector3f& pa = a.points[overlap.indices_a[i]];
    const Eigen::Vector3f& pb = b.points[overlap.indices_b[i]];
    EXPECT_GE(pa.x(), 1.0f - 1e-4f);
    EXPECT_LE(pb.x(), 2.0f + 1e-4f);
    EXPECT_NEAR((pa - pb).norm(), 0.04f, 1e-4f);  // the grids line up: each pair is vertical
    if (i > 0) {
      EXPECT_LT(overlap.indices_a[i - 1], overlap.indices_a[i]);
    }
  }
  EXPECT_EQ(overlap.size(), 21u * 21u);  // x in [1, 2] and y in [0, 1] at 5 cm
  EXPECT_NEAR(overlap.mean_distance_m, 0.04, 1e-4);
  const core::PointCloud selected = select_points(b, overlap.indices_b);
  ASSERT_EQ(selected.size(), overlap.size());
  EXPECT_EQ(selected.points[0], b.points[overlap.indices_b[0]]);
}

// The two faces of a 12 cm wall: mutual nearest neighbours within the radius, but facing away from each
// other. With normals they do not pair (and are counted); a face seen from the same side does.
TEST(OverlapFinder, OppositeNormalsDoNotPair) {
  core::PointCloud a = plane(0.0f, 1.0f, 0.0f, 0.05f);
  core::PointCloud b = plane(0.0f, 1.0f, 0.12f, 0.05f);
  a.normals.assign(a.size(), Eigen::Vector3f(0, 0, -1));  // seen from below
  b.normals.assign(b.size(), Eigen::Vector3f(0, 0, 1));   // seen from above
  OverlapConfig config;
  config.coarse_radius_m = 0.3;
  const Overlap opposite = OverlapFinder(config).find(a, b);
  EXPECT_TRUE(opposite.empty());
  EXPECT_EQ(opposite.normal_rejected, a.size());

  // Tilted by 100 degrees (within the 120 degree default; normals are noisy at edges): they pair. With
  // a limit of 60 degrees they do not.
  b.normals.assign(b.size(), Eigen::Vector3f(0, std::sin(1.745f), -std::cos(1.745f)));
  const Overlap same = OverlapFinder(config).find(a, b);
  EXPECT_EQ(same.size(), a.size());
  EXPECT_EQ(same.normal_rejected, 0u);
  OverlapConfig strict = config;
  strict.max_normal_angle_deg = 60.0;
  EXPECT_TRUE(OverlapFinder(strict).find(a, b).empty());

  // Unknown (zero) normals, a cloud without normals, or the check off: no pair is refused.
  b.normals.assign(b.size(), Eigen::Vector3f(0, 0, 1));
  b.normals[0] = Eigen::Vector3f::Zero();
  EXPECT_EQ(OverlapFinder(config).find(a, b).size(), 1u);
  core::PointCloud bare = b;
  bare.normals.clear();
  EXPECT_EQ(OverlapFinder(config).find(a, bare).size(), a.size());
  config.max_normal_angle_deg = 180.0;
  EXPECT_EQ(OverlapFinder(config).find(a, b).size(), a.size());
  config.max_normal_angle_deg = 181.0;
  EXPECT_THROW(OverlapFinder{config}, InputError);
}

TEST(OverlapFinder, EqualsBruteForceOnRoomClouds) {
  // Two rooms' worth of noisy points, B's cut shifted and turned a little: exact mutual pairs, ties
  // included (a lattice part makes equal distances common).
  core::PointCloud a = synthetic::room_cloud(2500, 0.0f, 4.0f, 0.01f, 1);
  core::PointCloud b = core::transformed(synthetic::room_cloud(2500, 2.0f, 6.0f, 0.01f, 2),
                                         synthetic::pose(1.0, -2.0, 3.0, Eigen::Vector3d(0.05, 0.02, -0.03)));
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3f lattice(2.0f + 0.1f * static_cast<float>(i % 10), 0.1f * static_cast<float>(i / 10), 0.0f);
    a.push_back(lattice);
    b.push_back(lattice + Eigen::Vector3f(0.05f, 0.0f, 0.0f));  // halfway: two A points at equal distance
  }
  a.points[10].x() = std::numeric_limits<float>::quiet_NaN();
  b.points[20].z() = std::numeric_limits<float>::infinity();
  for (const double radius : {0.05, 0.2, 0.6}) {
    SCOPED_TRACE(radius);
    OverlapConfig config;
    config.coarse_radius_m = radius;
    const Overlap overlap = OverlapFinder(config).find(a, b);
    const Overlap expected = brute_force(a, b, static_cast<float>(radius));
    EXPECT_FALSE(expected.empty());
    EXPECT_EQ(overlap.indices_a, expected.indices_a);
    EXPECT_EQ(overlap.indices_b, expected.indices_b);
  }
}

TEST(OverlapFinder, DisjointOrEmptyCloudsHaveNoOverlap) {
  const core::PointCloud a = plane(0.0f, 1.0f, 0.0f, 0.05f);
  const core::PointCloud far = plane(5.0f, 6.0f, 0.0f, 0.05f);
  const core::PointCloud above = plane(0.0f, 1.0f, 0.5f, 0.05f);  // parallel, farther than the radius
  const OverlapFinder finder(OverlapConfig{});  // 0.3 m
  EXPECT_TRUE(finder.find(a, far).empty());
  EXPECT_TRUE(finder.find(a, above).empty());
  EXPECT_TRUE(finder.find(a, core::PointCloud{}).empty());
  EXPECT_TRUE(finder.find(core::PointCloud{}, a).empty());
  core::PointCloud nan_only;
  nan_only.push_back(Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
  EXPECT_TRUE(finder.find(a, nan_only).empty());
}

TEST(OverlapRegions, HoldEveryPointWithinTheRadiusAndNoneFarFromTheOtherCloud) {
  const core::PointCloud a = synthetic::room_cloud(3000, 0.0f, 4.0f, 0.003f, 3);
  core::PointCloud b = synthetic::room_cloud(3000, 2.0f, 6.0f, 0.003f, 4);
  b.points[0].x() = std::numeric_limits<float>::quiet_NaN();
  const double radius = 0.1;
  const OverlapRegions regions = overlap_regions(a, b, radius);
  const auto distance_to = [](const Eigen::Vector3f& p, const core::PointCloud& cloud) {
    float best = std::numeric_limits<float>::infinity();
    for (const Eigen::Vector3f& q : cloud.points) {
      if (q.allFinite()) best = std::min(best, (p - q).norm());
    }
    return best;
  };
  const auto check = [&](const core::PointCloud& cloud, const core::PointCloud& other,
                         const std::vector<std::uint32_t>& indices) {
    std::vector<char> in(cloud.size(), 0);
    for (std::size_t i = 0; i < indices.size(); ++i) {
      in[indices[i]] = 1;
      if (i > 0) {
        EXPECT_LT(indices[i - 1], indices[i]);
      }
    }
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      if (!cloud.points[i].allFinite()) {
        EXPECT_FALSE(in[i]);
        continue;
      }
      const float d = distance_to(cloud.points[i], other);
      if (static_cast<double>(d) <= radius) {
        EXPECT_TRUE(in[i]) << i << " at " << d;
      }
      if (in[i]) {
        EXPECT_LE(d, 2.0 * std::sqrt(3.0) * radius * 1.01) << i;
      }
    }
  };
  check(a, b, regions.indices_a);
  check(b, a, regions.indices_b);
  EXPECT_GT(regions.indices_a.size(), 500u);
  EXPECT_TRUE(overlap_regions(a, core::PointCloud{}, radius).indices_a.empty());
  EXPECT_THROW(overlap_regions(a, b, 0.0), InputError);
}

TEST(OverlapFinder, RejectsANonPositiveRadius) {
  OverlapConfig config;
  config.coarse_radius_m = 0.0;
  EXPECT_THROW(OverlapFinder{config}, InputError);
}

}  // namespace
}  // namespace fleetslam::central
