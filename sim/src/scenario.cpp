#include "fleetslam/sim/scenario.hpp"

#include <cmath>
#include <set>
#include <string>

#include "fleetslam/core/error.hpp"

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
  for (std::size_t k = 1; k < robot.waypoints.size(); ++k) {
    if (!(robot.waypoints[k].t_s > robot.waypoints[k - 1].t_s)) {
      throw InputError(robot_key(file, index, "waypoints[" + std::to_string(k) + "].t_s"),
                       "waypoint times must increase");
    }
  }
}

void check_start_overlap(const std::filesystem::path& file, const ScenarioConfig& scenario) {
  for (std::size_t i = 0; i < scenario.robots.size(); ++i) {
    for (std::size_t j = i + 1; j < scenario.robots.size(); ++j) {
      const auto& a = scenario.robots[i];
      const auto& b = scenario.robots[j];
      const double distance = std::hypot(a.initial_pose.x - b.initial_pose.x, a.initial_pose.y - b.initial_pose.y,
                                         a.initial_pose.z - b.initial_pose.z);
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

ScenarioConfig load_scenario(const std::filesystem::path& file) {
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
    if (!names.insert(robot.name).second) {
      throw InputError(robot_key(file, i, "name"), "duplicate robot name '" + robot.name + "'");
    }
    check_waypoints(file, i, robot);
    if (robot.seed < 0) robot.seed = scenario.seed * 1000 + static_cast<std::int64_t>(i) + 1;
  }
  check_start_overlap(file, scenario);
  if (!std::filesystem::is_regular_file(scenario.scene_path())) {
    throw InputError(file.string() + ":scene", "scene file '" + scenario.scene_path().string() + "' not found");
  }
}

}  // namespace fleetslam::sim
