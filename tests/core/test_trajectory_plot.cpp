#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "fleetslam/core/trajectory_plot.hpp"

namespace fleetslam::core {
namespace {

Trajectory line_of_poses(std::size_t n, TimeNs period_ns, double step_m) {
  Trajectory t;
  for (std::size_t i = 0; i < n; ++i) {
    StampedPose p;
    p.t_ns = static_cast<TimeNs>(i) * period_ns;
    p.T_world_body.translation() = Eigen::Vector3d(step_m * static_cast<double>(i), 0.5 * step_m * static_cast<double>(i * i % 7), 0.0);
    t.push_back(p);
  }
  return t;
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto pos = text.find(what); pos != std::string::npos; pos = text.find(what, pos + 1)) ++n;
  return n;
}

TEST(TrajectoryPlot, DrawsBothTrajectoriesTheErrorCurveAndEscapesLabels) {
  const Trajectory gt = line_of_poses(50, 100'000'000, 0.2);
  const AteResult ate = compute_ate(gt, gt, associate_by_index(gt, gt), AlignmentMode::kSe3);
  TrajectoryPlotLabels labels;
  labels.title = "a<b & \"c\"";
  const std::string svg = trajectory_svg(gt, gt, ate, labels);
  EXPECT_EQ(svg.rfind("<?xml", 0), 0u);
  EXPECT_EQ(count(svg, "<svg "), 1u);
  EXPECT_EQ(count(svg, "</svg>"), 1u);
  EXPECT_EQ(count(svg, "<path "), 3u);
  EXPECT_NE(svg.find("a&lt;b &amp; &quot;c&quot;"), std::string::npos);
  EXPECT_NE(svg.find("x [m]"), std::string::npos);  // x and y are the widest axes here
  EXPECT_NE(svg.find("y [m]"), std::string::npos);
  EXPECT_NE(svg.find("time since the first pair [s]"), std::string::npos);
  EXPECT_EQ(svg.find("nan"), std::string::npos);
  EXPECT_EQ(svg.find(">-0<"), std::string::npos);
}

TEST(TrajectoryPlot, GapsBreakTheLines) {
  Trajectory gt = line_of_poses(40, 10'000'000, 0.1);
  for (std::size_t i = 20; i < gt.size(); ++i) gt[i].t_ns += 5'000'000'000;  // a 5 s dropout
  const AteResult ate = compute_ate(gt, gt, associate_by_index(gt, gt), AlignmentMode::kNone);
  const std::string svg = trajectory_svg(gt, gt, ate, {});
  EXPECT_EQ(count(svg, "d=\"M"), 3u);  // three paths ...
  EXPECT_EQ(count(svg, " M"), 3u);     // ... each broken once
}

TEST(TrajectoryPlot, SurvivesTinyAndEmptyInputs) {
  const Trajectory one = line_of_poses(1, 1, 0.0);
  const AteResult ate = compute_ate(one, one, associate_by_index(one, one), AlignmentMode::kNone);
  TrajectoryPlotLabels labels;
  labels.errors_over_time = false;
  for (const std::string& svg : {trajectory_svg(one, one, ate, labels), trajectory_svg({}, {}, AteResult{}, labels)}) {
    EXPECT_EQ(count(svg, "</svg>"), 1u);
    EXPECT_EQ(svg.find("nan"), std::string::npos);
    EXPECT_EQ(svg.find("inf"), std::string::npos);
  }
}

}  // namespace
}  // namespace fleetslam::core
