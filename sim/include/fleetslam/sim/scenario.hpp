#pragma once
// A scenario: which MJCF scene, which robots where, with which sensors, for how long.
// Read from YAML with core::ConfigReader (unknown keys, bad values: errors naming file:key).
//
//   scene: ../office/office.xml        # relative to the scenario file
//   duration_s: 20
//   seed: 1
//   robots:
//     - name: alpha
//       type: diff_drive               # diff_drive | free_rig
//       initial_pose: {x: 0.5, y: 0.0, z: 0.0, yaw_deg: 90}
//       camera: {width: 640, height: 480, fovy_deg: 45, rate_hz: 30, depth: true}
//       stereo: {enabled: true, baseline_m: 0.11}          # adds a right camera
//       waypoints: [{x: 1, y: 2}, {x: 3, y: 2}]   # diff_drive: path; free_rig: timed knots (t_s, rpy)

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "fleetslam/core/config.hpp"
#include "fleetslam/sim/imu_model.hpp"
#include "fleetslam/sim/motion.hpp"
#include "fleetslam/sim/sensor_noise.hpp"

namespace fleetslam::sim {

enum class RobotType { kDiffDrive, kFreeRig };

// A pose in the robot body frame (x forward, y left, z up) or in the world (z up).
struct PoseConfig {
  double x = 0.0, y = 0.0, z = 0.0;
  double roll_deg = 0.0, pitch_deg = 0.0, yaw_deg = 0.0;

  template <class V>
  void visit(V& v) {
    const core::Limits<double> position{-1e4, 1e4};
    const core::Limits<double> angle{-360.0, 360.0};
    v("x", x, position);
    v("y", y, position);
    v("z", z, position);
    v("roll_deg", roll_deg, angle);
    v("pitch_deg", pitch_deg, angle);
    v("yaw_deg", yaw_deg, angle);
  }
};

struct WaypointConfig {
  double t_s = 0.0;  // free_rig knots only
  double x = 0.0, y = 0.0, z = 0.0;
  double roll_deg = 0.0, pitch_deg = 0.0, yaw_deg = 0.0;

  template <class V>
  void visit(V& v) {
    v("t_s", t_s, core::Limits<double>{0.0, 1e6});
    const core::Limits<double> position{-1e4, 1e4};  // as initial_pose's (a free rig's first knot becomes it)
    v("x", x, position);
    v("y", y, position);
    v("z", z, position);
    // Unwrapped (a spline through 0, 350, 700 turns twice), within a range that keeps radians exact.
    const core::Limits<double> angle{-1e5, 1e5};
    v("roll_deg", roll_deg, angle);
    v("pitch_deg", pitch_deg, angle);
    v("yaw_deg", yaw_deg, angle);
  }
};

// The camera on a robot. The optical axis looks along the mount's +x (forward); intrinsics follow from
// the vertical field of view: fy = fx = (height / 2) / tan(fovy / 2), principal point at the image
// centre ((width - 1) / 2, (height - 1) / 2). With `depth` it is an RGB-D camera (metric depth
// registered to the image); with a stereo pair it is the left camera.
struct CameraConfig {
  bool enabled = true;
  bool depth = true;           // render metric depth registered to the image
  bool gray = false;           // 8-bit gray images instead of colour (EuRoC-like)
  int width = 640;
  int height = 480;
  double fovy_deg = 45.0;
  double rate_hz = 30.0;
  bool shadows = false;
  PoseConfig mount{0.15, 0.0, 0.3, 0.0, 0.0, 0.0};
  ImageNoiseConfig image_noise;
  DepthNoiseConfig depth_noise;

  template <class V>
  void visit(V& v) {
    v("enabled", enabled);
    v("depth", depth);
    v("gray", gray);
    v("width", width, core::Limits<int>{16, 4096});
    v("height", height, core::Limits<int>{16, 4096});
    v("fovy_deg", fovy_deg, core::Limits<double>{1.0, 170.0});
    v("rate_hz", rate_hz, core::Limits<double>{0.1, 1000.0});
    v("shadows", shadows);
    v("mount", mount);
    v("image_noise", image_noise);
    v("depth_noise", depth_noise);
  }
};

// A rectified stereo pair: the robot's camera is the left one; a right camera with the same intrinsics
// sits baseline_m along the left camera's x axis (to its right).
struct StereoConfig {
  bool enabled = false;
  double baseline_m = 0.11;

  template <class V>
  void visit(V& v) {
    v("enabled", enabled);
    v("baseline_m", baseline_m, core::Limits<double>{0.001, 10.0});
  }
};

struct RobotConfig {
  std::string name;
  RobotType type = RobotType::kDiffDrive;
  PoseConfig initial_pose;
  std::int64_t seed = -1;      // -1: derived from the scenario seed and the robot's index
  double radius_m = 0.2;       // collision radius (diff_drive body), also used for start overlap checks
  CameraConfig camera;
  StereoConfig stereo;
  ImuModelConfig imu;
  PurePursuitConfig controller;
  std::vector<WaypointConfig> waypoints;

  template <class V>
  void visit(V& v) {
    v.required("name", name);
    v.choice("type", type, {{"diff_drive", RobotType::kDiffDrive}, {"free_rig", RobotType::kFreeRig}});
    v("initial_pose", initial_pose);
    v("seed", seed, core::Limits<std::int64_t>{-1, std::numeric_limits<std::int64_t>::max()});
    v("radius_m", radius_m, core::Limits<double>{0.01, 10.0});
    v("camera", camera);
    v("stereo", stereo);
    v("imu", imu);
    v("controller", controller);
    v("waypoints", waypoints);
  }
};

struct ScenarioConfig {
  // Robot seeds are derived as seed * 1000 + index + 1 (validate_scenario): the largest seed keeps that
  // within std::int64_t.
  static constexpr std::int64_t kMaxSeed = 1'000'000'000'000'000;

  std::string scene;                 // MJCF file, relative to the scenario file's folder
  double duration_s = 10.0;
  double physics_step_s = 0.001;
  std::int64_t seed = 1;
  std::vector<RobotConfig> robots;

  std::filesystem::path base_dir;    // folder of the scenario file (not a YAML key)

  template <class V>
  void visit(V& v) {
    v.required("scene", scene);
    v("duration_s", duration_s, core::Limits<double>{1e-3, 1e6});
    v("physics_step_s", physics_step_s, core::Limits<double>{1e-5, 0.1});
    v("seed", seed, core::Limits<std::int64_t>{0, kMaxSeed});
    v("robots", robots);
  }

  std::filesystem::path scene_path() const { return base_dir / scene; }
  // The same, absolute and normalised: what an effective scenario written elsewhere names.
  std::filesystem::path absolute_scene_path() const { return std::filesystem::absolute(scene_path()).lexically_normal(); }
};

// Sections of a scenario file that the layers above the simulator read (`fleetslam run`: the agents'
// config, the central unit's, the planner's, the mission and the pass criteria); load_scenario skips them.
inline constexpr const char* kRunSections[] = {"agent", "central", "planner", "mission", "criteria"};

// A MuJoCo scene (.xml) given where a scenario is expected: an InputError saying so.
void refuse_scene_file(const std::filesystem::path& file);

// Reads a scenario file: the typed config plus checks that need the whole (unique robot names,
// at least one robot, waypoints fit the robot type). Throws InputError naming file:key.
ScenarioConfig load_scenario(const std::filesystem::path& file);

// The checks of load_scenario for a scenario read as part of a larger file (the runner's scenario, which
// adds the agent, central, planner, mission and criteria sections): sets base_dir to the file's folder,
// derives robot seeds, and throws InputError naming file:key.
void validate_scenario(ScenarioConfig& scenario, const std::filesystem::path& file);

// The seed of robot `index` without one of its own (RobotConfig::seed -1): scenario_seed * 1000 + index + 1.
// validate_scenario sets it; sim::World derives it too, for a ScenarioConfig built in code.
inline std::int64_t derived_robot_seed(std::int64_t scenario_seed, std::size_t index) {
  return scenario_seed * 1000 + static_cast<std::int64_t>(index) + 1;
}

// Whether an IMU at rate_hz samples every whole number of physics steps of step_s (its samples fall on
// steps, so any other period gives uneven gaps under a calibration that states one rate). Checked by
// validate_scenario and sim::World.
inline bool imu_period_fits_steps(double rate_hz, double step_s) {
  const double steps = 1.0 / (rate_hz * step_s);
  return std::abs(steps - std::round(steps)) <= 1e-6 * steps;
}

}  // namespace fleetslam::sim
