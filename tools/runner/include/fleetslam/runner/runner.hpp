#pragma once
// The closed loop of `fleetslam run`: the simulated world renders every robot's sensors, one SLAM agent
// per robot tracks and maps, the central unit integrates their updates, merges their dense maps and (for
// planned missions) plans the ground robots' paths on the fused map, which go back to the robots'
// controllers; at the end everything is judged against the simulator's ground truth and the pass
// criteria. Called in a fixed order each camera tick, so a run in deterministic mode repeats bit for bit.
//
// Priors: each robot's initial-pose prior is its camera's true pose at its first frame; prior_error
// perturbs every robot but the first (the reference) by a known translation and yaw, so that the map
// merging has something to correct.
//
// Outputs (one folder):
//   scenario.yaml                   the effective run scenario (world, agent, central, planner, mission, criteria)
//   merged_map.ply, merge.json, <robot>/{map.ply,trajectory.txt,trajectory_robot.txt}   (central unit)
//   <robot>/groundtruth.txt         the camera's true poses at the frames
//   occupancy.pgm                   the last planning grid (white free, black occupied, grey unknown)
//   metrics.json                    per robot: ATE (world and se3), placement errors, map accuracy,
//                                   collisions, goals, mission events, timings; merged map accuracy and
//                                   completeness, coverage, real-time factor, and the verdict
//   report.html                     the same for a person (report_html.hpp)
//   run.log                         the run's log

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "fleetslam/core/log.hpp"
#include "fleetslam/runner/run_config.hpp"

namespace fleetslam::runner {

struct RunnerOptions {
  std::filesystem::path out = "run_out";
  std::string scenario_name;        // for the report (the scenario file's name)
  std::vector<double> prior_error;  // dx dy dz (m) yaw (deg) for robots after the first, or empty
  double truth_spacing_m = 0.01;    // spacing of the true-surface samples maps are judged against
  // 1: every agent processes its frame on this thread, in robot order. More: the robots' agents process
  // a camera tick's frames concurrently, on up to this many threads (throughput; with threaded agents the
  // run is not repeatable anyway).
  int threads = 1;
};

// What the progress display shows, about once per simulated second.
struct RunProgress {
  double simulated_s = 0.0;
  double duration_s = 0.0;
  double real_time_factor = 0.0;
  std::vector<std::string> robot_states;  // "alpha: tracking, to (2.80, 3.50), 3.1 m path"
};

struct RunOutcome {
  nlohmann::json metrics;
  bool passed = true;  // metrics["verdict"]["passed"]
};

class Runner {
 public:
  using ProgressSink = std::function<void(const RunProgress&)>;

  // Throws InputError for a prior_error that is not 4 numbers or an output folder that cannot be made.
  Runner(RunScenarioConfig config, RunnerOptions options, core::Logger logger);

  // Runs the scenario to its end and writes the outputs. Throws InputError for a bad scene or agent
  // setup (before anything moves); everything that goes wrong during the run (lost tracking, no path,
  // collisions) is in the metrics and the verdict instead.
  RunOutcome run(const ProgressSink& progress = {});

 private:
  RunScenarioConfig config_;
  RunnerOptions options_;
  core::Logger logger_;
};

}  // namespace fleetslam::runner
