#include "mjcf_builder.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace fleetslam::sim::detail {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

std::string num(double value) {
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%.17g", value);
  return buffer;
}

std::string vec3(const Eigen::Vector3d& v) { return num(v.x()) + " " + num(v.y()) + " " + num(v.z()); }

// MuJoCo quaternions are "w x y z".
std::string quat(const Eigen::Matrix3d& R) {
  const Eigen::Quaterniond q(R);
  return num(q.w()) + " " + num(q.x()) + " " + num(q.y()) + " " + num(q.z());
}

// A MuJoCo camera looks along its -z with y up: the optical frame turned by diag(1, -1, -1).
Eigen::Matrix3d R_optical_mjcam() { return Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal(); }

const char* kRobotColours[] = {"0.85 0.33 0.10 1", "0.00 0.45 0.74 1", "0.47 0.67 0.19 1",
                               "0.49 0.18 0.56 1", "0.93 0.69 0.13 1", "0.30 0.75 0.93 1"};

void write_cameras(std::ostringstream& xml, const RobotConfig& robot) {
  if (!robot.camera.enabled) return;
  const std::string prefix = robot_prefix(robot);
  const std::string fovy = num(robot.camera.fovy_deg);
  const Eigen::Isometry3d left = T_body_optical(robot.camera);
  xml << "      <camera name=\"" << prefix << "_cam\" pos=\"" << vec3(left.translation()) << "\" quat=\""
      << quat(left.linear() * R_optical_mjcam()) << "\" fovy=\"" << fovy << "\"/>\n";
  if (robot.stereo.enabled) {
    const Eigen::Isometry3d right = T_body_optical_right(robot.camera, robot.stereo.baseline_m);
    xml << "      <camera name=\"" << prefix << "_cam_right\" pos=\"" << vec3(right.translation())
        << "\" quat=\"" << quat(right.linear() * R_optical_mjcam()) << "\" fovy=\"" << fovy << "\"/>\n";
  }
}

// A differential-drive base on planar joints (x, y slides and a yaw hinge) driven by velocity
// actuators: contacts keep it out of walls, and it cannot tip or fall.
void write_diff_drive(std::ostringstream& xml, const RobotConfig& robot, std::size_t index) {
  const std::string prefix = robot_prefix(robot);
  const std::string colour = kRobotColours[index % std::size(kRobotColours)];
  const double r = robot.radius_m;
  xml << "    <body name=\"" << prefix << "\" pos=\"" << num(robot.initial_pose.x) << " "
      << num(robot.initial_pose.y) << " " << num(robot.initial_pose.z) << "\">\n"
      << "      <joint name=\"" << prefix << "_x\" type=\"slide\" axis=\"1 0 0\"/>\n"
      << "      <joint name=\"" << prefix << "_y\" type=\"slide\" axis=\"0 1 0\"/>\n"
      << "      <joint name=\"" << prefix << "_yaw\" type=\"hinge\" axis=\"0 0 1\"/>\n"
      << "      <geom name=\"" << prefix << "_base\" type=\"cylinder\" size=\"" << num(r) << " 0.08\" pos=\"0 0 0.1\""
      << " mass=\"10\" rgba=\"" << colour << "\"/>\n"
      << "      <geom name=\"" << prefix << "_mast\" type=\"box\" size=\"0.04 0.04 0.12\" pos=\""
      << num(-0.5 * r) << " 0 0.3\" mass=\"1\" rgba=\"0.15 0.15 0.15 1\"/>\n"
      << "      <site name=\"" << prefix << "_imu\" pos=\"0 0 0\" group=\"5\"/>\n";
  write_cameras(xml, robot);
  xml << "    </body>\n";
}

// A free-flying rig: a mocap body whose pose the World sets from its trajectory every step.
void write_free_rig(std::ostringstream& xml, const RobotConfig& robot, std::size_t index) {
  const std::string prefix = robot_prefix(robot);
  const std::string colour = kRobotColours[index % std::size(kRobotColours)];
  const Eigen::Isometry3d T_world_body = pose_from_config(robot.initial_pose);
  xml << "    <body name=\"" << prefix << "\" mocap=\"true\" pos=\"" << vec3(T_world_body.translation())
      << "\" quat=\"" << quat(T_world_body.linear()) << "\">\n"
      << "      <geom name=\"" << prefix << "_shell\" type=\"box\" size=\"0.04 0.08 0.03\" contype=\"0\""
      << " conaffinity=\"0\" rgba=\"" << colour << "\"/>\n"
      << "      <site name=\"" << prefix << "_imu\" pos=\"0 0 0\" group=\"5\"/>\n";
  write_cameras(xml, robot);
  xml << "    </body>\n";
}

}  // namespace

Eigen::Isometry3d pose_from_config(const PoseConfig& pose) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(pose.yaw_deg * kDegToRad, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(pose.pitch_deg * kDegToRad, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(pose.roll_deg * kDegToRad, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(pose.x, pose.y, pose.z);
  return T;
}

Eigen::Isometry3d T_body_optical(const CameraConfig& camera) {
  // Columns: optical x = mount -y (right), optical y = mount -z (down), optical z = mount x (forward).
  Eigen::Matrix3d R_mount_optical;
  R_mount_optical << 0.0, 0.0, 1.0,  //
      -1.0, 0.0, 0.0,                //
      0.0, -1.0, 0.0;
  Eigen::Isometry3d T = pose_from_config(camera.mount);
  T.linear() = T.linear() * R_mount_optical;
  return T;
}

Eigen::Isometry3d T_body_optical_right(const CameraConfig& camera, double baseline_m) {
  Eigen::Isometry3d T_left_right = Eigen::Isometry3d::Identity();
  T_left_right.translation() = Eigen::Vector3d(baseline_m, 0.0, 0.0);
  return T_body_optical(camera) * T_left_right;
}

double focal_length_px(const CameraConfig& camera) {
  return 0.5 * camera.height / std::tan(0.5 * camera.fovy_deg * kDegToRad);
}

std::string robot_prefix(const RobotConfig& robot) { return "fs_" + robot.name; }

std::string build_scenario_mjcf(const ScenarioConfig& scenario, const std::string& scene_file_name) {
  int max_width = 64;
  int max_height = 64;
  for (const auto& robot : scenario.robots) {
    if (!robot.camera.enabled) continue;
    max_width = std::max(max_width, robot.camera.width);
    max_height = std::max(max_height, robot.camera.height);
  }
  std::ostringstream xml;
  xml << "<mujoco model=\"fleetslam_scenario\">\n"
      << "  <include file=\"" << scene_file_name << "\"/>\n"
      << "  <option timestep=\"" << num(scenario.physics_step_s) << "\"/>\n"
      // Multisampling corrupts depth at edges; the buffer must fit the largest camera (DESIGN.md).
      << "  <visual>\n    <global offwidth=\"" << max_width << "\" offheight=\"" << max_height << "\"/>\n"
      << "    <quality offsamples=\"0\"/>\n  </visual>\n"
      << "  <worldbody>\n";
  for (std::size_t i = 0; i < scenario.robots.size(); ++i) {
    const RobotConfig& robot = scenario.robots[i];
    if (robot.type == RobotType::kDiffDrive) {
      write_diff_drive(xml, robot, i);
    } else {
      write_free_rig(xml, robot, i);
    }
  }
  xml << "  </worldbody>\n  <actuator>\n";
  for (const auto& robot : scenario.robots) {
    if (robot.type != RobotType::kDiffDrive) continue;
    const std::string p = robot_prefix(robot);
    xml << "    <velocity name=\"" << p << "_vx\" joint=\"" << p << "_x\" kv=\"400\"/>\n"
        << "    <velocity name=\"" << p << "_vy\" joint=\"" << p << "_y\" kv=\"400\"/>\n"
        << "    <velocity name=\"" << p << "_wz\" joint=\"" << p << "_yaw\" kv=\"10\"/>\n";
  }
  xml << "  </actuator>\n  <sensor>\n";
  for (const auto& robot : scenario.robots) {
    if (robot.type != RobotType::kDiffDrive) continue;
    const std::string p = robot_prefix(robot);
    xml << "    <accelerometer name=\"" << p << "_accel\" site=\"" << p << "_imu\"/>\n"
        << "    <gyro name=\"" << p << "_gyro\" site=\"" << p << "_imu\"/>\n";
  }
  xml << "  </sensor>\n</mujoco>\n";
  return xml.str();
}

}  // namespace fleetslam::sim::detail
