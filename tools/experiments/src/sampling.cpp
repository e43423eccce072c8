#include "fleetslam/experiments/sampling.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <optional>

#include <spdlog/logger.h>

#include "fleetslam/central/link.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/core/trajectory_metrics.hpp"
#include "fleetslam/experiments/svg_plot.hpp"
#include "fleetslam/slam/agent.hpp"

namespace fleetslam::experiments {
namespace {

namespace fs = std::filesystem;

std::string robot_name(std::size_t r) { return std::string("robot_") + static_cast<char>('a' + static_cast<int>(r % 26)); }

}  // namespace

double SamplingRow::reduction_percent() const {
  if (points_before == 0) return std::numeric_limits<double>::quiet_NaN();
  return 100.0 * (static_cast<double>(points_before) - static_cast<double>(points_after)) /
         static_cast<double>(points_before);
}

SamplingExperiment::SamplingExperiment(const SamplingConfig& config, core::Logger logger)
    : config_(config), logger_(std::move(logger)) {
  if (config_.split < 2 || config_.split > 26) throw InputError("--split", "must be in [2, 26]");
}

SamplingRow SamplingExperiment::run_robots(const std::vector<RobotPart>& parts) const {
  const auto start_time = std::chrono::steady_clock::now();
  central::Server server(config_.central, core::null_logger());
  central::InProcessLink link;
  SamplingRow row;
  row.robots = static_cast<int>(parts.size());
  std::vector<core::Trajectory> groundtruths(parts.size());
  std::vector<bool> registered(parts.size(), false);  // its map started: the server knows it
  // The time the robots' frames span together: the whole sequence when it is split into consecutive
  // parts, the longest robot when they run side by side (the paper's "dataset length").
  std::optional<core::TimeNs> span_first, span_last;
  for (std::size_t r = 0; r < parts.size(); ++r) {
    const RobotPart& part = parts[r];
    const auto source = open_sequence(part.sequence, part.start, part.stop, logger_);
    slam::Agent agent(agent_config_for(part.sequence), source->rig(), core::null_logger());
    std::int64_t sequence = 0;
    core::TimeNs first_t = 0, last_t = 0;
    while (std::optional<core::SensorFrame> frame = source->next()) {
      if (sequence == 0) first_t = frame->t_ns;
      last_t = frame->t_ns;
      frame->robot_id = static_cast<int>(r);
      frame->sequence = sequence++;
      if (frame->T_world_cam_gt) groundtruths[r].push_back({frame->t_ns, *frame->T_world_cam_gt});
      slam::AgentUpdate update = agent.process(*frame);
      // The robot's frame is its agent's world: cam0 of the frame that started its map (not necessarily its
      // first frame). Its prior is that frame's true pose.
      if (!registered[r] && update.status == slam::FrameStatus::kInitialized) {
        if (!frame->T_world_cam_gt) {
          throw InputError(part.sequence.folder.string(), "frame " + std::to_string(part.start + frame->sequence) +
                                                              " starts robot " + part.name +
                                                              "'s map but has no ground-truth pose for its initial-pose prior");
        }
        server.add_robot(central::RobotSpec{static_cast<int>(r), part.name, *frame->T_world_cam_gt, {}});
        registered[r] = true;
      }
      if (registered[r]) link.send(std::move(update));  // before its map starts, nothing to send
      server.integrate_all(link);
    }
    if (registered[r]) link.send(agent.finish());  // the workers' last changes (threaded)
    server.integrate_all(link);
    row.frames += static_cast<std::size_t>(sequence);
    if (sequence > 0) {
      span_first = span_first ? std::min(*span_first, first_t) : first_t;
      span_last = span_last ? std::max(*span_last, last_t) : last_t;
    }
  }
  if (span_first) row.duration_s = core::ns_to_seconds(*span_last - *span_first);
  const central::ServerMergeReport& report = server.merge();
  row.points_before = report.merge.points_before_sampling;
  row.points_after = report.merge.points_after_sampling;
  row.points_after_filter = report.merge.points_after_filter;
  for (const central::RobotFusionReport& robot : report.robots) row.registered += robot.registered ? 1 : 0;
  for (std::size_t r = 0; r < parts.size(); ++r) {
    const core::Trajectory world = registered[r] ? server.world_trajectory(static_cast<int>(r)) : core::Trajectory{};
    const core::AteResult ate = core::compute_ate(groundtruths[r], world, core::associate_by_time(groundtruths[r], world),
                                                  core::AlignmentMode::kNone);
    row.robot_ate_m.push_back(ate.measured() ? ate.stats.rmse : std::numeric_limits<double>::quiet_NaN());
  }
  row.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time).count();
  return row;
}

SamplingResult SamplingExperiment::run(const std::vector<SequenceSpec>& sequences) const {
  SamplingResult result;
  result.config = config_;
  std::vector<std::string> scenarios;  // synthetic sequences grouped by scenario, in order
  std::map<std::string, std::vector<RobotPart>> scenario_parts;
  for (const SequenceSpec& spec : sequences) {
    if (spec.origin == "synthetic") {
      if (scenario_parts.count(spec.scenario) == 0) scenarios.push_back(spec.scenario);
      const std::string robot = spec.name.substr(spec.name.find('/') + 1);
      scenario_parts[spec.scenario].push_back({robot, spec, 0, config_.max_frames});
      continue;
    }
    if (spec.stereo) continue;  // the dense map needs depth per frame: RGB-D sequences only
    const auto probe = open_sequence(spec, 0, config_.max_frames, logger_);
    const auto total = static_cast<std::int64_t>(probe->size());
    const auto parts_count = static_cast<std::int64_t>(config_.split);
    if (total < 2 * parts_count) {
      throw InputError(spec.folder.string(), "splitting into " + std::to_string(parts_count) + " robots needs at least " +
                                                 std::to_string(2 * parts_count) + " frames, there are " + std::to_string(total));
    }
    std::vector<RobotPart> parts;
    for (std::int64_t r = 0; r < parts_count; ++r) {  // frame k goes to robot floor(k * parts / total), as replay --split
      const std::int64_t first = (r * total + parts_count - 1) / parts_count;
      const std::int64_t stop = ((r + 1) * total + parts_count - 1) / parts_count;
      parts.push_back({robot_name(static_cast<std::size_t>(r)), spec, first, stop});
    }
    SamplingRow row = run_robots(parts);
    row.dataset = spec.name;
    row.origin = spec.origin;
    row.mode = "split";
    logger_->info("sampling {}: {} -> {} points ({:.2f} % fewer)", row.dataset, row.points_before, row.points_after,
                  row.reduction_percent());
    result.rows.push_back(row);
  }
  for (const std::string& scenario : scenarios) {
    SamplingRow row = run_robots(scenario_parts[scenario]);
    row.dataset = fs::path(scenario).stem().string();
    row.origin = "synthetic";
    row.mode = "robots";
    logger_->info("sampling {}: {} -> {} points ({:.2f} % fewer)", row.dataset, row.points_before, row.points_after,
                  row.reduction_percent());
    result.rows.push_back(row);
  }
  return result;
}

Table sampling_table(const SamplingResult& result) {
  Table table;
  table.header = {"dataset", "origin", "mode", "robots", "frames", "duration_s", "points_before", "points_after",
                  "reduction_percent", "points_after_filter", "robots_registered", "robot_ate_world_rmse_m", "seconds"};
  for (const SamplingRow& r : result.rows) {
    std::string ates;
    for (const double a : r.robot_ate_m) ates += (ates.empty() ? "" : " ") + fixed(a, 4);
    table.rows.push_back({r.dataset, r.origin, r.mode, std::to_string(r.robots), std::to_string(r.frames),
                          fixed(r.duration_s, 3), std::to_string(r.points_before), std::to_string(r.points_after),
                          fixed(r.reduction_percent(), 2), std::to_string(r.points_after_filter),
                          std::to_string(r.registered), ates, fixed(r.seconds, 2)});
  }
  return table;
}

std::vector<fs::path> write_sampling_outputs(const SamplingResult& result, const fs::path& dir) {
  std::vector<fs::path> written = {dir / "sampling.csv", dir / "sampling.md", dir / "sampling_points.svg"};
  write_text(written[0], sampling_table(result).csv());
  Table table;
  table.header = {""};
  for (const SamplingRow& r : result.rows) table.header.push_back(r.dataset + " (" + r.mode + ", " + std::to_string(r.robots) + " robots)");
  std::vector<std::string> length = {"dataset length (s)"}, before = {"before sampling"}, after = {"after sampling"},
                           reduction = {"reduction (%)"};
  BarPlot plot{"Merged map points before and after uniform sampling", "points", {"before sampling", "after sampling"}, {}};
  for (const SamplingRow& r : result.rows) {
    length.push_back(fixed(r.duration_s, 3));
    before.push_back(std::to_string(r.points_before));
    after.push_back(std::to_string(r.points_after));
    reduction.push_back(fixed(r.reduction_percent(), 2));
    plot.groups.push_back({r.dataset, {static_cast<double>(r.points_before), static_cast<double>(r.points_after)}});
  }
  table.rows = {length, before, after, reduction};
  write_text(written[1], "# Uniform sampling of the merged map (paper Table 3)\n\n" + table.markdown());
  write_text(written[2], render_svg(plot));
  return written;
}

}  // namespace fleetslam::experiments
