#pragma once
// Subcommands of the `fleetslam` CLI. Each registers itself on the app and runs from its callback;
// failures throw (fleetslam::InputError for bad input), and main prints one line and exits non-zero.

#include <stdexcept>
#include <string>

#include <CLI/CLI.hpp>

namespace fleetslam::tools {

// A command that ran to its end but whose outcome failed its pass criteria (fleetslam run): main prints
// the message and exits 1 (bad input exits 2, internal errors 3).
struct CriteriaFailed : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// --format of a recorded sequence (replay, dataset, vocab): tum_rgbd, euroc or tumvi, with `tum` taken
// for tum_rgbd, as `generate` and `eval` name it.
inline CLI::Validator dataset_format_check() {
  return CLI::Validator(
      [](std::string& format) -> std::string {
        if (format == "tum") format = "tum_rgbd";
        if (format == "tum_rgbd" || format == "euroc" || format == "tumvi") return {};
        return "'" + format + "' is no dataset layout: tum_rgbd (or tum), euroc or tumvi";
      },
      "{tum_rgbd,tum,euroc,tumvi}");
}

// Options shared by every command.
struct GlobalOptions {
  bool verbose = false;
  bool quiet = false;
};

// fleetslam eval --gt G --est E [--align se3|sim3|none] [--format tum|euroc|kitti] [--out DIR]
void add_eval_command(CLI::App& app, const GlobalOptions& global);

// fleetslam dataset info|convert ...: inspect a TUM RGB-D / EuRoC / TUM-VI sequence, or rewrite it in
// another of those formats.
void add_dataset_command(CLI::App& app, const GlobalOptions& global);

// fleetslam generate SCENARIO.yaml --format tum|euroc --out DIR [--duration S] [--robots a,b]: run a
// scenario and write each robot's stream as a sequence in DIR/<robot>/ with its ORB-SLAM3 settings.
void add_generate_command(CLI::App& app, const GlobalOptions& global);

// fleetslam replay DATASET [--format tum_rgbd|euroc|tumvi] [--sensor rgbd|stereo] [--config C.yaml]
// [--calibration ORB-SLAM.yaml] [--groundtruth G] [--out DIR] [--max-frames N]: run one SLAM agent over
// a recorded sequence; write its trajectories, timings, keyframe decisions, config and ATE to DIR.
void add_replay_command(CLI::App& app, const GlobalOptions& global);

// fleetslam vocab train --images DIR... | --dataset DIR... --out FILE [--k 10 --levels 5 --features 1000
// --max-images N --seed S]: train a bag-of-words vocabulary from ORB features; fleetslam vocab info FILE.
void add_vocab_command(CLI::App& app, const GlobalOptions& global);

// fleetslam run SCENARIO.yaml [--out DIR] [--seed N] [--duration S] [--threads N] [--agent-config C]
// [--central-config C] [--prior-error dx dy dz yaw_deg]: world, agents, central unit and planner in
// lockstep, judged against ground truth and the scenario's pass criteria (CriteriaFailed when one fails).
void add_run_command(CLI::App& app, const GlobalOptions& global);

// fleetslam experiment matching|keyframes|sampling|all [--out DIR] [--tum DIR] [--euroc DIR] [--scenario F]
// [--frames N] [--repetitions N] [--runs N] [--features 250,1000,2000] [--doc FILE]: the paper's Tables 1-3
// and Fig. 7 as CSV, Markdown and SVG (tools/experiments/); `all --doc` writes the results document.
void add_experiment_command(CLI::App& app, const GlobalOptions& global);

}  // namespace fleetslam::tools
