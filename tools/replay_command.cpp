// fleetslam replay: run one SLAM agent over a recorded sequence (TUM RGB-D, EuRoC, TUM-VI) and write
// what it did to an output folder:
//   trajectory.txt           every tracked frame, cam0, TUM format
//   keyframes.txt            the keyframes left in the map, TUM format
//   groundtruth.txt          the sequence's ground truth at the frames (when it has some)
//   timings.csv              per frame: status, feature counts, stage timings
//   keyframe_decisions.csv   per tracked frame: the keyframe policy's decision and its factors
//   config.yaml              the effective agent config
//   dense_map.ply            the agent's dense map (world = cam0 of the first tracked frame), when it has one
//   metrics.json             frame counts, timing statistics and (with ground truth) the ATE
// With --split N (the paper's multi-robot experiment, PAPER.md §5) the sequence's N consecutive parts
// run as N robots, each with its own agent, whose initial-pose prior is the ground-truth pose of the frame
// that starts its map;
// the central unit merges their dense maps and fuses their trajectories, and DIR gets the server's
// outputs (merged_map.ply, <robot>/map.ply, <robot>/trajectory.txt in the world frame, merge.json),
// <robot>/groundtruth.txt, central_config.yaml and metrics.json with each robot's ATE in the world frame
// and the point counts before and after sampling.


#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <spdlog/logger.h>

#include "cli_util.hpp"
#include "commands.hpp"
#include "fleetslam/core/config.hpp"
#include "fleetslam/core/dataset.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/core/orbslam_settings.hpp"
#include "fleetslam/core/point_cloud.hpp"
#include "fleetslam/core/trajectory.hpp"
#include "fleetslam/core/trajectory_metrics.hpp"
#include "fleetslam/central/link.hpp"
#include "fleetslam/central/server.hpp"
#include "fleetslam/slam/agent.hpp"
#include "fleetslam/slam/orbslam_settings.hpp"

namespace fleetslam::tools {
namespace {

namespace fs = std::filesystem;

struct ReplayOptions {
  std::string dataset;
  std::string format;  // empty: detect
  std::string sensor;  // empty: the config's (default: the rig's mode)
  std::string config;
  std::string calibration;
  std::string groundtruth;
  bool groundtruth_body = false;
  std::string out = "replay_out";
  std::int64_t max_frames = -1;
  int split = 1;
  std::string central_config;
  std::string vocabulary;  // place_recognition.vocabulary; empty: the config's
  std::string save_map;    // the agent's map is saved here after the run
  std::string load_map;    // the agent localises (localization only) in this saved map
  bool skip_unreadable = false;  // an undecodable or missing image skips its frame instead of stopping
};

// Defaults, then the ORB-SLAM settings file's ORB and close-depth values, then the config file.
slam::AgentConfig agent_config(const ReplayOptions& o, const std::optional<core::OrbSlamSettings>& settings) {
  slam::AgentConfig config;
  if (settings) slam::apply_orbslam_settings(*settings, config.frontend);
  config = read_config_file(o.config, config);
  if (o.sensor == "rgbd") config.sensor = slam::AgentSensor::kRgbd;
  if (o.sensor == "stereo") config.sensor = slam::AgentSensor::kStereo;
  if (!o.vocabulary.empty()) {
    config.place_recognition.vocabulary = o.vocabulary;
    slam::load_place_vocabulary(config.place_recognition);  // a bad file fails before the dataset opens
  }
  if (!o.load_map.empty()) {
    config.load_map = o.load_map;
    config.localization_only = true;
  }
  return config;
}

std::unique_ptr<core::FrameSource> open_source(const ReplayOptions& o,
                                               const std::optional<core::OrbSlamSettings>& settings,
                                               const core::Logger& logger) {
  core::DatasetConfig config;
  config.groundtruth_file = o.groundtruth;
  config.groundtruth_in_body_frame = o.groundtruth_body;
  config.load_imu = true;  // the agent predicts rotations with the gyroscope (tracking.gyro)
  config.stereo = o.sensor != "rgbd";
  config.skip_unreadable_frames = o.skip_unreadable;
  if (o.max_frames >= 0) config.stop_index = o.max_frames;
  if (settings) {
    config.rig = settings->rig;
    config.rig_source = o.calibration;
  }
  std::optional<core::DatasetFormat> format;
  if (!o.format.empty()) format = core::dataset_format_from_string(o.format);
  return core::open_dataset(o.dataset, format, config, logger);
}

std::string csv_text(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

std::string number(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.4f", value);
  return buffer;
}

// Per-frame rows of timings.csv and keyframe_decisions.csv, built while the run goes.
class RunLog {
 public:
  void add(const slam::AgentUpdate& u) {
    const slam::AgentTimings& t = u.timings;
    timings_ += std::to_string(u.sequence) + "," + core::format_seconds(u.t_ns, 6) + "," + slam::to_string(u.status) +
                "," + std::to_string(u.features) + "," + std::to_string(u.features_with_depth) + "," +
                std::to_string(u.inliers) + "," + number(t.extract_ms) + "," + number(t.match_ms) + "," +
                number(t.pose_ms) + "," + number(t.local_map_ms) + "," + number(t.tracking_ms) + "," +
                number(t.mapping_ms) + "," + number(t.total_ms) + "\n";
    ++status_counts_[slam::to_string(u.status)];
    relocalizations_ += u.relocalized ? 1 : 0;
    for (const slam::LoopEvent& loop : u.loops) loops_.push_back(loop_event_json(loop));
    if (u.status == slam::FrameStatus::kTracked || u.status == slam::FrameStatus::kInitialized) {
      tracking_ms_.push_back(t.tracking_ms);
      total_ms_.push_back(t.total_ms);
    }
    if (u.keyframe_decision) add_decision(u);
  }

  void write(const fs::path& out) const {
    write_text_file(out / "timings.csv",
               "sequence,t_s,status,features,features_with_depth,inliers,extract_ms,match_ms,pose_ms,local_map_ms,"
               "tracking_ms,mapping_ms,total_ms\n" + timings_);
    std::string header = "sequence,t_s,insert,score,reason";
    for (const std::string& name : factor_names_) header += "," + name;
    write_text_file(out / "keyframe_decisions.csv", header + "\n" + decisions_);
  }

  const std::map<std::string, int>& status_counts() const { return status_counts_; }
  const nlohmann::json& loops() const { return loops_; }
  int relocalizations() const { return relocalizations_; }
  const std::vector<double>& tracking_ms() const { return tracking_ms_; }
  const std::vector<double>& total_ms() const { return total_ms_; }

 private:
  void add_decision(const slam::AgentUpdate& u) {
    const slam::KeyframeDecision& d = *u.keyframe_decision;
    if (factor_names_.empty()) {
      for (const auto& factor : d.factors) factor_names_.push_back(factor.first);
    }
    decisions_ += std::to_string(u.sequence) + "," + core::format_seconds(u.t_ns, 6) + "," +
                  (d.insert ? "1" : "0") + "," + number(d.score) + "," + csv_text(d.reason);
    for (const std::string& name : factor_names_) {
      const auto it = std::find_if(d.factors.begin(), d.factors.end(), [&](const auto& f) { return f.first == name; });
      decisions_ += "," + (it == d.factors.end() ? std::string() : number(it->second));
    }
    decisions_ += "\n";
  }

  nlohmann::json loops_ = nlohmann::json::array();
  int relocalizations_ = 0;
  std::string timings_;
  std::string decisions_;
  std::vector<std::string> factor_names_;
  std::map<std::string, int> status_counts_;
  std::vector<double> tracking_ms_;
  std::vector<double> total_ms_;
};

// The ground truth to score against: the dataset's (or the given) camera-pose file as it is, as the
// TUM tools do; the per-frame (interpolated) poses when the file holds body poses (EuRoC's own).
core::Trajectory groundtruth(const ReplayOptions& o, const core::FrameSource& source,
                             const core::Trajectory& per_frame, std::string& used) {
  const std::string& file = source.info().groundtruth_file;
  // A file of body poses (--groundtruth-body) is compared through the per-frame camera poses the reader
  // made of it.
  const bool camera_poses =
      !o.groundtruth_body && (!o.groundtruth.empty() || source.info().format == core::DatasetFormat::kTumRgbd);
  if (!file.empty() && camera_poses) {
    used = file;
    core::TrajectoryReadOptions options;
    options.duplicate_stamps = core::DuplicateStamps::kKeepLast;
    return core::read_trajectory_file(file, options).trajectory;
  }
  used = "per-frame ground truth of the dataset reader";
  return per_frame;
}

struct RunResult {
  core::Trajectory estimate;
  core::Trajectory keyframes;
  core::Trajectory per_frame_groundtruth;
  slam::MapStats map;
  slam::DenseStats dense_stats;
  core::PointCloud dense;
  RunLog log;
  std::size_t frames = 0;
  // The unreadable frame that stopped the run (without --skip-unreadable): the frames before it were
  // processed and their outputs are written all the same.
  std::optional<core::SkippedRow> stopped_at;
};

RunResult run_agent(slam::Agent& agent, core::FrameSource& source, const core::Logger& logger) {
  RunResult run;
  core::Progress progress = make_progress(source.size(), "frames", logger);
  for (;;) {
    std::optional<core::SensorFrame> frame;
    try {
      frame = source.next();
    } catch (const InputError& e) {
      run.stopped_at = core::SkippedRow{e.where(), e.why()};
      break;
    }
    if (!frame) break;
    const slam::AgentUpdate update = agent.process(*frame);
    run.log.add(update);
    if (frame->T_world_cam_gt) run.per_frame_groundtruth.push_back({frame->t_ns, *frame->T_world_cam_gt});
    progress.update(++run.frames);
  }
  progress.finish();
  agent.finish();
  run.estimate = agent.trajectory();
  run.keyframes = agent.keyframe_trajectory();
  run.map = agent.map_stats();
  run.dense_stats = agent.dense_stats();
  run.dense = agent.dense_cloud();
  return run;
}

nlohmann::json ate_json(const core::AteResult& ate, const std::string& gt_source) {
  const core::ErrorStats& s = ate.stats;
  return {{"groundtruth", gt_source}, {"pairs", ate.pairs.size()}, {"alignment", "se3"},
          {"alignment_status", core::to_string(ate.alignment.status)},
          {"ate_m", {{"rmse", s.rmse}, {"mean", s.mean}, {"median", s.median}, {"std", s.std}, {"min", s.min},
                     {"max", s.max}}}};
}

void print_summary(const RunResult& run, const std::vector<core::SkippedRow>& unreadable,
                   const std::optional<core::AteResult>& ate, const fs::path& out) {
  std::printf("frames:       %zu (", run.frames);
  bool first = true;
  for (const auto& [status, count] : run.log.status_counts()) {
    std::printf("%s%s %d", first ? "" : ", ", status.c_str(), count);
    first = false;
  }
  std::printf(")\n");
  if (!unreadable.empty()) std::printf("skipped:      %zu unreadable frame(s)\n", unreadable.size());
  if (run.stopped_at) std::printf("stopped at:   %s (unreadable frame)\n", run.stopped_at->where.c_str());
  std::printf("map:          %zu keyframes, %zu points, %d component(s)\n", run.map.keyframes, run.map.points,
              run.map.components);
  std::printf("dense map:    %zu points (%zu back-projected)\n", run.dense_stats.points, run.dense_stats.back_projected);
  std::printf("loops:        %zu closed, %d relocalisation(s)\n", run.log.loops().size(), run.log.relocalizations());
  const nlohmann::json tracking = timing_stats_json(run.log.tracking_ms());
  if (!tracking.is_null()) {
    std::printf("tracking:     median %.1f ms, p90 %.1f ms per frame\n", tracking["median"].get<double>(),
                tracking["p90"].get<double>());
  }
  if (ate) {
    std::printf("ATE RMSE:     %.4f m (%zu pairs, se3 alignment)\n", ate->stats.rmse, ate->pairs.size());
  }
  std::printf("wrote:        %s/{trajectory.txt,keyframes.txt,timings.csv,keyframe_decisions.csv,config.yaml,"
              "metrics.json%s%s}\n",
              out.string().c_str(), run.dense.empty() ? "" : ",dense_map.ply",
              run.per_frame_groundtruth.empty() ? "" : ",groundtruth.txt");
}

// The files a replay writes in its folder, some only sometimes (a dense map, ground truth, the split's
// merged map): an earlier replay's are removed first, so that what the folder holds afterwards is this
// run's (a stale dense_map.ply or metrics.json next to new results read as theirs). Only these names are
// touched: a split's robot folders (robot_a, ...) are left as they are.
void remove_earlier_outputs(const fs::path& out, const core::Logger& logger) {
  const std::size_t removed = remove_files_named(
      out, {"config.yaml", "trajectory.txt", "keyframes.txt", "timings.csv", "keyframe_decisions.csv", "dense_map.ply",
            "groundtruth.txt", "metrics.json", "central_config.yaml", "merged_map.ply", "merge.json"});
  if (removed > 0) logger->info("removed {} output file(s) of an earlier replay from {}", removed, out.string());
}

// The sequence's parts as robots: frame k of n goes to robot floor(k * parts / n).
void run_split_replay(const ReplayOptions& o, const GlobalOptions& global, const slam::AgentConfig& config,
                      const central::ServerConfig& central_config, core::FrameSource& source, const core::Logger& logger,
                      const fs::path& out) {
  const std::size_t total = source.size();
  const std::size_t parts = static_cast<std::size_t>(o.split);
  write_text_file(out / "central_config.yaml", core::config_to_yaml(central_config));
  central::Server server(central_config, logger);
  central::InProcessLink link;
  std::vector<slam::Agent> agents;
  std::vector<std::string> names;
  std::vector<core::Trajectory> groundtruths(parts);
  for (std::size_t r = 0; r < parts; ++r) {
    agents.emplace_back(config, source.rig(), logger);
    names.push_back(std::string("robot_") + static_cast<char>('a' + static_cast<int>(r % 26)) +
                    (r >= 26 ? std::to_string(r / 26) : std::string()));
  }
  core::Progress progress = make_progress(total, "frames", logger);
  std::size_t k = 0;
  std::vector<std::int64_t> first_index(parts, -1);
  std::vector<std::int64_t> map_start(parts, -1);  // the frame that started the robot's map
  std::vector<std::size_t> frames_of(parts, 0);
  while (std::optional<core::SensorFrame> frame = source.next()) {
    const std::size_t r = std::min(parts - 1, k * parts / total);
    if (first_index[r] < 0) first_index[r] = static_cast<std::int64_t>(k);
    frame->robot_id = static_cast<int>(r);
    frame->sequence = static_cast<std::int64_t>(k) - first_index[r];
    ++frames_of[r];
    if (frame->T_world_cam_gt) groundtruths[r].push_back({frame->t_ns, *frame->T_world_cam_gt});
    slam::AgentUpdate update = agents[r].process(*frame);
    // The robot's frame is its agent's world: cam0 of the frame that started its map, which need not be
    // the part's first frame (one without texture or depth starts none). Its prior is that frame's pose.
    if (map_start[r] < 0 && update.status == slam::FrameStatus::kInitialized) {
      if (!frame->T_world_cam_gt) {
        throw InputError(o.dataset, "--split needs ground truth at the frame that starts each part's map (frame " +
                                        std::to_string(k) + ") for the robot's initial-pose prior");
      }
      map_start[r] = static_cast<std::int64_t>(k);
      server.add_robot(central::RobotSpec{static_cast<int>(r), names[r], *frame->T_world_cam_gt, {}});
    }
    if (map_start[r] >= 0) link.send(std::move(update));  // before its map starts, nothing to send
    server.integrate_all(link);
    progress.update(++k);
  }
  progress.finish();
  for (std::size_t r = 0; r < parts; ++r) {
    if (map_start[r] >= 0) link.send(agents[r].finish());  // the workers' last changes (threaded)
  }
  server.integrate_all(link);
  const central::ServerMergeReport& report = server.merge();
  server.write_outputs(out);

  nlohmann::json robots = nlohmann::json::array();
  for (std::size_t r = 0; r < parts; ++r) {
    const int id = static_cast<int>(r);
    core::write_trajectory(out / names[r] / "groundtruth.txt", groundtruths[r], core::TrajectoryFormat::kTum);
    const core::Trajectory world = map_start[r] >= 0 ? server.world_trajectory(id) : core::Trajectory{};
    nlohmann::json entry = {{"name", names[r]}, {"frames", frames_of[r]}, {"tracked", world.size()},
                            {"first_frame", first_index[r]}, {"map_start_frame", map_start[r]}};
    for (const auto& [mode, key] : {std::pair{core::AlignmentMode::kNone, "ate_world_m"}, std::pair{core::AlignmentMode::kSe3, "ate_se3_m"}}) {
      const core::AteResult ate = core::compute_ate(groundtruths[r], world, core::associate_by_time(groundtruths[r], world), mode);
      if (ate.measured()) entry[key] = {{"rmse", ate.stats.rmse}, {"mean", ate.stats.mean}, {"max", ate.stats.max}};
    }
    robots.push_back(entry);
  }
  const central::MergeResult& m = report.merge;
  const nlohmann::json metrics = {{"command", "fleetslam replay --split"}, {"dataset", o.dataset}, {"split", parts},
                                  {"frames", k}, {"robots", robots}, {"merge", central::to_json(m)},
                                  {"skipped_rows", skipped_rows_json(source.info().skipped)},
                                  {"unreadable_frames_skipped", skipped_rows_json(source.unreadable_frames())}};
  write_text_file(out / "metrics.json", metrics.dump(2) + "\n");
  if (global.quiet) return;
  for (const nlohmann::json& entry : robots) {
    std::printf("%-12s %zu frames from %lld, tracked %zu", entry["name"].get<std::string>().c_str(),
                entry["frames"].get<std::size_t>(), static_cast<long long>(entry["first_frame"].get<std::int64_t>()),
                entry["tracked"].get<std::size_t>());
    if (entry.contains("ate_world_m")) std::printf(", ATE in the world frame %.4f m", entry["ate_world_m"]["rmse"].get<double>());
    std::printf("\n");
  }
  std::printf("merged map:  %zu points before sampling, %zu after (%+.2f %%), %zu after filtering\n",
              m.points_before_sampling, m.points_after_sampling,
              m.points_before_sampling > 0 ? 100.0 * (static_cast<double>(m.points_after_sampling) - static_cast<double>(m.points_before_sampling)) /
                                                 static_cast<double>(m.points_before_sampling)
                                           : 0.0,
              m.points_after_filter);
  std::printf("wrote:       %s/{merged_map.ply,merge.json,metrics.json,central_config.yaml,<robot>/...}\n", out.string().c_str());
}

void run_replay(const ReplayOptions& o, const GlobalOptions& global) {
  const core::Logger logger = make_cli_logger("replay", global);
  std::optional<core::OrbSlamSettings> settings;
  if (!o.calibration.empty()) settings = core::read_orbslam_settings(o.calibration);
  const slam::AgentConfig config = agent_config(o, settings);
  std::unique_ptr<core::FrameSource> source = open_source(o, settings, logger);
  // Everything that can refuse the input is checked before the output folder is touched: an earlier
  // run's results there are removed only for a run that goes ahead.
  if (source->size() == 0) {
    throw InputError(o.dataset, "no frames selected (the sequence is empty, or --max-frames is 0)");
  }
  const fs::path out = o.out;
  if (o.split > 1) {
    if (!o.save_map.empty() || !o.load_map.empty()) throw InputError("--split", "takes neither --save-map nor --load-map");
    const std::size_t parts = static_cast<std::size_t>(o.split);
    if (source->size() < 2 * parts) {
      throw InputError(o.dataset, "--split " + std::to_string(parts) + " needs at least " + std::to_string(2 * parts) +
                                      " frames, the sequence has " + std::to_string(source->size()));
    }
    const central::ServerConfig central_config = read_config_file<central::ServerConfig>(o.central_config);
    create_output_folder(out);
    remove_earlier_outputs(out, logger);
    write_text_file(out / "config.yaml", core::config_to_yaml(config));
    run_split_replay(o, global, config, central_config, *source, logger, out);
    return;
  }
  if (!o.central_config.empty()) {
    throw InputError("--central-config", "needs --split: without it no central unit runs");
  }
  // The map is saved after the whole run: a folder that is not there is said now, not after it.
  if (!o.save_map.empty()) {
    const fs::path folder = fs::path(o.save_map).parent_path();
    std::error_code ec;
    if (!folder.empty() && !fs::is_directory(folder, ec)) {
      throw InputError(o.save_map, "the folder " + folder.string() + " does not exist (--save-map)");
    }
    if (fs::is_directory(o.save_map, ec)) throw InputError(o.save_map, "is a folder; --save-map takes a file name");
  }

  slam::AgentConfig without_map = config;  // the map is loaded below, timed (reported only)
  without_map.load_map.clear();
  slam::Agent agent(without_map, source->rig(), logger);
  double load_s = 0.0;
  if (!config.load_map.empty()) {
    const auto load_start = std::chrono::steady_clock::now();
    agent.load_map(config.load_map);
    load_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - load_start).count();
  }
  create_output_folder(out);
  remove_earlier_outputs(out, logger);
  write_text_file(out / "config.yaml", core::config_to_yaml(config));
  RunResult run = run_agent(agent, *source, logger);
  if (run.frames == 0 && !run.stopped_at) {
    throw InputError(o.dataset, "no frame could be read: all " + std::to_string(source->unreadable_frames().size()) +
                                    " selected frame(s) were unreadable and skipped (--skip-unreadable); the "
                                    "calibration may not fit the images");
  }
  // A map that cannot be saved costs the run nothing else: the other outputs are written, then the error
  // is raised.
  std::optional<double> save_s;
  std::optional<InputError> save_error;
  if (!o.save_map.empty()) {
    const auto save_start = std::chrono::steady_clock::now();
    try {
      agent.save_map(o.save_map);
      save_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - save_start).count();
      logger->info("map saved to {} ({} keyframes, {} points) in {:.3f} s", o.save_map, run.map.keyframes,
                   run.map.points, *save_s);
    } catch (const InputError& e) {
      save_error = e;
    }
  }
  core::write_trajectory(out / "trajectory.txt", run.estimate, core::TrajectoryFormat::kTum);
  core::write_trajectory(out / "keyframes.txt", run.keyframes, core::TrajectoryFormat::kTum);
  run.log.write(out);
  if (!run.dense.empty()) core::write_ply(out / "dense_map.ply", run.dense);

  nlohmann::json metrics = {{"command", "fleetslam replay"}, {"dataset", o.dataset},
                            {"frames", run.frames}, {"status_counts", run.log.status_counts()},
                            {"keyframes", run.map.keyframes}, {"map_points", run.map.points},
                            {"components", run.map.components},
                            {"loops", run.log.loops()}, {"loops_refused", loop_rejections_json(run.map.loop_rejections)},
                            {"relocalizations", run.log.relocalizations()},
                            {"dense_points", run.dense_stats.points},
                            {"dense_back_projected", run.dense_stats.back_projected},
                            {"tracking_ms", timing_stats_json(run.log.tracking_ms())},
                            {"total_ms", timing_stats_json(run.log.total_ms())},
                            {"localization_only", config.localization_only},
                            {"skipped_rows", skipped_rows_json(source->info().skipped)},
                            {"unreadable_frames_skipped", skipped_rows_json(source->unreadable_frames())}};
  if (run.stopped_at) metrics["stopped_at"] = skipped_row_json(*run.stopped_at);
  if (!o.load_map.empty()) {
    metrics["loaded_map"] = {{"file", o.load_map}, {"load_s", load_s}};
  }
  if (save_s) {
    std::error_code size_ec;
    const auto bytes = fs::file_size(o.save_map, size_ec);
    metrics["saved_map"] = {{"file", o.save_map}, {"bytes", size_ec ? 0 : bytes}, {"save_s", *save_s}};
  }
  if (save_error) metrics["saved_map"] = {{"file", o.save_map}, {"error", save_error->what()}};
  std::optional<core::AteResult> ate;
  if (run.per_frame_groundtruth.empty() && !source->info().groundtruth_file.empty()) {
    logger->warn("no ATE: {} gives none of the {} replayed frame(s) a pose (it covers other frames of the "
                 "sequence: see --max-frames)",
                 source->info().groundtruth_file, run.frames);
  }
  if (!run.per_frame_groundtruth.empty()) {
    core::write_trajectory(out / "groundtruth.txt", run.per_frame_groundtruth, core::TrajectoryFormat::kTum);
    std::string gt_source;
    const core::Trajectory gt = groundtruth(o, *source, run.per_frame_groundtruth, gt_source);
    ate = core::compute_ate(gt, run.estimate, core::associate_by_time(gt, run.estimate), core::AlignmentMode::kSe3);
    if (ate->measured()) {
      metrics["ate"] = ate_json(*ate, gt_source);
      if (!ate->ok()) {
        logger->warn("ATE alignment: {}; the ATE is still the least-squares minimum, but the alignment is not unique",
                     core::to_string(ate->alignment.status));
      }
    } else {
      logger->warn("no ATE: {} estimated pose(s) paired with the ground truth; the se3 alignment needs at least 3",
                   ate->pairs.size());
      ate.reset();
    }
  }
  write_text_file(out / "metrics.json", metrics.dump(2) + "\n");
  if (!global.quiet) {
    print_summary(run, source->unreadable_frames(), ate, out);
    if (!o.load_map.empty()) std::printf("loaded map:   %s in %.3f s (localization only)\n", o.load_map.c_str(), load_s);
    if (save_s) std::printf("saved map:    %s in %.3f s\n", o.save_map.c_str(), *save_s);
  }
  if (save_error) {
    throw InputError(save_error->where(),
                     save_error->why() + "; the map was not saved, the other outputs are in " + out.string());
  }
  if (run.stopped_at) {
    throw InputError(run.stopped_at->where,
                     run.stopped_at->why + "; the replay stopped there, after " + std::to_string(run.frames) +
                         " frame(s), whose outputs are in " + out.string() + " (--skip-unreadable skips such frames)");
  }
}

}  // namespace

void add_replay_command(CLI::App& app, const GlobalOptions& global) {
  auto options = std::make_shared<ReplayOptions>();
  CLI::App* cmd = app.add_subcommand(
      "replay", "Run one SLAM agent over a recorded sequence; write its trajectory, keyframes, timings, keyframe "
                "decisions, effective config and (with ground truth) the ATE to --out");
  cmd->add_option("dataset", options->dataset, "Sequence folder (TUM RGB-D, EuRoC or TUM-VI layout)")->required();
  cmd->add_option("--format", options->format, "Dataset layout (default: detected)")
      ->transform(dataset_format_check());
  cmd->add_option("--sensor", options->sensor, "Sensors to use (default: the rig's mode)")
      ->check(CLI::IsMember({"rgbd", "stereo"}));
  cmd->add_option("--config", options->config, "Agent config YAML (see config.yaml of any run for every key)");
  cmd->add_option("--calibration", options->calibration,
                  "Camera settings in the ORB-SLAM format (cameras, ORBextractor, ThDepth)");
  cmd->add_option("--groundtruth", options->groundtruth, "Ground-truth camera poses to use instead of the dataset's");
  cmd->add_flag("--groundtruth-body", options->groundtruth_body,
                "The --groundtruth file holds body (IMU) poses, as EuRoC's data.csv: turned into camera poses by the "
                "calibration's body-to-camera transform");
  cmd->add_option("--out", options->out, "Output folder")->capture_default_str();
  cmd->add_option("--max-frames", options->max_frames, "Process at most this many frames")
      ->check(whole_number_at_least(0));
  cmd->add_flag("--skip-unreadable", options->skip_unreadable,
                "Skip a frame whose image is missing (dropped while the lists are read: skipped_rows in "
                "metrics.json) or cannot be decoded (unreadable_frames_skipped) instead of stopping there");
  cmd->add_option("--split", options->split,
                  "Run the sequence's N consecutive parts as N robots (the ground-truth pose of the frame that starts "
                  "each part's map as its prior) and merge their maps in the central unit")
      ->check(CLI::Range(1, 26));
  cmd->add_option("--central-config", options->central_config, "Central unit config YAML (with --split)");
  cmd->add_option("--vocabulary", options->vocabulary,
                  "Vocabulary file for place recognition (binary or DBoW2 text; default: the config's, else the "
                  "shipped one)");
  cmd->add_option("--save-map", options->save_map, "Save the agent's map to this file after the run");
  cmd->add_option("--load-map", options->load_map,
                  "Start from this saved map and localise in it only (no keyframes, no mapping, no loop closing)");
  cmd->callback([options, &global] { run_replay(*options, global); });
}

}  // namespace fleetslam::tools
