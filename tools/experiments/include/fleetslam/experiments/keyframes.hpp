#pragma once
// Paper Table 2 and Fig. 7 in kind (PAPER.md section 3): the ATE of each keyframe policy on each
// sequence. One agent per run over the sequence's first max_frames frames with the sequence's replay
// config and keyframes.policy set (the exponential policy with the agent's defaults); the ATE after SE(3)
// alignment as `fleetslam replay` computes it. `runs` runs per (sequence, policy): in deterministic mode
// (the default) run r sets loop_closing.seed = r, the agent's one seed (its RANSAC draws), so runs differ
// only where a loop closing draws; `threaded` runs the agent's threaded mode instead, whose runs vary with
// the scheduling (and whose outputs are then not repeatable). Each statistic (max, median, RMSE, std) is
// averaged over the runs with its largest and smallest value dropped, as the paper does.
// Fig. 7: the cumulative RMSE and std of the ATE over time (errors of the first t seconds, after the
// whole run's alignment) for the run whose RMSE is the median of its runs.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "fleetslam/core/log.hpp"
#include "fleetslam/core/trajectory_metrics.hpp"
#include "fleetslam/experiments/sequences.hpp"
#include "fleetslam/experiments/table.hpp"
#include "fleetslam/slam/keyframe_policy.hpp"

namespace fleetslam::experiments {

std::string to_string(slam::KeyframePolicyKind policy);  // "orbslam3", "exponential", "fixed_interval"

struct KeyframesConfig {
  std::vector<slam::KeyframePolicyKind> policies = {slam::KeyframePolicyKind::kOrbslam3,
                                                    slam::KeyframePolicyKind::kExponential,
                                                    slam::KeyframePolicyKind::kFixedInterval};
  int runs = 10;
  bool threaded = false;  // frames then come at their own rate (real-time playback)
  std::int64_t max_frames = -1;
};

struct KeyframeRun {
  int run = 0;
  std::int64_t seed = 0;
  std::size_t frames = 0;
  std::size_t tracked = 0;
  std::size_t keyframes_inserted = 0;  // decisions to insert
  std::size_t keyframes = 0;           // left in the map at the end
  bool ate_ok = false;
  core::ErrorStats ate;                // metres
  std::vector<double> t_s;             // per ATE pair: seconds since the first pair
  std::vector<double> errors_m;
  double seconds = 0.0;                // timing
};

struct KeyframesRow {
  std::string sequence;
  std::string origin;
  slam::KeyframePolicyKind policy = slam::KeyframePolicyKind::kExponential;
  std::vector<KeyframeRun> runs;
  // Over the runs with an ATE: trimmed means (extremes dropped).
  int runs_with_ate = 0;
  int distinct_results = 0;  // different RMSE values among the runs (1: the runs agree bit for bit)
  double max_m = 0.0, median_m = 0.0, rmse_m = 0.0, std_m = 0.0;
  double keyframes_mean = 0.0, inserted_mean = 0.0, tracked_mean = 0.0;
  std::size_t median_run = 0;  // index into runs of the median-RMSE run (Fig. 7)
};

struct KeyframesResult {
  KeyframesConfig config;
  std::vector<KeyframesRow> rows;
};

class KeyframesExperiment {
 public:
  // Throws InputError for bad settings (no policy, runs < 1).
  KeyframesExperiment(const KeyframesConfig& config, core::Logger logger);
  KeyframesResult run(const std::vector<SequenceSpec>& sequences) const;

 private:
  KeyframeRun run_once(const SequenceSpec& spec, slam::KeyframePolicyKind policy, int run) const;

  KeyframesConfig config_;
  core::Logger logger_;
};

Table keyframes_table(const KeyframesResult& result);       // one row per (sequence, policy)
Table keyframes_runs_table(const KeyframesResult& result);  // one row per run (seconds: the timing column)

// "tracked / frames": the frames tracked, averaged over the runs (the ATE covers those), of the sequence's.
std::string tracked_share(const KeyframesRow& row);

// keyframes.csv, keyframes_runs.csv, keyframes.md, cumulative_ate_rmse_<sequence>.svg and
// cumulative_ate_std_<sequence>.svg (Fig. 7). Returns the files written.
std::vector<std::filesystem::path> write_keyframes_outputs(const KeyframesResult& result,
                                                           const std::filesystem::path& dir);

}  // namespace fleetslam::experiments
