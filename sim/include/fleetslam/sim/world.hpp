#pragma once
// The simulated world: a MuJoCo scene with robots inserted, stepped in lockstep with integer-nanosecond
// scheduling, rendering each robot's cameras off-screen (OSMesa) and sampling its IMU.
//
// Each call to step() advances physics to the next camera tick of any robot and returns the frames of
// the robots whose camera ticks then. Physics runs at a fixed step; IMU and camera ticks are the physics
// instants nearest to k / rate (computed from k, so they never drift). Same scenario + seeds -> the
// same bytes. MuJoCo and OpenGL stay behind this interface.

#include <cstddef>
#include <memory>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "fleetslam/core/log.hpp"
#include "fleetslam/core/sensor_frame.hpp"
#include "fleetslam/core/sensor_rig.hpp"
#include "fleetslam/sim/scenario.hpp"

namespace fleetslam::sim {

// Ground truth of one robot at the current time.
struct RobotTruth {
  Eigen::Isometry3d T_world_body = Eigen::Isometry3d::Identity();
  Eigen::Vector3d v_world_mps = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_bias_radps = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias_mps2 = Eigen::Vector3d::Zero();
  int contacts_with_scene = 0;  // contacts between the robot's geoms and anything else right now
};

// The space a robot's body takes, as a cylinder about its body frame's z axis that holds all its geoms:
// what other robots' cameras see of it (a central unit that knows where its robots are can tell them
// apart from the scene).
struct BodyCylinder {
  double radius_m = 0.0;
  double z_min_m = 0.0;  // along body z
  double z_max_m = 0.0;
};

class World {
 public:
  // Loads the scene, inserts the robots and prepares rendering. Throws InputError naming the scenario or
  // scene file on a missing or malformed MJCF, cameras larger than the GL buffer, or no OSMesa.
  World(ScenarioConfig scenario, core::Logger logger);
  ~World();
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  // Advances to the next camera tick and returns the frames rendered then (robot order). Empty once the
  // scenario duration is over.
  std::vector<core::SensorFrame> step();

  core::TimeNs time_ns() const;
  core::TimeNs end_ns() const;
  bool finished() const;

  std::size_t robot_count() const;
  const RobotConfig& robot_config(std::size_t robot) const;
  // The robot's sensors as a SLAM system sees them: camera intrinsics (undistorted pinhole), stereo
  // extrinsics, T_body_cam0 (body = IMU frame), IMU noise, depth scale and virtual baseline.
  core::SensorRig sensor_rig(std::size_t robot) const;
  // Pose of the (left) camera's optical frame (OpenCV: x right, y down, z forward) in the body frame.
  Eigen::Isometry3d T_body_cam(std::size_t robot) const;
  RobotTruth truth(std::size_t robot) const;
  // From the robot's geoms in the model (exact for spheres and upright cylinders, a geom's box corners
  // otherwise).
  BodyCylinder body_cylinder(std::size_t robot) const;

  // Diff-drive robots: replace the path their controller follows (world x/y; the scenario's waypoints
  // are the initial path). Throws std::invalid_argument for free rigs or a bad index.
  void set_path(std::size_t robot, std::vector<Eigen::Vector2d> path_xy);
  bool path_done(std::size_t robot) const;

  // Points on the static scene's surfaces (not the robots), about spacing_m apart: ground truth for
  // judging maps. Infinite planes are clipped to the scene's bounds.
  std::vector<Eigen::Vector3f> surface_points(double spacing_m) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fleetslam::sim
