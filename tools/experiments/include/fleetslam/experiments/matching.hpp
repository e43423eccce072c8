#pragma once
// Paper Table 1 in kind (PAPER.md section 2): the time of one match between adjacent frames and its
// quality against ground truth, per sequence, feature count and matcher.
//   Pairs: `pairs` adjacent frame pairs (k, k+1) spread evenly over the sequence's first max_frames frames
//   (the paper's "match A..D"), features from the agent's own front end (slam::FrameBuilder, the
//   sequence's ORB settings with num_features replaced). The projection matchers get the constant-velocity
//   prediction an ORB-SLAM tracker makes, from the ground truth: T_A_B = T_(k-1)_k.
//   Time: each matcher runs `repetitions` times per pair, each call timed alone (single-threaded OpenCV);
//   the grid and cross-validation matchers interleaved (alternating which goes first) so that their
//   ratio does not depend on the machine's slow spells; mean and median over every call of every pair.
//   Quality: matches, precision and recall (matchers.hpp) summed over the pairs.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "fleetslam/core/log.hpp"
#include "fleetslam/experiments/matchers.hpp"
#include "fleetslam/experiments/sequences.hpp"
#include "fleetslam/experiments/table.hpp"

namespace fleetslam::experiments {

struct MatchingConfig {
  std::vector<int> features = {250, 1000, 2000};
  int repetitions = 100;
  int pairs = 4;
  std::int64_t max_frames = -1;  // pairs are picked among the first max_frames frames (-1: all)
  double correct_px = 3.0;
  MatchSettings settings;
  // The matchers to run (each at most once; rows and tables keep all_matchers' order). Timing grid and
  // cross_validation alone is the quick way to their ratio.
  std::vector<MatcherKind> matchers = all_matchers();
};

struct MatchingRow {
  std::string sequence;
  std::string origin;
  int features = 0;       // asked for
  MatcherKind matcher = MatcherKind::kGrid;
  int pairs = 0;
  double features_a_mean = 0.0;  // extracted (ORB may find fewer)
  double features_b_mean = 0.0;
  MatchQuality quality;
  double mean_ms = 0.0;    // timing
  double median_ms = 0.0;  // timing
};

struct MatchingResult {
  MatchingConfig config;
  std::vector<MatchingRow> rows;
};

class MatchingExperiment {
 public:
  // Throws InputError for bad settings (empty feature list, counts out of range, no matcher or one twice).
  MatchingExperiment(const MatchingConfig& config, core::Logger logger);
  // Throws InputError for a sequence that cannot be read or has too few frames with ground truth.
  MatchingResult run(const std::vector<SequenceSpec>& sequences) const;

 private:
  MatchingConfig config_;
  core::Logger logger_;
};

// matching.csv (every row; mean_ms and median_ms are the timing columns), matching.md (a table per
// sequence: median ms, matches, precision and recall per matcher and feature count, and what
// cross-validation adds to the grid matcher's median time),
// matching_time_<sequence>.svg and matching_precision_<sequence>.svg. Returns the files written.
std::vector<std::filesystem::path> write_matching_outputs(const MatchingResult& result, const std::filesystem::path& dir);

Table matching_table(const MatchingResult& result);

// Sequence names as file-name parts ("tum/rgbd_x" -> "tum_rgbd_x").
std::string file_stem(const std::string& sequence);

}  // namespace fleetslam::experiments
