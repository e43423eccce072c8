// Reading a run scenario (run_config.hpp).

#include "fleetslam/runner/run_config.hpp"

#include <string>

#include "fleetslam/core/error.hpp"

namespace fleetslam::runner {

RunScenarioConfig load_run_scenario(const std::filesystem::path& file, std::optional<std::int64_t> seed) {
  sim::refuse_scene_file(file);
  RunScenarioConfig config = core::load_config<RunScenarioConfig>(file);
  if (seed) {
    config.world.seed = *seed;
  }
  sim::validate_scenario(config.world, file);
  for (std::size_t i = 0; i < config.world.robots.size(); ++i) {
    if (!config.world.robots[i].camera.enabled) {
      throw InputError(file.string() + ":robots[" + std::to_string(i) + "].camera.enabled",
                       "robot '" + config.world.robots[i].name +
                           "' has no camera: every robot of a run carries a SLAM agent, which tracks with it");
    }
  }
  if (config.mission.kind != MissionKind::kScripted) {
    bool ground = false;
    for (const sim::RobotConfig& robot : config.world.robots) ground = ground || robot.type == sim::RobotType::kDiffDrive;
    if (!ground) throw InputError(file.string() + ":mission.kind", "a planned mission needs at least one diff_drive robot");
  }
  if (config.planner.deconfliction.separation_m < 2.0 * config.planner.grid.robot_radius_m - 1e-9) {
    throw InputError(file.string() + ":planner.deconfliction.separation_m", "must be at least twice planner.grid.robot_radius_m");
  }
  return config;
}

}  // namespace fleetslam::runner
