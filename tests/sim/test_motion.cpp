// Robot motion without physics. SmoothTrajectory: interpolation of the knots, derivatives against
// finite differences (position -> velocity -> acceleration, rotation -> body angular velocity),
// continuity at knots, angle unwrapping, held poses, bad knots. PurePursuit: a kinematic unicycle
// driven by it follows L-shaped and square paths, respects its limits and stops at the goal.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

#include "fleetslam/core/se3.hpp"
#include "fleetslam/sim/motion.hpp"

namespace fleetslam::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr core::TimeNs kSecondNs = core::kNsPerSecond;

Eigen::Matrix3d rpy_rotation(const Eigen::Vector3d& rpy) {
  return (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

// Uneven knot times and a tour of position and attitude (pitch kept away from +-90 deg).
std::vector<TimedWaypoint> test_knots() {
  const std::vector<double> t_s = {0.0, 1.5, 2.5, 4.5, 5.0, 7.0};
  std::mt19937 engine(17);
  std::uniform_real_distribution<double> position(-2.0, 2.0);
  std::uniform_real_distribution<double> angle(-1.0, 1.0);
  std::vector<TimedWaypoint> knots;
  for (double t : t_s) {
    TimedWaypoint knot;
    knot.t_ns = 1'000'000'000 + static_cast<core::TimeNs>(t * 1e9);
    knot.p_world = Eigen::Vector3d(position(engine), position(engine), position(engine));
    knot.rpy_rad = Eigen::Vector3d(0.6 * angle(engine), 0.6 * angle(engine), 3.0 * angle(engine));
    knots.push_back(knot);
  }
  return knots;
}

TEST(SmoothTrajectory, PassesThroughTheKnotsAtRestAtTheEnds) {
  const std::vector<TimedWaypoint> knots = test_knots();
  const SmoothTrajectory trajectory(knots);
  EXPECT_EQ(trajectory.start_ns(), knots.front().t_ns);
  EXPECT_EQ(trajectory.end_ns(), knots.back().t_ns);
  for (const TimedWaypoint& knot : knots) {
    const SmoothTrajectory::State state = trajectory.evaluate(knot.t_ns);
    EXPECT_LT((state.T_world_body.translation() - knot.p_world).norm(), 1e-12);
    EXPECT_LT((state.T_world_body.linear() - rpy_rotation(knot.rpy_rad)).norm(), 1e-12);
  }
  for (core::TimeNs t : {trajectory.start_ns(), trajectory.end_ns()}) {
    const SmoothTrajectory::State state = trajectory.evaluate(t);
    EXPECT_LT(state.v_world_mps.norm(), 1e-12);
    EXPECT_LT(state.omega_body_radps.norm(), 1e-12);
  }
}

TEST(SmoothTrajectory, DerivativesMatchFiniteDifferences) {
  const SmoothTrajectory trajectory(test_knots());
  constexpr core::TimeNs kH = 100'000;  // 0.1 ms
  const double h_s = core::ns_to_seconds(kH);
  std::mt19937_64 engine(3);
  std::uniform_int_distribution<core::TimeNs> when(trajectory.start_ns() + kH, trajectory.end_ns() - kH);
  double worst_v = 0.0, worst_a = 0.0, worst_omega = 0.0;
  for (int i = 0; i < 500; ++i) {
    const core::TimeNs t = when(engine);
    const SmoothTrajectory::State before = trajectory.evaluate(t - kH);
    const SmoothTrajectory::State now = trajectory.evaluate(t);
    const SmoothTrajectory::State after = trajectory.evaluate(t + kH);
    const Eigen::Vector3d v_numeric =
        (after.T_world_body.translation() - before.T_world_body.translation()) / (2.0 * h_s);
    const Eigen::Vector3d a_numeric = (after.v_world_mps - before.v_world_mps) / (2.0 * h_s);
    // log(R(t - h)^T R(t + h)) / 2h is the body rate at t to second order.
    const Eigen::Vector3d omega_numeric =
        core::so3_log(before.T_world_body.linear().transpose() * after.T_world_body.linear()) / (2.0 * h_s);
    worst_v = std::max(worst_v, (v_numeric - now.v_world_mps).norm());
    worst_a = std::max(worst_a, (a_numeric - now.a_world_mps2).norm());
    worst_omega = std::max(worst_omega, (omega_numeric - now.omega_body_radps).norm());
  }
  std::printf("finite differences, worst error: v %.2e m/s, a %.2e m/s^2, omega %.2e rad/s\n", worst_v, worst_a,
              worst_omega);
  EXPECT_LT(worst_v, 1e-6);
  EXPECT_LT(worst_a, 1e-4);  // the third derivative jumps at knots: first order there
  EXPECT_LT(worst_omega, 1e-6);
}

TEST(SmoothTrajectory, AccelerationAndAngularVelocityAreContinuousAtKnots) {
  const std::vector<TimedWaypoint> knots = test_knots();
  const SmoothTrajectory trajectory(knots);
  for (std::size_t i = 1; i + 1 < knots.size(); ++i) {
    const SmoothTrajectory::State left = trajectory.evaluate(knots[i].t_ns - 1);
    const SmoothTrajectory::State right = trajectory.evaluate(knots[i].t_ns + 1);
    EXPECT_LT((left.a_world_mps2 - right.a_world_mps2).norm(), 1e-6) << "knot " << i;
    EXPECT_LT((left.v_world_mps - right.v_world_mps).norm(), 1e-6) << "knot " << i;
    EXPECT_LT((left.omega_body_radps - right.omega_body_radps).norm(), 1e-6) << "knot " << i;
    EXPECT_GT(left.a_world_mps2.norm(), 1e-3) << "knot " << i;  // not trivially zero
  }
}

TEST(SmoothTrajectory, HoldsThePoseOutsideItsSpan) {
  const std::vector<TimedWaypoint> knots = test_knots();
  const SmoothTrajectory trajectory(knots);
  for (const auto& [t, knot] : {std::pair{trajectory.start_ns() - kSecondNs, knots.front()},
                                std::pair{trajectory.end_ns() + kSecondNs, knots.back()}}) {
    const SmoothTrajectory::State state = trajectory.evaluate(t);
    EXPECT_LT((state.T_world_body.translation() - knot.p_world).norm(), 1e-12);
    EXPECT_LT((state.T_world_body.linear() - rpy_rotation(knot.rpy_rad)).norm(), 1e-12);
    EXPECT_EQ(state.v_world_mps, Eigen::Vector3d::Zero());
    EXPECT_EQ(state.a_world_mps2, Eigen::Vector3d::Zero());
    EXPECT_EQ(state.omega_body_radps, Eigen::Vector3d::Zero());
  }
}

TEST(SmoothTrajectory, YawTakesTheShortWayAcrossPi) {
  TimedWaypoint a, b;
  a.rpy_rad.z() = 170.0 * kPi / 180.0;
  b.t_ns = 2 * kSecondNs;
  b.rpy_rad.z() = -170.0 * kPi / 180.0;
  const SmoothTrajectory trajectory({a, b});
  const SmoothTrajectory::State middle = trajectory.evaluate(kSecondNs);
  const Eigen::Matrix3d& R = middle.T_world_body.linear();
  EXPECT_NEAR(std::atan2(R(1, 0), R(0, 0)), kPi, 1e-9);  // yaw 180 deg, not 0
  EXPECT_GT(middle.omega_body_radps.z(), 0.0);
  EXPECT_LT(middle.omega_body_radps.z(), 0.3);  // 20 deg in 2 s peaks at 1.5 x 10 deg/s = 0.26 rad/s
}

TEST(SmoothTrajectory, RejectsBadKnots) {
  std::vector<TimedWaypoint> knots = test_knots();
  EXPECT_THROW(SmoothTrajectory({}), std::invalid_argument);
  EXPECT_THROW(SmoothTrajectory({knots[0]}), std::invalid_argument);
  std::vector<TimedWaypoint> repeated = knots;
  repeated[2].t_ns = repeated[1].t_ns;
  EXPECT_THROW(SmoothTrajectory{repeated}, std::invalid_argument);
  std::vector<TimedWaypoint> decreasing = knots;
  std::swap(decreasing[2], decreasing[3]);
  EXPECT_THROW(SmoothTrajectory{decreasing}, std::invalid_argument);
  std::vector<TimedWaypoint> nan_position = knots;
  nan_position[1].p_world.y() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(SmoothTrajectory{nan_position}, std::invalid_argument);
  std::vector<TimedWaypoint> inf_angle = knots;
  inf_angle[4].rpy_rad.x() = std::numeric_limits<double>::infinity();
  EXPECT_THROW(SmoothTrajectory{inf_angle}, std::invalid_argument);
}

// Distance from a point to a polyline.
double distance_to_path(const Eigen::Vector2d& p, const std::vector<Eigen::Vector2d>& path) {
  double best = (p - path.front()).norm();
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    const Eigen::Vector2d ab = path[i + 1] - path[i];
    const double s = std::clamp((p - path[i]).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    best = std::min(best, (p - (path[i] + s * ab)).norm());
  }
  return best;
}

struct DriveResult {
  bool done = false;
  double time_s = 0.0;
  double max_path_error_m = 0.0;
  double final_goal_error_m = 0.0;
  double max_v_mps = 0.0, min_v_mps = 0.0, max_abs_omega_radps = 0.0, max_dv_mps = 0.0;
  double path_covered = 0.0;  // fraction of path vertices passed within 0.25 m
};

// A kinematic unicycle (exact arc integration) driven at 50 Hz for at most max_s.
DriveResult drive(PurePursuit& controller, const std::vector<Eigen::Vector2d>& path, Eigen::Vector2d p, double yaw,
                  double max_s) {
  constexpr double kDt = 0.02;
  DriveResult result;
  std::vector<bool> visited(path.size(), false);
  double v_previous = 0.0;
  for (double t = 0.0; t < max_s; t += kDt) {
    const PurePursuit::Command command = controller.update(p, yaw, kDt);
    result.max_v_mps = std::max(result.max_v_mps, command.v_mps);
    result.min_v_mps = std::min(result.min_v_mps, command.v_mps);
    result.max_abs_omega_radps = std::max(result.max_abs_omega_radps, std::abs(command.omega_radps));
    result.max_dv_mps = std::max(result.max_dv_mps, std::abs(command.v_mps - v_previous));
    v_previous = command.v_mps;
    if (command.done) {
      result.done = true;
      result.time_s = t;
      break;
    }
    const double dyaw = command.omega_radps * kDt;
    const double chord = std::abs(dyaw) > 1e-12 ? 2.0 * std::sin(0.5 * dyaw) / dyaw : 1.0;
    p += command.v_mps * kDt * chord * Eigen::Vector2d(std::cos(yaw + 0.5 * dyaw), std::sin(yaw + 0.5 * dyaw));
    yaw += dyaw;
    result.max_path_error_m = std::max(result.max_path_error_m, distance_to_path(p, path));
    for (std::size_t i = 0; i < path.size(); ++i) visited[i] = visited[i] || (p - path[i]).norm() < 0.25;
  }
  result.final_goal_error_m = (p - path.back()).norm();
  result.path_covered = static_cast<double>(std::count(visited.begin(), visited.end(), true)) / path.size();
  return result;
}

void expect_limits(const DriveResult& r, const PurePursuitConfig& config, double dt_s) {
  EXPECT_LE(r.max_v_mps, config.max_speed_mps + 1e-12);
  EXPECT_GE(r.min_v_mps, 0.0);
  EXPECT_LE(r.max_abs_omega_radps, config.max_yaw_rate_radps + 1e-12);
  EXPECT_LE(r.max_dv_mps, config.max_accel_mps2 * dt_s + 1e-12);
}

void report(const char* name, const DriveResult& r) {
  std::printf("%s: done %d after %.2f s, max path error %.3f m, goal error %.3f m, v max %.3f, |omega| max %.3f\n",
              name, r.done ? 1 : 0, r.time_s, r.max_path_error_m, r.final_goal_error_m, r.max_v_mps,
              r.max_abs_omega_radps);
}

TEST(PurePursuit, FollowsAnLShapedPathToTheGoal) {
  const PurePursuitConfig config;
  PurePursuit controller(config);
  const std::vector<Eigen::Vector2d> path = {{0.0, 0.0}, {3.0, 0.0}, {3.0, 2.0}};
  controller.set_path(path);
  EXPECT_FALSE(controller.done());
  const DriveResult r = drive(controller, path, {0.0, 0.0}, 0.0, 60.0);
  report("L path", r);
  EXPECT_TRUE(r.done);
  EXPECT_TRUE(controller.done());
  EXPECT_LE(r.final_goal_error_m, config.goal_tolerance_m);
  EXPECT_LT(r.max_path_error_m, 0.5 * config.lookahead_m);  // pure pursuit cuts corners by a fraction of it
  EXPECT_LT(r.time_s, 1.5 * 5.0 / config.max_speed_mps);
  expect_limits(r, config, 0.02);
}

TEST(PurePursuit, FollowsAClosedSquareAllTheWayRound) {
  PurePursuitConfig config;
  config.max_speed_mps = 0.6;
  PurePursuit controller(config);
  // Starts and ends at the origin: the goal is reached only after the whole loop.
  const std::vector<Eigen::Vector2d> path = {{0.0, 0.0}, {2.0, 0.0}, {2.0, 2.0}, {0.0, 2.0}, {0.0, 0.0}};
  controller.set_path(path);
  const DriveResult r = drive(controller, path, {0.05, -0.05}, 0.2, 120.0);
  report("square", r);
  EXPECT_TRUE(r.done);
  EXPECT_DOUBLE_EQ(r.path_covered, 1.0);
  EXPECT_GT(r.time_s, 8.0 / config.max_speed_mps);
  EXPECT_LE(r.final_goal_error_m, config.goal_tolerance_m);
  EXPECT_LT(r.max_path_error_m, 0.5 * config.lookahead_m);
  expect_limits(r, config, 0.02);
}

TEST(PurePursuit, ALoopStartingFarFromTheRobotIsNotSkipped) {
  const PurePursuitConfig config;
  PurePursuit controller(config);
  // The loop's first point is 6 m away and its closing leg passes nearer the robot than that: the robot
  // drives to the start and then all the way round, instead of measuring its progress against the whole
  // loop and jumping to its end.
  const std::vector<Eigen::Vector2d> loop = {{6.0, 0.0}, {8.0, 0.0}, {8.0, 2.0}, {6.0, 2.0}, {5.0, 0.5}};
  controller.set_path(loop);
  const DriveResult r = drive(controller, loop, {0.0, 0.0}, 0.0, 200.0);
  report("far loop", r);
  EXPECT_TRUE(r.done);
  EXPECT_DOUBLE_EQ(r.path_covered, 1.0);
  EXPECT_GT(r.time_s, (6.0 + 7.1) / config.max_speed_mps);
  EXPECT_LE(r.final_goal_error_m, config.goal_tolerance_m);
}

TEST(PurePursuit, TurnsOnTheSpotTowardsAPathBehind) {
  PurePursuitConfig config;
  config.max_yaw_rate_radps = 0.8;
  PurePursuit controller(config);
  const std::vector<Eigen::Vector2d> path = {{0.0, 0.0}, {-2.0, 0.0}};
  controller.set_path(path);
  const PurePursuit::Command first = controller.update({0.0, 0.0}, 0.0, 0.02);
  EXPECT_EQ(first.v_mps, 0.0);
  EXPECT_NEAR(std::abs(first.omega_radps), config.max_yaw_rate_radps, 1e-12);
  const DriveResult r = drive(controller, path, {0.0, 0.0}, 0.0, 30.0);
  report("behind", r);
  EXPECT_TRUE(r.done);
  EXPECT_LT(r.max_path_error_m, 0.5 * config.lookahead_m);  // it drives off on an arc below 60 deg
  expect_limits(r, config, 0.02);
}

// Planned paths can end in a kink shorter than the goal tolerance (a goal snapped to the nearest free
// cell): the robot must still come to the goal and be done, not stop short on the segment before.
TEST(PurePursuit, APathEndingInAShortKinkIsFinished) {
  const PurePursuitConfig config;
  for (const Eigen::Vector2d& kink : {Eigen::Vector2d(-0.047, 0.033), Eigen::Vector2d(0.0, 0.06),
                                      Eigen::Vector2d(0.03, -0.08)}) {
    PurePursuit controller(config);
    std::vector<Eigen::Vector2d> path = {{0.0, 0.0}, {1.0, -0.2}, {2.0, -0.4}};
    path.push_back(path.back() + kink);
    controller.set_path(path);
    const DriveResult r = drive(controller, path, {0.0, 0.0}, 0.0, 30.0);
    EXPECT_TRUE(r.done) << kink.transpose();
    EXPECT_LE(r.final_goal_error_m, config.goal_tolerance_m) << kink.transpose();
  }
}

// A path ending in a segment shorter than the goal tolerance (a goal snapped to the nearest free cell):
// a robot near the end of the segment before it, nearer to that one, has less path left than half the
// tolerance. It must be done there (it stood still, never done, in a closed-loop run), and a robot
// beside the end with the goal beyond the tolerance must still drive to it.
TEST(PurePursuit, APathEndingInASegmentShorterThanTheToleranceIsFinished) {
  const PurePursuitConfig config;
  const std::vector<Eigen::Vector2d> path = {{1.9, 0.0}, {2.0, 0.0}, {1.975, 0.017}};
  {
    PurePursuit controller(config);
    controller.set_path(path);
    const DriveResult r = drive(controller, path, {1.99, 0.003}, 0.0, 5.0);
    EXPECT_TRUE(r.done);
    EXPECT_LE(r.final_goal_error_m, config.goal_tolerance_m);
  }
  {
    PurePursuit controller(config);
    const std::vector<Eigen::Vector2d> beside = {{1.9, 0.0}, {2.0, 0.0}, {1.985, 0.2}};
    controller.set_path(beside);
    const DriveResult r = drive(controller, beside, {1.99, 0.003}, 0.0, 10.0);
    EXPECT_TRUE(r.done);
    EXPECT_LE(r.final_goal_error_m, config.goal_tolerance_m);
  }
}

TEST(PurePursuit, EmptyPathIsDoneWithAZeroCommand) {
  PurePursuit controller(PurePursuitConfig{});
  EXPECT_TRUE(controller.done());
  PurePursuit::Command command = controller.update({1.0, 2.0}, 0.3, 0.02);
  EXPECT_TRUE(command.done);
  EXPECT_EQ(command.v_mps, 0.0);
  EXPECT_EQ(command.omega_radps, 0.0);

  controller.set_path({{0.0, 0.0}, {5.0, 0.0}});
  for (int k = 0; k < 20; ++k) command = controller.update({0.0, 0.0}, 0.0, 0.02);
  EXPECT_GT(command.v_mps, 0.0);
  controller.set_path({});
  command = controller.update({0.1, 0.0}, 0.0, 0.02);
  EXPECT_TRUE(command.done);
  EXPECT_EQ(command.v_mps, 0.0);
  EXPECT_EQ(command.omega_radps, 0.0);
}

TEST(PurePursuit, SinglePointPathAndGoalUnderTheRobot) {
  PurePursuit controller(PurePursuitConfig{});
  controller.set_path({{0.02, 0.0}});
  EXPECT_TRUE(controller.update({0.0, 0.0}, 1.0, 0.02).done);
  const std::vector<Eigen::Vector2d> path = {{1.0, 1.0}};
  controller.set_path(path);
  const DriveResult r = drive(controller, path, {0.0, 0.0}, 0.0, 30.0);
  EXPECT_TRUE(r.done);
  EXPECT_LE(r.final_goal_error_m, 0.1);
}

TEST(PurePursuit, RejectsBadInput) {
  PurePursuitConfig config;
  config.lookahead_m = 0.0;
  EXPECT_THROW(PurePursuit{config}, std::invalid_argument);
  PurePursuit controller(PurePursuitConfig{});
  EXPECT_THROW(controller.set_path({{0.0, std::nan("")}}), std::invalid_argument);
  controller.set_path({{0.0, 0.0}, {1.0, 0.0}});
  EXPECT_THROW(controller.update({0.0, 0.0}, 0.0, 0.0), std::invalid_argument);
  EXPECT_THROW(controller.update({0.0, 0.0}, std::nan(""), 0.02), std::invalid_argument);
}

}  // namespace
}  // namespace fleetslam::sim
