// The experiments' measured values on known input: the paper's trimmed mean over runs, the median and
// mean, and the ground-truth check of a matcher's matches (precision and recall of Table 1), each
// against numbers worked out by hand.

#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "fleetslam/core/camera.hpp"
#include "fleetslam/experiments/matchers.hpp"
#include "fleetslam/experiments/table.hpp"

namespace fleetslam::experiments {
namespace {

TEST(ExperimentMeasures, TrimmedMeanDropsOneLargestAndOneSmallest) {
  EXPECT_TRUE(std::isnan(trimmed_mean({})));
  EXPECT_DOUBLE_EQ(trimmed_mean({4.0}), 4.0);
  EXPECT_DOUBLE_EQ(trimmed_mean({1.0, 3.0}), 2.0);          // fewer than three: the plain mean
  EXPECT_DOUBLE_EQ(trimmed_mean({5.0, 1.0, 3.0}), 3.0);     // the middle one
  EXPECT_DOUBLE_EQ(trimmed_mean({100.0, 1.0, 2.0, 3.0}), 2.5);
  EXPECT_DOUBLE_EQ(trimmed_mean({1.0, 5.0, 5.0}), 5.0);     // one of the two largest is dropped, not both
  EXPECT_DOUBLE_EQ(trimmed_mean({2.0, 2.0, 2.0, 2.0}), 2.0);
}

TEST(ExperimentMeasures, MedianAndMean) {
  EXPECT_TRUE(std::isnan(median_of({})));
  EXPECT_TRUE(std::isnan(mean_of({})));
  EXPECT_DOUBLE_EQ(median_of({3.0, 1.0, 2.0}), 2.0);
  EXPECT_DOUBLE_EQ(median_of({4.0, 1.0, 3.0, 2.0}), 2.5);  // numpy's: the mean of the middle two
  EXPECT_DOUBLE_EQ(mean_of({1.0, 2.0, 6.0}), 3.0);
}

// A at the origin, B 10 cm to its right (T_a_b_true a pure translation), both 640x480 with f = 500 px.
// Five known points at 2 to 4 m; each frame's features sit at the points' true projections, with one A
// feature 1.5 px off its point's projection (within the 3 px check) and one far from everything.
class EvaluateMatches : public ::testing::Test {
 protected:
  void SetUp() override {
    const core::PinholeCamera camera(640, 480, 500.0, 500.0, 320.0, 240.0);
    pair.a.camera = camera;
    pair.b.camera = camera;
    pair.T_a_b_true = Eigen::Isometry3d(Eigen::Translation3d(0.1, 0.0, 0.0));
    const std::vector<Eigen::Vector3d> points_a{{-0.5, -0.2, 2.0}, {0.3, 0.1, 2.5}, {0.0, 0.4, 3.0},
                                                {0.6, -0.3, 4.0}, {-0.4, 0.3, 2.2}};
    const Eigen::Isometry3d T_b_a = pair.T_a_b_true.inverse();
    for (std::size_t k = 0; k < points_a.size(); ++k) {
      pair.a.uv.push_back(*camera.project(points_a[k]));
      pair.b.uv.push_back(*camera.project(T_b_a * points_a[k]));
    }
    pair.a.uv[1] += Eigen::Vector2d(1.5, 0.0);     // still within 3 px of its point's projection
    pair.a.uv.push_back({600.0, 50.0});             // a5: no point near it
    pair.b.uv.push_back({20.0, 460.0});             // b5: likewise
    // Depth: B has it for b0..b2 (b3, b4, b5 none); A only for a3.
    pair.p_b.assign(pair.b.uv.size(), std::nullopt);
    for (std::size_t k = 0; k < 3; ++k) pair.p_b[k] = T_b_a * points_a[k];
    pair.p_a.assign(pair.a.uv.size(), std::nullopt);
    pair.p_a[3] = points_a[3];
  }
  MatchPair pair;
};

TEST_F(EvaluateMatches, CountsAgainstTheTruePoseAndDepth) {
  const std::vector<slam::Match> matches{
      {0, 0, 10},  // correct, checked with B's depth; b0 has a true partner
      {1, 1, 12},  // correct (1.5 px off), checked with B's depth
      {3, 2, 20},  // wrong: b2's point projects onto a2, not a3
      {3, 3, 15},  // b3 has no depth: checked with A's depth of a3 moved into B, correct
      {5, 5, 30},  // neither side has depth: unverifiable
  };
  const MatchQuality q = evaluate_matches(pair, matches, 3.0);
  EXPECT_EQ(q.matches, 5);
  EXPECT_EQ(q.verifiable, 4);
  EXPECT_EQ(q.correct, 3);
  EXPECT_EQ(q.with_partner, 3);           // b0, b1, b2: depth, and an A feature at their true projection
  EXPECT_EQ(q.correct_with_partner, 2);   // b0 and b1 (b3's match is correct but checked with A's depth)
  EXPECT_DOUBLE_EQ(q.precision(), 0.75);
  EXPECT_DOUBLE_EQ(q.recall(), 2.0 / 3.0);
  // A tighter check: a1 is 1.5 px off, so it is neither correct nor b1's partner within 1 px.
  const MatchQuality tight = evaluate_matches(pair, matches, 1.0);
  EXPECT_EQ(tight.correct, 2);
  EXPECT_EQ(tight.with_partner, 2);
  EXPECT_EQ(tight.correct_with_partner, 1);
  // Sums over pairs, and no matches at all: precision and recall are not numbers where nothing counts.
  MatchQuality sum = q;
  sum += tight;
  EXPECT_EQ(sum.verifiable, 8);
  EXPECT_EQ(sum.correct, 5);
  const MatchQuality none = evaluate_matches(pair, {}, 3.0);
  EXPECT_EQ(none.matches, 0);
  EXPECT_TRUE(std::isnan(none.precision()));
  EXPECT_DOUBLE_EQ(none.recall(), 0.0);  // the partners are there, none matched
}

// A B point that lands behind A's camera cannot be correct; it is still verifiable.
TEST_F(EvaluateMatches, APointBehindTheOtherCameraIsWrong) {
  pair.T_a_b_true = Eigen::Isometry3d(Eigen::Translation3d(0.0, 0.0, -10.0));  // A 10 m in front of B
  const MatchQuality q = evaluate_matches(pair, {{0, 0, 10}}, 3.0);
  EXPECT_EQ(q.verifiable, 1);
  EXPECT_EQ(q.correct, 0);
  EXPECT_EQ(q.with_partner, 0);
}

}  // namespace
}  // namespace fleetslam::experiments
