#include "fleetslam/sim/scenario.hpp"

#include <cmath>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "fleetslam/core/error.hpp"
#include "fleetslam/core/time.hpp"

namespace fleetslam::sim {
namespace {

std::string robot_key(const std::filesystem::path& file, std::size_t index, const std::string& key) {
  return file.string() + ":robots[" + std::to_string(index) + "]" + (key.empty() ? "" : "." + key);
}

void check_waypoints(const std::filesystem::path& file, std::size_t index, const RobotConfig& robot) {
  if (robot.type != RobotType::kFreeRig) return;
  if (robot.waypoints.size() < 2) {
    throw InputError(robot_key(file, index, "waypoints"), "a free_rig needs at least 2 timed waypoints");
  }
  // In nanoseconds, as the trajectory takes them: 0 and 1e-10 s are one knot time.
  for (std::size_t k = 1; k < robot.waypoints.size(); ++k) {
    if (!(core::seconds_to_ns(robot.waypoints[k].t_s) > core::seconds_to_ns(robot.waypoints[k - 1].t_s))) {
      throw InputError(robot_key(file, index, "waypoints[" + std::to_string(k) + "].t_s"),
                       "waypoint times must increase");
    }
  }
}

// The values of a config's fields, in visit order (PoseConfig, WaypointConfig, PurePursuitConfig: numbers).
struct FieldValues {
  std::vector<std::pair<std::string, double>> fields;
  template <class T, class... Limits>
  void operator()(const char* key, T& value, Limits&&...) {
    fields.emplace_back(key, static_cast<double>(value));
  }
};

template <class Config>
std::vector<std::pair<std::string, double>> field_values(Config config) {
  FieldValues values;
  config.visit(values);
  return values.fields;
}

// The first field of `given` that differs from `reference`'s, or "".
template <class Config>
std::string first_difference(const Config& given, const Config& reference) {
  const auto a = field_values(given);
  const auto b = field_values(reference);
  for (std::size_t k = 0; k < a.size(); ++k) {
    if (!(a[k].second == b[k].second)) return a[k].first;
  }
  return "";
}

// Settings a robot type does not use are refused, not silently ignored: a diff_drive robot stands on the
// floor (no roll or pitch) and follows x/y waypoints (no times, heights or angles); a free_rig follows its
// timed waypoints (no controller) and starts at the first one (initial_pose, when given, must be it).
void check_unused_settings(const std::filesystem::path& file, std::size_t index, RobotConfig& robot) {
  if (robot.type == RobotType::kDiffDrive) {
    if (robot.initial_pose.roll_deg != 0.0 || robot.initial_pose.pitch_deg != 0.0) {
      throw InputError(robot_key(file, index, robot.initial_pose.roll_deg != 0.0 ? "initial_pose.roll_deg" : "initial_pose.pitch_deg"),
                       "a diff_drive robot stands on the floor: its initial pose has x, y, z and yaw_deg only");
    }
    for (std::size_t k = 0; k < robot.waypoints.size(); ++k) {
      WaypointConfig plain;
      plain.x = robot.waypoints[k].x;
      plain.y = robot.waypoints[k].y;
      const std::string key = first_difference(robot.waypoints[k], plain);
      if (!key.empty()) {
        throw InputError(robot_key(file, index, "waypoints[" + std::to_string(k) + "]." + key),
                         "a diff_drive robot's waypoints are x and y (t_s, z and angles are a free_rig's)");
      }
    }
    const PurePursuitConfig& c = robot.controller;
    if (!(c.max_speed_mps > 0.0) || !(c.max_yaw_rate_radps > 0.0)) {
      throw InputError(robot_key(file, index, c.max_speed_mps > 0.0 ? "controller.max_yaw_rate_radps" : "controller.max_speed_mps"),
                       "must be positive: the robot could never finish its path");
    }
    return;
  }
  const std::string controller_key = first_difference(robot.controller, PurePursuitConfig{});
  if (!controller_key.empty()) {
    throw InputError(robot_key(file, index, "controller." + controller_key),
                     "a free_rig follows its timed waypoints: it has no controller");
  }
  if (robot.waypoints.empty()) return;  // check_waypoints refuses it
  // Angles as initial_pose holds them, in [-180, 180): knots may count turns beyond +-360 degrees, and the
  // effective scenario written with this initial_pose must load again.
  const auto with_wrapped_angles = [](PoseConfig pose) {
    for (double* deg : {&pose.roll_deg, &pose.pitch_deg, &pose.yaw_deg}) {
      const double w = std::fmod(*deg + 180.0, 360.0);
      *deg = (w < 0.0 ? w + 360.0 : w) - 180.0;
    }
    return pose;
  };
  const WaypointConfig& w = robot.waypoints.front();
  const PoseConfig first = with_wrapped_angles({w.x, w.y, w.z, w.roll_deg, w.pitch_deg, w.yaw_deg});
  if (first_difference(robot.initial_pose, PoseConfig{}).empty()) {
    robot.initial_pose = first;  // not given: where the rig starts
  } else if (const std::string key = first_difference(with_wrapped_angles(robot.initial_pose), first); !key.empty()) {
    throw InputError(robot_key(file, index, "initial_pose." + key),
                     "a free_rig starts at its first waypoint: give initial_pose as that pose, or leave it out");
  }
}

// What the World's parts would refuse later without naming the file and key.
void check_sensors(const std::filesystem::path& file, std::size_t index, const RobotConfig& robot, double physics_step_s) {
  // Sensors are sampled at physics steps: two ticks in one step would stop a stream for good.
  if (robot.camera.enabled && robot.camera.rate_hz * physics_step_s > 1.0) {
    throw InputError(robot_key(file, index, "camera.rate_hz"),
                     std::to_string(robot.camera.rate_hz) + " Hz exceeds the physics rate " +
                         std::to_string(1.0 / physics_step_s) + " Hz (physics_step_s)");
  }
  if (robot.imu.enabled && robot.imu.noise.rate_hz * physics_step_s > 1.0) {
    throw InputError(robot_key(file, index, "imu.rate_hz"),
                     std::to_string(robot.imu.noise.rate_hz) + " Hz exceeds the physics rate " +
                         std::to_string(1.0 / physics_step_s) + " Hz (physics_step_s)");
  }
  // IMU samples fall on physics steps: a period that is not a whole number of steps gives uneven gaps
  // (6, 3, 6, 6, 3 ms for 200 Hz at 3 ms steps) under a calibration that states one rate, and white noise
  // scaled for that rate. Cameras may be uneven (30 Hz at 1 ms steps): their stamps say when each image is.
  if (robot.imu.enabled && !imu_period_fits_steps(robot.imu.noise.rate_hz, physics_step_s)) {
    const double steps = 1.0 / (robot.imu.noise.rate_hz * physics_step_s);
    const double step_hz = 1.0 / physics_step_s;
    const double below = step_hz / std::ceil(steps);
    const double above = step_hz / std::max(1.0, std::floor(steps));
    throw InputError(robot_key(file, index, "imu.rate_hz"),
                     std::to_string(robot.imu.noise.rate_hz) + " Hz is not a whole number of physics steps (" +
                         std::to_string(physics_step_s) + " s): its samples would be unevenly spaced; take " +
                         std::to_string(below) + " or " + std::to_string(above) + " Hz, or another physics_step_s");
  }
  // IMU samples travel in the SensorFrame of the next camera image: without a camera none is ever
  // delivered, and they pile up for the whole run.
  if (robot.imu.enabled && !robot.camera.enabled) {
    throw InputError(robot_key(file, index, "imu.enabled"),
                     "IMU samples are delivered with camera frames; a robot with its camera off cannot have an IMU");
  }
  // The rig's calibration (EuRoC sensor.yaml, ORB-SLAM3 settings) needs positive noise figures: a zero
  // one makes an export that no reader takes. Exact measurements are noise_enabled: false.
  if (robot.imu.enabled) {
    const core::ImuNoise& noise = robot.imu.noise;
    const std::pair<const char*, double> figures[] = {{"imu.gyro_noise_density", noise.gyro_noise_density},
                                                      {"imu.gyro_random_walk", noise.gyro_random_walk},
                                                      {"imu.accel_noise_density", noise.accel_noise_density},
                                                      {"imu.accel_random_walk", noise.accel_random_walk}};
    for (const auto& [key, value] : figures) {
      if (!(value > 0.0)) {
        throw InputError(robot_key(file, index, key),
                         "must be positive (the exported calibration states it; for exact IMU measurements set "
                         "imu.noise_enabled: false)");
      }
    }
  }
  const DepthNoiseConfig& depth = robot.camera.depth_noise;
  if (!(depth.min_depth_m < depth.max_depth_m)) {
    throw InputError(robot_key(file, index, "camera.depth_noise.max_depth_m"),
                     "must exceed min_depth_m (" + std::to_string(depth.min_depth_m) + ")");
  }
  if (robot.imu.initial_gyro_bias_radps.size() != 3) {
    throw InputError(robot_key(file, index, "imu.initial_gyro_bias_radps"), "needs 3 entries (x, y, z)");
  }
  if (robot.imu.initial_accel_bias_mps2.size() != 3) {
    throw InputError(robot_key(file, index, "imu.initial_accel_bias_mps2"), "needs 3 entries (x, y, z)");
  }
}

// Robot names become MJCF names (an '&' broke the scene's XML) and folder names.
void check_name(const std::filesystem::path& file, std::size_t index, const std::string& name) {
  for (const char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
    if (!ok) {
      throw InputError(robot_key(file, index, "name"),
                       "robot name '" + name + "' may hold only letters, digits, '_' and '-'");
    }
  }
}

// Where a robot starts: a free rig at its first waypoint (its initial_pose is not used).
Eigen::Vector3d start_position(const RobotConfig& robot) {
  if (robot.type == RobotType::kFreeRig && !robot.waypoints.empty()) {
    const WaypointConfig& w = robot.waypoints.front();
    return {w.x, w.y, w.z};
  }
  return {robot.initial_pose.x, robot.initial_pose.y, robot.initial_pose.z};
}

void check_start_overlap(const std::filesystem::path& file, const ScenarioConfig& scenario) {
  for (std::size_t i = 0; i < scenario.robots.size(); ++i) {
    for (std::size_t j = i + 1; j < scenario.robots.size(); ++j) {
      const auto& a = scenario.robots[i];
      const auto& b = scenario.robots[j];
      const Eigen::Vector3d pa = start_position(a);
      const Eigen::Vector3d pb = start_position(b);
      const double distance = (pa - pb).norm();
      if (distance < a.radius_m + b.radius_m) {
        throw InputError(robot_key(file, j, "initial_pose"),
                         "robot '" + b.name + "' starts overlapping robot '" + a.name + "' (" +
                             std::to_string(distance) + " m apart, radii " + std::to_string(a.radius_m) + " + " +
                             std::to_string(b.radius_m) + " m)");
      }
    }
  }
}

}  // namespace

void refuse_scene_file(const std::filesystem::path& file) {
  if (file.extension() == ".xml") {
    throw InputError(file.string(), "is a MuJoCo scene (XML); give the scenario YAML that names it (scene: ...), "
                                    "e.g. the .yaml files beside it");
  }
}

ScenarioConfig load_scenario(const std::filesystem::path& file) {
  refuse_scene_file(file);
  ScenarioConfig scenario;
  core::ConfigReader reader = core::ConfigReader::from_file(file).section("");
  scenario.visit(reader);
  for (const char* key : kRunSections) reader.skip(key);
  reader.finish();
  validate_scenario(scenario, file);
  return scenario;
}

void validate_scenario(ScenarioConfig& scenario, const std::filesystem::path& file) {
  scenario.base_dir = file.parent_path();
  if (scenario.robots.empty()) throw InputError(file.string() + ":robots", "a scenario needs at least one robot");
  if (scenario.seed < 0 || scenario.seed > ScenarioConfig::kMaxSeed) {
    throw InputError(file.string() + ":seed", "must be in [0, " + std::to_string(ScenarioConfig::kMaxSeed) + "]");
  }
  std::set<std::string> names;
  for (std::size_t i = 0; i < scenario.robots.size(); ++i) {
    RobotConfig& robot = scenario.robots[i];
    if (robot.name.empty()) throw InputError(robot_key(file, i, "name"), "robot name is empty");
    check_name(file, i, robot.name);
    if (!names.insert(robot.name).second) {
      throw InputError(robot_key(file, i, "name"), "duplicate robot name '" + robot.name + "'");
    }
    check_waypoints(file, i, robot);
    check_unused_settings(file, i, robot);
    check_sensors(file, i, robot, scenario.physics_step_s);
    if (robot.seed < 0) robot.seed = derived_robot_seed(scenario.seed, i);
  }
  // Two robots with one seed draw the same noise: a seed of its own can equal another robot's derived one.
  std::map<std::int64_t, std::size_t> robot_of_seed;
  for (std::size_t i = 0; i < scenario.robots.size(); ++i) {
    const auto [it, inserted] = robot_of_seed.emplace(scenario.robots[i].seed, i);
    if (!inserted) {
      throw InputError(robot_key(file, i, "seed"),
                       "robot '" + scenario.robots[i].name + "' has seed " + std::to_string(scenario.robots[i].seed) +
                           ", as robot '" + scenario.robots[it->second].name +
                           "' has: their sensor noise would be identical (robots without a seed of their own get "
                           "seed * 1000 + index + 1)");
    }
  }
  check_start_overlap(file, scenario);
  if (!std::filesystem::is_regular_file(scenario.scene_path())) {
    throw InputError(file.string() + ":scene", "scene file '" + scenario.scene_path().string() + "' not found");
  }
}

}  // namespace fleetslam::sim
