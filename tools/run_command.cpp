// fleetslam run: the whole multi-robot system in lockstep: the simulated world renders every robot's
// sensors, one SLAM agent per robot tracks and maps, the central unit integrates their updates, and at
// the end merges their dense maps and fuses their trajectories; everything is judged against the
// simulator's ground truth. Robots follow their scenario waypoints (OMPL planning on the fused map comes
// with the planners module).
//
// Priors: each robot's initial-pose prior is its camera's true pose at its first frame; --prior-error
// perturbs every robot but the first (the reference) by a known translation and yaw, so that the map
// merging has something to correct, as in the target experiment.
//
//   DIR/scenario.yaml, agent_config.yaml, central_config.yaml   the effective configs
//   DIR/merged_map.ply, merge.json, <robot>/{map.ply,trajectory.txt,trajectory_robot.txt}   (central)
//   DIR/<robot>/groundtruth.txt            the camera's true poses at the frames
//   DIR/metrics.json                       per robot: ATE in the world frame and after se3 alignment,
//                                          prior and refined inter-robot alignment errors; merged map
//                                          accuracy and completeness; counts, timings, real-time factor


#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <spdlog/logger.h>

#include "cli_util.hpp"
#include "commands.hpp"
#include "fleetslam/central/link.hpp"
#include "fleetslam/central/map_evaluation.hpp"
#include "fleetslam/central/server.hpp"
#include "fleetslam/core/config.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/core/se3.hpp"
#include "fleetslam/core/trajectory.hpp"
#include "fleetslam/core/trajectory_metrics.hpp"
#include "fleetslam/sim/scenario.hpp"
#include "fleetslam/sim/world.hpp"
#include "fleetslam/slam/agent.hpp"

namespace fleetslam::tools {
namespace {

namespace fs = std::filesystem;

struct RunOptions {
  std::string scenario;
  std::string out = "run_out";
  std::optional<std::int64_t> seed;
  std::optional<double> duration_s;
  std::string agent_config;
  std::string central_config;
  std::vector<double> prior_error;  // dx dy dz (m) yaw (deg), applied to robots after the first
  double truth_spacing_m = 0.01;
  std::string vocabulary;  // place_recognition.vocabulary of every agent; empty: the config's
};

// The prior of a robot whose true first camera pose is T_true: shifted by (dx, dy, dz) in the world and
// turned by yaw about the world's vertical through the camera (so the error is what it says it is).
Eigen::Isometry3d perturbed_prior(const Eigen::Isometry3d& T_true, const std::vector<double>& e) {
  if (e.empty()) return T_true;
  Eigen::Isometry3d T = T_true;
  T.translation() += Eigen::Vector3d(e[0], e[1], e[2]);
  T.linear() = Eigen::AngleAxisd(e[3] * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix() * T_true.linear();
  return T;
}

nlohmann::json alignment_error_json(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth) {
  return {{"translation_m", (estimate.translation() - truth.translation()).norm()},
          {"rotation_deg", core::rotation_angle_rad(estimate.linear().transpose() * truth.linear()) * 180.0 / M_PI}};
}

nlohmann::json accuracy_json(const central::MapAccuracy& a) {
  return {{"map_points", a.map_points}, {"truth_points", a.truth_points}, {"far_points", a.far_points},
          {"mean_m", a.mean_m}, {"median_m", a.median_m}, {"p95_m", a.p95_m}, {"completeness", a.completeness}};
}

struct RobotRun {
  std::string name;
  std::unique_ptr<slam::Agent> agent;
  core::Trajectory groundtruth;
  std::optional<Eigen::Isometry3d> T_world_robot_true;  // the camera's true pose at its first frame
  Eigen::Isometry3d T_world_robot_prior = Eigen::Isometry3d::Identity();
  std::size_t frames = 0;
  std::size_t tracked = 0;
  std::size_t lost = 0;
  std::size_t relocalizations = 0;
  nlohmann::json loops = nlohmann::json::array();
};

void run_scenario(const RunOptions& o, const GlobalOptions& global) {
  const core::Logger logger = make_cli_logger("run", global);
  sim::ScenarioConfig scenario = sim::load_scenario(o.scenario);
  if (o.seed) scenario.seed = *o.seed;
  if (o.duration_s) scenario.duration_s = *o.duration_s;
  slam::AgentConfig agent_config = read_config_file<slam::AgentConfig>(o.agent_config);
  if (!o.vocabulary.empty()) {
    agent_config.place_recognition.vocabulary = o.vocabulary;
    slam::load_place_vocabulary(agent_config.place_recognition);  // a bad file fails before the world is built
  }
  const central::ServerConfig central_config = read_config_file<central::ServerConfig>(o.central_config);
  if (!o.prior_error.empty() && o.prior_error.size() != 4) {
    throw InputError("--prior-error", "needs 4 values: dx dy dz (m) yaw (deg)");
  }
  const fs::path out = o.out;
  std::error_code ec;
  fs::create_directories(out, ec);
  if (ec) throw InputError(o.out, "cannot create the output folder: " + ec.message());
  write_text_file(out / "scenario.yaml", core::config_to_yaml(scenario));
  write_text_file(out / "agent_config.yaml", core::config_to_yaml(agent_config));
  write_text_file(out / "central_config.yaml", core::config_to_yaml(central_config));

  sim::World world(scenario, logger);
  central::Server server(central_config, logger);
  central::InProcessLink link;
  std::vector<RobotRun> robots(world.robot_count());
  for (std::size_t r = 0; r < robots.size(); ++r) {
    robots[r].name = world.robot_config(r).name;
    robots[r].agent = std::make_unique<slam::Agent>(agent_config, world.sensor_rig(r), logger);
  }
  const auto wall_start = std::chrono::steady_clock::now();  // reported only (real-time factor)
  core::Progress progress =
      make_progress(static_cast<std::size_t>(std::max<core::TimeNs>(world.end_ns() / 1000000, 1)), "simulated ms", logger);
  while (!world.finished()) {
    for (core::SensorFrame& frame : world.step()) {
      RobotRun& robot = robots.at(static_cast<std::size_t>(frame.robot_id));
      if (!robot.T_world_robot_true) {
        FLEETSLAM_CHECK(frame.T_world_cam_gt.has_value(), "simulated frames carry ground truth");
        robot.T_world_robot_true = *frame.T_world_cam_gt;
        robot.T_world_robot_prior =
            frame.robot_id == 0 ? *frame.T_world_cam_gt : perturbed_prior(*frame.T_world_cam_gt, o.prior_error);
        server.add_robot(central::RobotSpec{frame.robot_id, robot.name, robot.T_world_robot_prior});
      }
      if (frame.T_world_cam_gt) robot.groundtruth.push_back({frame.t_ns, *frame.T_world_cam_gt});
      slam::AgentUpdate update = robot.agent->process(frame);
      ++robot.frames;
      robot.tracked += update.has_pose() ? 1 : 0;
      robot.lost += update.status == slam::FrameStatus::kLost ? 1 : 0;
      robot.relocalizations += update.relocalized ? 1 : 0;
      for (const slam::LoopEvent& loop : update.loops) robot.loops.push_back(loop_event_json(loop));
      link.send(std::move(update));
    }
    server.integrate_all(link);
    progress.update(static_cast<std::size_t>(world.time_ns() / 1000000));
  }
  progress.finish();
  for (RobotRun& robot : robots) robot.agent->finish();
  server.integrate_all(link);
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();

  const central::ServerMergeReport& report = server.merge();
  server.write_outputs(out);
  const std::vector<Eigen::Vector3f> truth = world.surface_points(o.truth_spacing_m);
  const central::MapAccuracy merged_accuracy = central::evaluate_map(report.merge.cloud_world, truth);

  nlohmann::json robots_json = nlohmann::json::array();
  for (std::size_t r = 0; r < robots.size(); ++r) {
    RobotRun& robot = robots[r];
    const int id = static_cast<int>(r);
    nlohmann::json entry = {{"name", robot.name}, {"frames", robot.frames}, {"tracked", robot.tracked}, {"lost", robot.lost},
                            {"relocalizations", robot.relocalizations}, {"loops", robot.loops}};
    if (!robot.T_world_robot_true) {
      robots_json.push_back(entry);
      continue;
    }
    core::write_trajectory(out / robot.name / "groundtruth.txt", robot.groundtruth, core::TrajectoryFormat::kTum);
    const core::Trajectory world_trajectory = server.world_trajectory(id);
    for (const auto& [mode, key] : {std::pair{core::AlignmentMode::kNone, "ate_world_m"}, std::pair{core::AlignmentMode::kSe3, "ate_se3_m"}}) {
      const core::AteResult ate = core::compute_ate(robot.groundtruth, world_trajectory,
                                                    core::associate_by_time(robot.groundtruth, world_trajectory), mode);
      if (ate.ok()) entry[key] = {{"rmse", ate.stats.rmse}, {"mean", ate.stats.mean}, {"max", ate.stats.max}};
    }
    for (const central::RobotFusionReport& fused : report.robots) {
      if (fused.robot_id != id) continue;
      entry["merge_status"] = fused.merge_status;
      entry["prior_error"] = alignment_error_json(robot.T_world_robot_prior, *robot.T_world_robot_true);
      entry["refined_error"] = alignment_error_json(fused.T_world_robot, *robot.T_world_robot_true);
      entry["map_accuracy"] = accuracy_json(
          central::evaluate_map(core::transformed(server.robot_cloud(id), fused.T_world_robot), truth));
    }
    robots_json.push_back(entry);
  }
  const double sim_s = core::ns_to_seconds(world.time_ns());
  const nlohmann::json metrics = {{"command", "fleetslam run"}, {"scenario", o.scenario}, {"seed", scenario.seed},
                                  {"simulated_s", sim_s}, {"wall_s", wall_s},
                                  {"real_time_factor", wall_s > 0.0 ? sim_s / wall_s : 0.0},
                                  {"prior_error", o.prior_error}, {"robots", robots_json},
                                  {"merged_map_accuracy", accuracy_json(merged_accuracy)},
                                  {"merge", central::to_json(report.merge)}};
  write_text_file(out / "metrics.json", metrics.dump(2) + "\n");
  if (global.quiet) return;
  for (const nlohmann::json& entry : robots_json) {
    std::printf("%-10s %zu frames, tracked %zu", entry["name"].get<std::string>().c_str(), entry["frames"].get<std::size_t>(),
                entry["tracked"].get<std::size_t>());
    if (entry.contains("ate_world_m")) std::printf(", ATE world %.4f m", entry["ate_world_m"]["rmse"].get<double>());
    if (entry.contains("refined_error")) {
      std::printf(", placed to %.4f m / %.3f deg (prior %.4f m / %.3f deg)", entry["refined_error"]["translation_m"].get<double>(),
                  entry["refined_error"]["rotation_deg"].get<double>(), entry["prior_error"]["translation_m"].get<double>(),
                  entry["prior_error"]["rotation_deg"].get<double>());
    }
    std::printf("\n");
  }
  std::printf("merged map: %zu points (%zu before sampling), accuracy mean %.4f m, p95 %.4f m, completeness %.1f %%\n",
              report.merge.cloud_world.size(), report.merge.points_before_sampling, merged_accuracy.mean_m,
              merged_accuracy.p95_m, 100.0 * merged_accuracy.completeness);
  std::printf("time:       %.1f s simulated in %.1f s (real-time factor %.2f)\n", sim_s, wall_s, wall_s > 0.0 ? sim_s / wall_s : 0.0);
  std::printf("wrote:      %s/{metrics.json,merged_map.ply,merge.json,<robot>/...}\n", out.string().c_str());
}

}  // namespace

void add_run_command(CLI::App& app, const GlobalOptions& global) {
  auto options = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand(
      "run", "Run a scenario with the whole system in lockstep (world, one agent per robot, central unit) and judge "
             "it against ground truth");
  cmd->add_option("scenario", options->scenario, "Scenario YAML file")->required();
  cmd->add_option("--out", options->out, "Output folder")->capture_default_str();
  cmd->add_option("--seed", options->seed, "Seed (default: the scenario's)");
  cmd->add_option("--duration", options->duration_s, "Seconds to simulate (default: the scenario's)")->check(CLI::PositiveNumber);
  cmd->add_option("--agent-config", options->agent_config, "Agent config YAML for every robot");
  cmd->add_option("--central-config", options->central_config, "Central unit config YAML");
  cmd->add_option("--vocabulary", options->vocabulary,
                  "Vocabulary file for every agent's place recognition (binary or DBoW2 text; default: the "
                  "config's, else the shipped one)");
  cmd->add_option("--prior-error", options->prior_error,
                  "Error added to the initial-pose prior of every robot but the first: dx dy dz (m) yaw (deg)")
      ->expected(4);
  cmd->add_option("--truth-spacing", options->truth_spacing_m, "Spacing of the true-surface samples maps are judged against (m)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->callback([options, &global] { run_scenario(*options, global); });
}

}  // namespace fleetslam::tools
