#pragma once
// Paper Table 3 in kind (PAPER.md sections 4-5): the merged dense map's points before and after uniform
// sampling in multi-robot runs. Each robot is one agent over its part of the data, its first
// ground-truth pose its initial-pose prior; the central unit (central::Server, its MapMerger) merges their
// dense maps, as `fleetslam replay --split` does.
//   real sequence: its first max_frames frames split into `split` consecutive parts, one per robot
//                  (replay --split);
//   scenario:      each rendered robot's own sequence (first max_frames frames) as one robot.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "fleetslam/central/server.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/experiments/sequences.hpp"
#include "fleetslam/experiments/table.hpp"

namespace fleetslam::experiments {

struct SamplingConfig {
  int split = 2;                  // robots a real sequence is split into
  std::int64_t max_frames = -1;   // per sequence (-1: all)
  central::ServerConfig central;  // defaults: the central unit's
};

// A robot of a multi-robot run: frames [start, stop) of a sequence.
struct RobotPart {
  std::string name;
  SequenceSpec sequence;
  std::int64_t start = 0;
  std::int64_t stop = -1;
};

struct SamplingRow {
  std::string dataset;  // a real sequence's name, or a scenario's stem
  std::string origin;
  std::string mode;     // "split" or "robots"
  int robots = 0;
  std::size_t frames = 0;
  double duration_s = 0.0;  // the time all robots' frames span: a split sequence's whole length
  std::size_t points_before = 0;
  std::size_t points_after = 0;
  std::size_t points_after_filter = 0;
  int registered = 0;                // robots whose prior fine registration refined
  std::vector<double> robot_ate_m;   // per robot: ATE RMSE in the world frame (no alignment; NaN without)
  double reduction_percent() const;  // 100 * (before - after) / before
  double seconds = 0.0;              // timing
};

struct SamplingResult {
  SamplingConfig config;
  std::vector<SamplingRow> rows;
};

class SamplingExperiment {
 public:
  // Throws InputError for bad settings (split outside [2, 26]).
  SamplingExperiment(const SamplingConfig& config, core::Logger logger);
  // Real sequences are split; synthetic ones are grouped by scenario, each robot one part.
  SamplingResult run(const std::vector<SequenceSpec>& sequences) const;
  // One multi-robot run (every part's first frame needs a ground-truth pose: InputError otherwise).
  SamplingRow run_robots(const std::vector<RobotPart>& parts) const;

 private:
  SamplingConfig config_;
  core::Logger logger_;
};

Table sampling_table(const SamplingResult& result);
// sampling.csv, sampling.md, sampling_points.svg. Returns the files written.
std::vector<std::filesystem::path> write_sampling_outputs(const SamplingResult& result, const std::filesystem::path& dir);

}  // namespace fleetslam::experiments
