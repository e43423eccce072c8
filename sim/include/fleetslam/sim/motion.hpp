#pragma once
// Robot motion without physics: a smooth timed trajectory for the free-flying rig, and a path-following
// controller for the differential-drive robot.

#include <cstddef>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/time.hpp"

namespace fleetslam::sim {

// A knot of a rig trajectory: position and roll/pitch/yaw (R = Rz(yaw) Ry(pitch) Rx(roll)) at a time.
struct TimedWaypoint {
  core::TimeNs t_ns = 0;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d rpy_rad = Eigen::Vector3d::Zero();
};

// C2-continuous trajectory through timed knots (cubic splines with zero velocity at both ends, for
// position and for unwrapped roll/pitch/yaw), so accelerations and angular velocities are continuous
// and a simulated IMU is consistent with the poses. Outside [start, end] the pose is held with zero
// velocity, acceleration and angular velocity; at the ends the velocities are zero but the spline's
// acceleration generally is not, so acceleration jumps there (start and end at rest with a knot close
// to the end ones to keep that jump small). Angles are unwrapped so each moves by less than half a
// turn between knots (179 deg -> -179 deg turns by 2 deg); turn further through intermediate knots.
// omega_body follows analytically from the Euler angle rates.
class SmoothTrajectory {
 public:
  struct State {
    Eigen::Isometry3d T_world_body = Eigen::Isometry3d::Identity();
    Eigen::Vector3d v_world_mps = Eigen::Vector3d::Zero();
    Eigen::Vector3d a_world_mps2 = Eigen::Vector3d::Zero();
    Eigen::Vector3d omega_body_radps = Eigen::Vector3d::Zero();  // angular velocity in the body frame
  };

  // Throws std::invalid_argument on fewer than 2 knots, non-increasing times or non-finite values.
  explicit SmoothTrajectory(std::vector<TimedWaypoint> knots);

  State evaluate(core::TimeNs t_ns) const;
  core::TimeNs start_ns() const;
  core::TimeNs end_ns() const;

 private:
  std::vector<TimedWaypoint> knots_;
  // Per-axis cubic spline second derivatives (6 axes: x, y, z, roll, pitch, yaw), computed once.
  std::vector<Eigen::Matrix<double, 6, 1>> second_derivatives_;
};

struct PurePursuitConfig {
  double lookahead_m = 0.4;
  double max_speed_mps = 0.4;
  double max_yaw_rate_radps = 1.0;
  double max_accel_mps2 = 0.5;         // speed changes are limited to this
  double goal_tolerance_m = 0.1;
  double rotate_in_place_deg = 60.0;   // heading errors beyond this turn on the spot first

  template <class V>
  void visit(V& v) {
    v("lookahead_m", lookahead_m, core::Limits<double>{0.01, 100.0});
    v("max_speed_mps", max_speed_mps, core::Limits<double>{0.0, 20.0});
    v("max_yaw_rate_radps", max_yaw_rate_radps, core::Limits<double>{0.0, 20.0});
    v("max_accel_mps2", max_accel_mps2, core::Limits<double>{0.01, 100.0});
    v("goal_tolerance_m", goal_tolerance_m, core::Limits<double>{0.001, 10.0});
    v("rotate_in_place_deg", rotate_in_place_deg, core::Limits<double>{0.0, 180.0});
  }
};

// Pure pursuit (Coulter 1992) on a polyline path for a unicycle/differential-drive base.
// Each update: the progress index moves to the nearest segment within a window ahead (never back, so a
// closed loop is followed to its end); the target is the point lookahead_m of arc length ahead of the
// robot's projection on the path (the goal near the end); the command follows the arc of curvature
// 2 sin(alpha) / L to it. Speed is the least of max_speed_mps, max_yaw_rate_radps / |curvature| and the
// speed from which the robot can brake to a stop at half the goal tolerance (along the path), then
// limited to max_accel_mps2 * dt_s of change; v is never negative and |omega| <= max_yaw_rate_radps.
// A heading error beyond rotate_in_place_deg (at least 2 deg) brakes and turns on the spot. The goal is
// reached on the last segment within goal_tolerance_m once the robot can stop within one step.
class PurePursuit {
 public:
  // The least rotate_in_place_deg in effect: a proportional turn never reaches zero heading error exactly,
  // and below this the robot would never drive off.
  static constexpr double kMinRotateInPlaceDeg = 2.0;
  struct Command {
    double v_mps = 0.0;
    double omega_radps = 0.0;
    bool done = true;  // the goal (last path point) is reached, or there is no path
  };

  // Throws std::invalid_argument on a non-positive lookahead, acceleration or tolerance.
  explicit PurePursuit(const PurePursuitConfig& config);
  // Replaces the path (world x/y) and restarts progress at its first segment; the current speed is
  // kept (the acceleration limit still applies). An empty path stops the robot at once.
  // Throws std::invalid_argument on a non-finite point.
  void set_path(std::vector<Eigen::Vector2d> path_xy);
  // Command for the current planar pose; dt_s bounds the speed change (acceleration limit).
  // Once done, every call returns a zero command until the next set_path.
  // Throws std::invalid_argument on a non-finite pose or a dt_s that is not positive.
  Command update(const Eigen::Vector2d& p_xy, double yaw_rad, double dt_s);
  bool done() const { return done_; }

 private:
  struct Projection {
    std::size_t segment = 0;  // segment from path_[segment] to path_[segment + 1]
    double s = 0.0;           // position along it in [0, 1]
    double distance_m = 0.0;  // from the robot
  };
  void rebuild_arc_lengths();
  void anchor_path_at(const Eigen::Vector2d& p_xy);
  Projection project_on_segment(std::size_t segment, const Eigen::Vector2d& p_xy) const;
  Projection advance_progress(const Eigen::Vector2d& p_xy);
  double arc_length_m(const Projection& projection) const;
  Eigen::Vector2d lookahead_point(const Projection& projection) const;
  double stopping_speed_mps(double distance_m, double dt_s) const;
  Command steer(const Eigen::Vector2d& p_xy, double yaw_rad, const Eigen::Vector2d& target, double v_brake_mps,
                double dt_s);

  PurePursuitConfig config_;
  std::vector<Eigen::Vector2d> path_;
  std::vector<double> cumulative_m_;  // arc length from the first point to each point
  std::size_t progress_ = 0;  // index of the path segment the robot is on
  bool anchor_pending_ = false;  // the next update prepends the robot's position to a new path
  double v_last_ = 0.0;
  bool done_ = true;
};

}  // namespace fleetslam::sim
