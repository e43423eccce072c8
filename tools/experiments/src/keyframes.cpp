#include "fleetslam/experiments/keyframes.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <set>
#include <thread>

#include <spdlog/logger.h>

#include "fleetslam/core/error.hpp"
#include "fleetslam/experiments/matching.hpp"
#include "fleetslam/experiments/svg_plot.hpp"
#include "fleetslam/slam/agent.hpp"

namespace fleetslam::experiments {
namespace {

namespace fs = std::filesystem;

// Cumulative RMSE and std of errors[0..i] for every i.
void cumulative(const std::vector<double>& errors, std::vector<double>& rmse, std::vector<double>& std_dev) {
  double sum = 0.0, sum_sq = 0.0;
  for (std::size_t i = 0; i < errors.size(); ++i) {
    sum += errors[i];
    sum_sq += errors[i] * errors[i];
    const double n = static_cast<double>(i + 1);
    const double mean = sum / n;
    rmse.push_back(std::sqrt(sum_sq / n));
    std_dev.push_back(std::sqrt(std::max(0.0, sum_sq / n - mean * mean)));
  }
}

void summarise(KeyframesRow& row) {
  std::vector<double> max, median, rmse, std_dev, keyframes, inserted, tracked;
  std::set<double> distinct;
  for (const KeyframeRun& run : row.runs) {
    keyframes.push_back(static_cast<double>(run.keyframes));
    inserted.push_back(static_cast<double>(run.keyframes_inserted));
    tracked.push_back(static_cast<double>(run.tracked));
    if (!run.ate_ok) continue;
    max.push_back(run.ate.max);
    median.push_back(run.ate.median);
    rmse.push_back(run.ate.rmse);
    std_dev.push_back(run.ate.std);
    distinct.insert(run.ate.rmse);
  }
  row.runs_with_ate = static_cast<int>(rmse.size());
  row.distinct_results = static_cast<int>(distinct.size());
  row.max_m = trimmed_mean(max);
  row.median_m = trimmed_mean(median);
  row.rmse_m = trimmed_mean(rmse);
  row.std_m = trimmed_mean(std_dev);
  row.keyframes_mean = mean_of(keyframes);
  row.inserted_mean = mean_of(inserted);
  row.tracked_mean = mean_of(tracked);
  // The median-RMSE run: the lower middle of the runs with an ATE sorted by RMSE (first run on ties).
  std::vector<std::size_t> order;
  for (std::size_t i = 0; i < row.runs.size(); ++i) {
    if (row.runs[i].ate_ok) order.push_back(i);
  }
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return row.runs[a].ate.rmse < row.runs[b].ate.rmse; });
  row.median_run = order.empty() ? 0 : order[(order.size() - 1) / 2];
}

}  // namespace

std::string to_string(slam::KeyframePolicyKind policy) {
  switch (policy) {
    case slam::KeyframePolicyKind::kOrbslam3: return "orbslam3";
    case slam::KeyframePolicyKind::kExponential: return "exponential";
    case slam::KeyframePolicyKind::kFixedInterval: return "fixed_interval";
  }
  return "unknown";
}

KeyframesExperiment::KeyframesExperiment(const KeyframesConfig& config, core::Logger logger)
    : config_(config), logger_(std::move(logger)) {
  if (config_.policies.empty()) throw InputError("--policies", "give at least one keyframe policy");
  if (config_.runs < 1) throw InputError("--runs", "must be at least 1");
}

KeyframeRun KeyframesExperiment::run_once(const SequenceSpec& spec, slam::KeyframePolicyKind policy, int run) const {
  slam::AgentConfig config = agent_config_for(spec);
  config.keyframes.policy = policy;
  config.threaded = config_.threaded;
  config.loop_closing.seed = run;
  KeyframeRun result;
  result.run = run;
  result.seed = config.loop_closing.seed;
  const auto start = std::chrono::steady_clock::now();
  const auto source = open_sequence(spec, 0, config_.max_frames, logger_);
  slam::Agent agent(config, source->rig(), core::null_logger());
  core::Trajectory per_frame_gt;
  // Threaded: the frames come at their own rate (real-time playback, as ORB-SLAM3's examples feed them).
  // Fed as fast as tracking runs, local mapping lags behind, and the orbslam3 policy, which waits for it,
  // was held back where the exponential policy, which does not, was not. A frame late already is not
  // waited for.
  std::optional<core::TimeNs> first_t_ns;
  std::chrono::steady_clock::time_point playback_start;
  while (std::optional<core::SensorFrame> frame = source->next()) {
    if (config_.threaded) {
      if (!first_t_ns) {
        first_t_ns = frame->t_ns;
        playback_start = std::chrono::steady_clock::now();
      } else {
        std::this_thread::sleep_until(playback_start + std::chrono::nanoseconds(frame->t_ns - *first_t_ns));
      }
    }
    const slam::AgentUpdate update = agent.process(*frame);
    ++result.frames;
    result.tracked += update.has_pose() ? 1 : 0;
    result.keyframes_inserted += update.keyframe_decision && update.keyframe_decision->insert ? 1 : 0;
    if (frame->T_world_cam_gt) per_frame_gt.push_back({frame->t_ns, *frame->T_world_cam_gt});
  }
  agent.finish();
  const core::Trajectory estimate = agent.trajectory();
  result.keyframes = agent.map_stats().keyframes;
  const core::Trajectory gt = groundtruth_for(spec, *source, per_frame_gt);
  const core::AteResult ate =
      core::compute_ate(gt, estimate, core::associate_by_time(gt, estimate), core::AlignmentMode::kSe3);
  result.ate_ok = ate.measured();
  if (result.ate_ok) {
    result.ate = ate.stats;
    result.errors_m = ate.errors_m;
    for (const core::TimeNs t : ate.t_ns) result.t_s.push_back(core::ns_to_seconds(t - ate.t_ns.front()));
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

KeyframesResult KeyframesExperiment::run(const std::vector<SequenceSpec>& sequences) const {
  KeyframesResult result;
  result.config = config_;
  for (const SequenceSpec& spec : sequences) {
    for (const slam::KeyframePolicyKind policy : config_.policies) {
      KeyframesRow row;
      row.sequence = spec.name;
      row.origin = spec.origin;
      row.policy = policy;
      for (int r = 0; r < config_.runs; ++r) {
        row.runs.push_back(run_once(spec, policy, r));
        const KeyframeRun& last = row.runs.back();
        logger_->info("keyframes {} {} run {}/{}: {} keyframes, ATE RMSE {} m ({:.1f} s)", spec.name, to_string(policy),
                      r + 1, config_.runs, last.keyframes, last.ate_ok ? fixed(last.ate.rmse, 4) : "none", last.seconds);
      }
      summarise(row);
      result.rows.push_back(std::move(row));
    }
  }
  return result;
}

Table keyframes_table(const KeyframesResult& result) {
  Table table;
  table.header = {"sequence", "origin", "policy", "runs", "runs_with_ate", "distinct_results", "ate_max_m",
                  "ate_median_m", "ate_rmse_m", "ate_std_m", "keyframes", "keyframes_inserted", "tracked_frames"};
  for (const KeyframesRow& r : result.rows) {
    table.rows.push_back({r.sequence, r.origin, to_string(r.policy), std::to_string(r.runs.size()),
                          std::to_string(r.runs_with_ate), std::to_string(r.distinct_results), fixed(r.max_m, 6),
                          fixed(r.median_m, 6), fixed(r.rmse_m, 6), fixed(r.std_m, 6), fixed(r.keyframes_mean, 1),
                          fixed(r.inserted_mean, 1), fixed(r.tracked_mean, 1)});
  }
  return table;
}

Table keyframes_runs_table(const KeyframesResult& result) {
  Table table;
  table.header = {"sequence", "policy", "run", "seed", "threaded", "frames", "tracked", "keyframes_inserted",
                  "keyframes", "ate_pairs", "ate_max_m", "ate_median_m", "ate_rmse_m", "ate_std_m", "seconds"};
  for (const KeyframesRow& r : result.rows) {
    for (const KeyframeRun& run : r.runs) {
      const auto ate = [&](double v) { return run.ate_ok ? fixed(v, 6) : std::string(); };
      table.rows.push_back({r.sequence, to_string(r.policy), std::to_string(run.run), std::to_string(run.seed),
                            result.config.threaded ? "1" : "0", std::to_string(run.frames), std::to_string(run.tracked),
                            std::to_string(run.keyframes_inserted), std::to_string(run.keyframes),
                            std::to_string(run.errors_m.size()), ate(run.ate.max), ate(run.ate.median),
                            ate(run.ate.rmse), ate(run.ate.std), fixed(run.seconds, 2)});
    }
  }
  return table;
}

std::string tracked_share(const KeyframesRow& row) {
  if (row.runs.empty()) return "-";
  return fixed(row.tracked_mean, 1) + " / " + std::to_string(row.runs.front().frames);
}

std::vector<fs::path> write_keyframes_outputs(const KeyframesResult& result, const fs::path& dir) {
  std::vector<fs::path> written = {dir / "keyframes.csv", dir / "keyframes_runs.csv", dir / "keyframes.md"};
  write_text(written[0], keyframes_table(result).csv());
  write_text(written[1], keyframes_runs_table(result).csv());
  std::string md = "# Keyframe policies (paper Table 2)\n\nATE (m, SE(3) alignment) averaged over " +
                   std::to_string(result.config.runs) + " run(s) per policy" +
                   (result.config.runs >= 3 ? " with the largest and smallest value of each statistic dropped where at least 3 runs gave one" : "") + " (" + std::string(result.config.threaded ? "threaded mode, frames at their own rate" : "deterministic mode, loop-closing seed = run") + ").\n";
  std::vector<std::string> names;
  for (const KeyframesRow& r : result.rows) names.push_back(r.sequence);
  for (const std::string& sequence : unique_in_order(names)) {
    Table table;
    table.header = {"policy", "max", "median", "RMSE", "std", "keyframes", "tracked", "runs (distinct)"};
    LinePlot rmse_plot{"Cumulative ATE RMSE, " + sequence, "time (s)", "ATE RMSE (m)", {}};
    LinePlot std_plot{"Cumulative ATE std, " + sequence, "time (s)", "ATE std (m)", {}};
    rmse_plot.markers = std_plot.markers = false;
    for (const KeyframesRow& r : result.rows) {
      if (r.sequence != sequence) continue;
      table.rows.push_back({to_string(r.policy), fixed(r.max_m, 6), fixed(r.median_m, 6), fixed(r.rmse_m, 6),
                            fixed(r.std_m, 6), fixed(r.keyframes_mean, 1), tracked_share(r),
                            std::to_string(r.runs_with_ate) + " (" + std::to_string(r.distinct_results) + ")"});
      if (r.runs.empty() || !r.runs[r.median_run].ate_ok) continue;
      const KeyframeRun& run = r.runs[r.median_run];
      PlotSeries rmse{to_string(r.policy), run.t_s, {}}, std_dev{to_string(r.policy), run.t_s, {}};
      cumulative(run.errors_m, rmse.y, std_dev.y);
      rmse_plot.series.push_back(rmse);
      std_plot.series.push_back(std_dev);
    }
    md += "\n## " + sequence + "\n\n" + table.markdown();
    const fs::path rmse_svg = dir / ("cumulative_ate_rmse_" + file_stem(sequence) + ".svg");
    const fs::path std_svg = dir / ("cumulative_ate_std_" + file_stem(sequence) + ".svg");
    write_text(rmse_svg, render_svg(rmse_plot));
    write_text(std_svg, render_svg(std_plot));
    written.push_back(rmse_svg);
    written.push_back(std_svg);
  }
  write_text(written[2], md);
  return written;
}

}  // namespace fleetslam::experiments
