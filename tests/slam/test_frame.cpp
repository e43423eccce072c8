// Frame basics: pyramid values, the feature grid against a brute-force oracle on random points,
// unprojection, finalize() and the undistorted image bounds.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "fleetslam/core/camera.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/slam/frame.hpp"

namespace fleetslam::slam {
namespace {

TEST(ScalePyramid, ValuesFollowTheScaleFactor) {
  const ScalePyramid p = ScalePyramid::make(8, 1.2);
  EXPECT_EQ(p.levels, 8);
  EXPECT_DOUBLE_EQ(p.scale_factor, 1.2);
  ASSERT_EQ(p.scale.size(), 8u);
  ASSERT_EQ(p.inv_sigma2.size(), 8u);
  EXPECT_DOUBLE_EQ(p.scale[0], 1.0);
  EXPECT_NEAR(p.scale[3], 1.728, 1e-12);
  EXPECT_NEAR(p.scale[7], std::pow(1.2, 7), 1e-12);
  for (std::size_t l = 0; l < 8; ++l) {
    EXPECT_NEAR(p.inv_scale[l] * p.scale[l], 1.0, 1e-15);
    EXPECT_NEAR(p.sigma2[l], p.scale[l] * p.scale[l], 1e-12);
    EXPECT_NEAR(p.inv_sigma2[l] * p.sigma2[l], 1.0, 1e-15);
  }
  EXPECT_EQ(ScalePyramid::make(1, 2.0).scale.size(), 1u);
  EXPECT_THROW(ScalePyramid::make(0, 1.2), std::invalid_argument);
  EXPECT_THROW(ScalePyramid::make(4, 0.9), std::invalid_argument);
  EXPECT_THROW(ScalePyramid::make(4, std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
}

// Brute force: every feature inside the grid's area, at distance <= r, within the level bounds.
std::vector<int> oracle(const std::vector<Eigen::Vector2d>& uv, const std::vector<int>& level, const ImageBounds& b,
                        double u, double v, double r, int min_level, int max_level) {
  std::vector<int> found;
  for (std::size_t i = 0; i < uv.size(); ++i) {
    const Eigen::Vector2d& p = uv[i];
    if (!(p.x() >= b.min_u && p.x() < b.max_u && p.y() >= b.min_v && p.y() < b.max_v)) continue;
    if (min_level >= 0 && level[i] < min_level) continue;
    if (max_level >= 0 && level[i] > max_level) continue;
    if ((p - Eigen::Vector2d(u, v)).squaredNorm() <= r * r) found.push_back(static_cast<int>(i));
  }
  return found;
}

TEST(FeatureGrid, RadiusQueriesMatchBruteForce) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u_dist(-30.0, 670.0), v_dist(-30.0, 510.0), r_dist(0.0, 60.0);
  std::uniform_int_distribution<int> level_dist(0, 7), bound_dist(-1, 7);
  const ImageBounds bounds{-12.3, 651.7, -8.1, 488.9};
  std::vector<Eigen::Vector2d> uv;
  std::vector<int> level;
  for (int i = 0; i < 3000; ++i) {
    uv.emplace_back(u_dist(rng), v_dist(rng));
    level.push_back(level_dist(rng));
  }
  // Points on cell edges, the exclusive upper bounds and non-finite ones.
  uv.emplace_back(bounds.max_u, 100.0);
  uv.emplace_back(bounds.min_u, bounds.min_v);
  uv.emplace_back(std::nan(""), 100.0);
  uv.emplace_back(100.0, std::numeric_limits<double>::infinity());
  for (int i = 0; i < 4; ++i) level.push_back(0);
  const FeatureGrid grid(uv, level, bounds);
  for (int q = 0; q < 2000; ++q) {
    const double u = u_dist(rng), v = v_dist(rng), r = q % 50 == 0 ? 0.0 : r_dist(rng);
    const int min_level = q % 3 == 0 ? -1 : bound_dist(rng);
    const int max_level = q % 4 == 0 ? -1 : bound_dist(rng);
    ASSERT_EQ(grid.features_in_area(u, v, r, min_level, max_level),
              oracle(uv, level, bounds, u, v, r, min_level, max_level))
        << "query " << q << " at (" << u << ", " << v << ") r " << r;
  }
  // Radius exactly to a feature counts it; a huge radius returns every indexed feature.
  const std::vector<Eigen::Vector2d> one{{10.0, 10.0}};
  const FeatureGrid small(one, {}, bounds);
  EXPECT_EQ(small.features_in_area(13.0, 14.0, 5.0), std::vector<int>{0});
  EXPECT_TRUE(small.features_in_area(13.0, 14.0, 4.999).empty());
  EXPECT_EQ(grid.features_in_area(320.0, 240.0, 1e6).size(), oracle(uv, level, bounds, 0, 0, 1e9, -1, -1).size());
  EXPECT_TRUE(grid.features_in_area(std::nan(""), 10.0, 5.0).empty());
  EXPECT_TRUE(grid.features_in_area(10.0, 10.0, -1.0).empty());
  EXPECT_TRUE(FeatureGrid().features_in_area(10.0, 10.0, 5.0).empty());
}

// Queries whose square ends exactly on a feature that lies on a cell edge (or one ulp off it), on grids
// whose cell sizes have no exact reciprocal: the cell range (computed with the reciprocal) must still
// reach every cell the constructor put such a feature in.
TEST(FeatureGrid, QueriesEndingOnCellEdgesFindTheFeaturesThere) {
  const std::vector<ImageBounds> all_bounds{{-12.3, 651.7, -8.1, 488.9}, {0.0, 640.0 / 3.0, 0.0, 1.0 / 7.0},
                                            {-1e-3, 1e4 / 3.0, 100.1, 100.1 + 480.0 / 49.0}};
  for (const ImageBounds& bounds : all_bounds) {
    const int cols = 37, rows = 23;
    const double cell_w = (bounds.max_u - bounds.min_u) / cols;
    const double cell_h = (bounds.max_v - bounds.min_v) / rows;
    std::vector<Eigen::Vector2d> uv;
    for (int x = 0; x < cols; ++x) {
      for (int y = 0; y < rows; y += 5) {
        const double u = bounds.min_u + cell_w * x;
        const double v = bounds.min_v + cell_h * y;
        uv.emplace_back(u, v);
        uv.emplace_back(std::nextafter(u, -1e300), std::nextafter(v, 1e300));
        uv.emplace_back(std::nextafter(u, 1e300), std::nextafter(v, -1e300));
      }
    }
    const std::vector<int> level(uv.size(), 0);
    const FeatureGrid grid(uv, level, bounds, cols, rows);
    int found = 0;
    for (const Eigen::Vector2d& f : uv) {
      for (const double r : {0.0, 0.25 * cell_w, cell_w, 2.5 * cell_w}) {
        // The feature on the query square's left, right, top and bottom edge.
        for (const Eigen::Vector2d& q : {Eigen::Vector2d(f.x() + r, f.y()), Eigen::Vector2d(f.x() - r, f.y()),
                                         Eigen::Vector2d(f.x(), f.y() + r), Eigen::Vector2d(f.x(), f.y() - r)}) {
          const std::vector<int> expected = oracle(uv, level, bounds, q.x(), q.y(), r, -1, -1);
          ASSERT_EQ(grid.features_in_area(q.x(), q.y(), r), expected)
              << "query (" << q.x() << ", " << q.y() << ") r " << r;
          found += static_cast<int>(expected.size());
        }
      }
    }
    EXPECT_GT(found, static_cast<int>(uv.size()));  // the queries do find features, edge ones included
  }
}

// The appending overload: the same features (in grid order), appended after what the vector held, one
// vector reused across queries.
TEST(FeatureGrid, AppendingQueriesMatchBruteForceAndKeepTheVector) {
  std::mt19937 rng(43);
  std::uniform_real_distribution<double> u_dist(-30.0, 670.0), v_dist(-30.0, 510.0), r_dist(0.0, 80.0);
  std::uniform_int_distribution<int> level_dist(0, 7), bound_dist(-1, 7), prefix_dist(0, 3);
  const ImageBounds bounds = ImageBounds::of_image(640, 480);
  std::vector<Eigen::Vector2d> uv;
  std::vector<int> level;
  for (int i = 0; i < 2000; ++i) {
    uv.emplace_back(u_dist(rng), v_dist(rng));
    level.push_back(level_dist(rng));
  }
  for (int i = 0; i < 50; ++i) {  // duplicates: several features in one spot
    uv.push_back(uv[static_cast<std::size_t>(i)]);
    level.push_back(level[static_cast<std::size_t>(i)]);
  }
  const FeatureGrid grid(uv, level, bounds);
  std::vector<int> found;
  for (int q = 0; q < 3000; ++q) {
    const double u = u_dist(rng), v = v_dist(rng), r = q % 50 == 0 ? 0.0 : r_dist(rng);
    const int min_level = q % 3 == 0 ? -1 : bound_dist(rng);
    const int max_level = q % 4 == 0 ? -1 : bound_dist(rng);
    found.assign(static_cast<std::size_t>(prefix_dist(rng)), -7);  // earlier contents stay
    const std::size_t prefix = found.size();
    const std::size_t appended = grid.features_in_area(u, v, r, min_level, max_level, found);
    ASSERT_EQ(found.size(), prefix + appended);
    EXPECT_TRUE(std::all_of(found.begin(), found.begin() + static_cast<long>(prefix), [](int i) { return i == -7; }));
    std::vector<int> tail(found.begin() + static_cast<long>(prefix), found.end());
    std::sort(tail.begin(), tail.end());
    ASSERT_EQ(tail, oracle(uv, level, bounds, u, v, r, min_level, max_level)) << "query " << q;
    ASSERT_EQ(tail, grid.features_in_area(u, v, r, min_level, max_level));
  }
  found.assign(2, 5);
  EXPECT_EQ(grid.features_in_area(std::nan(""), 10.0, 5.0, -1, -1, found), 0u);
  EXPECT_EQ(grid.features_in_area(10.0, 10.0, -1.0, 0, 3, found), 0u);
  EXPECT_EQ(FeatureGrid().features_in_area(10.0, 10.0, 5.0, -1, -1, found), 0u);
  EXPECT_EQ(grid.features_in_area(-500.0, 10.0, 20.0, -1, -1, found), 0u);  // off the grid
  EXPECT_EQ(found, std::vector<int>(2, 5));
  // Level bounds need a grid built with levels; levels are one per feature or none.
  const FeatureGrid no_levels(uv, {}, bounds);
  EXPECT_THROW(no_levels.features_in_area(320.0, 240.0, 50.0, 0, 2, found), InvariantError);
  EXPECT_EQ(no_levels.features_in_area(320.0, 240.0, 50.0), oracle(uv, level, bounds, 320.0, 240.0, 50.0, -1, -1));
  const std::vector<int> fewer_levels(level.begin(), level.begin() + 10);
  EXPECT_THROW(FeatureGrid(uv, fewer_levels, bounds), InvariantError);
  EXPECT_EQ(grid.features(), uv.size());
  // scan_area reads the vectors the grid was built from: others are caught.
  const std::vector<Eigen::Vector2d> fewer(uv.begin(), uv.begin() + 10);
  EXPECT_THROW(grid.scan_area(fewer, level, 320.0, 240.0, 50.0, -1, -1, [](int, bool) {}), InvariantError);
  EXPECT_THROW(grid.scan_area(uv, fewer_levels, 320.0, 240.0, 50.0, -1, -1, [](int, bool) {}), InvariantError);
  EXPECT_THROW(no_levels.scan_area(uv, level, 320.0, 240.0, 50.0, -1, -1, [](int, bool) {}), InvariantError);
}

// scan_area: every feature of the cells around the query once, flagged in-area exactly for the features
// features_in_area returns; a superset of them within the query square's cells. Grids of several shapes
// (slices longer and rows more than the scan gathers at once) and crowded spots.
TEST(FeatureGrid, ScanFlagsExactlyTheFeaturesInTheArea) {
  std::mt19937 rng(44);
  std::uniform_real_distribution<double> u_dist(-30.0, 670.0), v_dist(-30.0, 510.0), r_dist(0.0, 120.0);
  std::uniform_real_distribution<double> near(-3.0, 3.0);
  std::uniform_int_distribution<int> level_dist(0, 7), bound_dist(-1, 7);
  const ImageBounds bounds = ImageBounds::of_image(640, 480);
  std::vector<Eigen::Vector2d> uv;
  std::vector<int> level;
  for (int i = 0; i < 2500; ++i) {
    uv.emplace_back(u_dist(rng), v_dist(rng));
    level.push_back(level_dist(rng));
  }
  for (int i = 0; i < 300; ++i) {  // a crowded spot: cells with dozens of features
    uv.emplace_back(200.0 + near(rng), 150.0 + near(rng));
    level.push_back(level_dist(rng));
  }
  for (const auto& [cols, rows] : {std::pair<int, int>{64, 48}, {8, 6}, {200, 150}, {1, 1}}) {
    SCOPED_TRACE(std::to_string(cols) + "x" + std::to_string(rows));
    const FeatureGrid grid(uv, level, bounds, cols, rows);
    for (int q = 0; q < 1500; ++q) {
      const bool crowded = q % 5 == 0;
      const double u = crowded ? 200.0 + near(rng) : u_dist(rng);
      const double v = crowded ? 150.0 + near(rng) : v_dist(rng);
      const double r = q % 50 == 0 ? 0.0 : r_dist(rng);
      const int min_level = q % 3 == 0 ? -1 : bound_dist(rng);
      const int max_level = q % 4 == 0 ? -1 : bound_dist(rng);
      std::vector<int> visited, in_area, offered;
      grid.scan_area(uv, level, u, v, r, min_level, max_level, [&](int i, bool inside) {
        visited.push_back(i);
        if (inside) in_area.push_back(i);
      });
      // visit_area offers exactly the in-area ones, in the same (grid) order.
      grid.visit_area(u, v, r, min_level, max_level, [&](int i) { offered.push_back(i); });
      ASSERT_EQ(offered, in_area) << "query " << q;
      std::sort(in_area.begin(), in_area.end());
      ASSERT_EQ(in_area, oracle(uv, level, bounds, u, v, r, min_level, max_level)) << "query " << q;
      std::sort(visited.begin(), visited.end());
      ASSERT_TRUE(std::adjacent_find(visited.begin(), visited.end()) == visited.end()) << "visited twice, query " << q;
    }
    std::size_t visits = 0;
    grid.scan_area(uv, level, std::nan(""), 10.0, 5.0, -1, -1, [&](int, bool) { ++visits; });
    grid.scan_area(uv, level, 10.0, 10.0, -1.0, -1, -1, [&](int, bool) { ++visits; });
    grid.scan_area(uv, level, 10.0, 10.0, 5.0, 3, 2, [&](int, bool inside) { visits += inside ? 1 : 0; });
    grid.visit_area(std::nan(""), 10.0, 5.0, -1, -1, [&](int) { ++visits; });
    grid.visit_area(10.0, 10.0, -1.0, -1, -1, [&](int) { ++visits; });
    grid.visit_area(200.0, 150.0, 50.0, 3, 2, [&](int) { ++visits; });  // empty level window
    EXPECT_EQ(visits, 0u);
  }
}

// The four-entry area test visit_area filters with: the SSE2 version (where built) agrees with the
// portable one bit for bit, on random entries, boundary distances (exactly r) and level edges.
TEST(FeatureGrid, FourWideAreaTestAgreesWithThePortableOne) {
  std::mt19937 rng(45);
  std::uniform_real_distribution<double> coordinate(-20.0, 20.0), radius(0.0, 15.0);
  std::uniform_int_distribution<int> level_dist(0, 7), bound_dist(-1, 7);
  int inside = 0;
  for (int t = 0; t < 20000; ++t) {
    double u[4], v[4];
    int level[4];
    const double qu = coordinate(rng), qv = coordinate(rng), r = radius(rng);
    for (int k = 0; k < 4; ++k) {
      u[k] = coordinate(rng);
      v[k] = coordinate(rng);
      level[k] = level_dist(rng);
    }
    if (t % 7 == 0) {  // on the circle: exactly at distance r
      u[t % 4] = qu + r;
      v[t % 4] = qv;
    }
    const int min_level = bound_dist(rng), max_level = bound_dist(rng);
    const int lowest = min_level >= 0 ? min_level : std::numeric_limits<int>::min();
    const int highest = max_level >= 0 ? max_level : std::numeric_limits<int>::max();
    const int portable = detail::in_area_mask4_portable(u, v, level, qu, qv, r * r, lowest, highest);
    int expected = 0;
    for (int k = 0; k < 4; ++k) {
      const bool in = (u[k] - qu) * (u[k] - qu) + (v[k] - qv) * (v[k] - qv) <= r * r && level[k] >= lowest &&
                      level[k] <= highest;
      expected |= static_cast<int>(in) << k;
    }
    ASSERT_EQ(portable, expected) << "case " << t;
#if defined(__SSE2__)
    ASSERT_EQ(detail::in_area_mask4_sse2(u, v, level, qu, qv, r * r, lowest, highest), portable) << "case " << t;
#endif
    inside += __builtin_popcount(static_cast<unsigned>(portable));
  }
  EXPECT_GT(inside, 1000);  // the cases do put entries inside
}

Frame frame_with(const std::vector<Eigen::Vector2d>& uv, const std::vector<double>& depth) {
  Frame frame;
  frame.camera = core::PinholeCamera(640, 480, 500.0, 490.0, 320.0, 240.0);
  frame.pyramid = ScalePyramid::make(8, 1.2);
  frame.uv = uv;
  for (const Eigen::Vector2d& p : uv) {
    frame.keypoints.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()), 31.0f);
    frame.level.push_back(0);
  }
  frame.descriptors = cv::Mat::zeros(static_cast<int>(uv.size()), 32, CV_8UC1);
  frame.depth_m = depth;
  return frame;
}

TEST(Frame, UnprojectGivesTheCameraPointOfTheDepth) {
  Frame frame = frame_with({{100.0, 50.0}, {320.0, 240.0}, {600.0, 400.0}}, {2.0, -1.0, 0.5});
  frame.finalize();
  const auto p = frame.unproject(0);
  ASSERT_TRUE(p.has_value());
  EXPECT_DOUBLE_EQ(p->z(), 2.0);
  const auto uv = frame.camera.project(*p);
  ASSERT_TRUE(uv.has_value());
  EXPECT_NEAR(uv->x(), 100.0, 1e-9);
  EXPECT_NEAR(uv->y(), 50.0, 1e-9);
  EXPECT_FALSE(frame.unproject(1).has_value());
  EXPECT_TRUE(frame.has_depth(2));
  EXPECT_NEAR(frame.unproject(2)->x(), (600.0 - 320.0) / 500.0 * 0.5, 1e-12);
  EXPECT_THROW(frame.unproject(3), InvariantError);
}

TEST(Frame, FinalizeFillsPerFeatureStateAndTheGrid) {
  Frame frame = frame_with({{10.0, 10.0}, {639.0, 479.0}, {320.0, 240.0}}, {});
  frame.map_points = {7};
  frame.finalize();
  EXPECT_EQ(frame.depth_m, std::vector<double>(3, -1.0));
  EXPECT_EQ(frame.u_right, std::vector<double>(3, -1.0));
  EXPECT_EQ(frame.map_points, std::vector<MapPointId>(3, kNoMapPoint));
  EXPECT_EQ(frame.outlier, std::vector<bool>(3, false));
  EXPECT_FALSE(frame.grid.empty());
  EXPECT_EQ(frame.grid.features_in_area(639.0, 479.0, 1.0), std::vector<int>{1});
  EXPECT_EQ(frame.grid.features_in_area(320.0, 240.0, 400.0).size(), 3u);

  Frame broken = frame_with({{10.0, 10.0}}, {});
  broken.level.clear();
  EXPECT_THROW(broken.finalize(), InvariantError);
  Frame empty;
  empty.finalize();
  EXPECT_EQ(empty.size(), 0u);
  EXPECT_TRUE(empty.grid.features_in_area(0.0, 0.0, 10.0).empty());
  EXPECT_TRUE(empty.grid.features_in_area(0.0, 0.0, 10.0, 0, 2).empty());  // level bounds on no features
}

TEST(Frame, UndistortedBoundsHoldEveryUndistortedPixel) {
  const core::PinholeCamera barrel(752, 480, 458.654, 457.296, 367.215, 248.375,
                                   core::Distortion{-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0.0});
  const core::PinholeCamera pincushion(640, 480, 517.3, 516.5, 318.6, 255.3, core::Distortion{0.2624, -0.9531, -0.0054, 0.0026, 1.1633});
  for (const core::PinholeCamera& raw : {barrel, pincushion}) {
    const ImageBounds b = undistorted_image_bounds(raw);
    std::vector<Eigen::Vector2d> pixels;
    for (int v = 0; v < raw.height(); v += 7) {
      for (int u = 0; u < raw.width(); u += 7) pixels.emplace_back(u, v);
    }
    for (int v = 0; v < raw.height(); ++v) pixels.emplace_back(raw.width() - 1, v);
    double min_u = 1e9, max_u = -1e9;
    for (const Eigen::Vector2d& p : raw.undistort_points(pixels)) {
      ASSERT_TRUE(p.allFinite());
      EXPECT_GE(p.x(), b.min_u);
      EXPECT_LT(p.x(), b.max_u);
      EXPECT_GE(p.y(), b.min_v);
      EXPECT_LT(p.y(), b.max_v);
      min_u = std::min(min_u, p.x());
      max_u = std::max(max_u, p.x());
    }
    // Tight: the box is the border's extent, not a generous margin.
    EXPECT_LT(min_u - b.min_u, 3.0);
    EXPECT_LT(b.max_u - max_u, 3.0);
  }
  const ImageBounds plain = undistorted_image_bounds(core::PinholeCamera(640, 480, 500.0, 500.0, 320.0, 240.0));
  EXPECT_DOUBLE_EQ(plain.min_u, -0.5);
  EXPECT_DOUBLE_EQ(plain.max_u, 639.5);
  EXPECT_DOUBLE_EQ(plain.max_v, 479.5);
}

}  // namespace
}  // namespace fleetslam::slam
