// fleetslam eval: ATE and RPE of an estimated trajectory against ground truth, as figures on stdout,
// metrics.json, the aligned estimate (TUM) and a picture (SVG) in the output folder.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/core/trajectory.hpp"
#include "fleetslam/core/trajectory_metrics.hpp"
#include "fleetslam/core/trajectory_plot.hpp"

namespace fleetslam::tools {
namespace {

namespace fs = std::filesystem;
using namespace fleetslam::core;

constexpr double kDegreesPerRadian = 57.29577951308232;

struct EvalOptions {
  std::string gt_path, est_path;
  std::string align = "se3";
  std::string est_format = "auto", gt_format = "auto";
  std::string associate = "auto";
  std::string max_diff = "0.02", offset = "0";
  double rpe_delta = 1.0;
  std::string rpe_unit = "frames";
  std::string duplicates = "keep-last";
  std::string out_dir = "eval_out";
};

// Everything the options say, parsed and checked.
struct EvalSettings {
  AlignmentMode align = AlignmentMode::kSe3;
  TrajectoryReadOptions gt_read, est_read;
  TimeAssociationConfig association;
  RpeConfig rpe;
};

// Six significant digits, no trailing zeros ("1", "0.5", "0.00814392").
std::string number_text(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%g", v);
  return buffer;
}

TimeNs parse_seconds_option(const std::string& name, const std::string& text) {
  const auto t_ns = parse_seconds(text);
  if (!t_ns) throw InputError(name, "not a number of seconds: '" + text + "'");
  return *t_ns;
}

std::optional<TrajectoryFormat> parse_format_option(const std::string& text) {
  return text == "auto" ? std::nullopt : trajectory_format_from_string(text);
}

EvalSettings settings_from(const EvalOptions& o) {
  EvalSettings s;
  s.align = *alignment_mode_from_string(o.align);  // CLI11 checked the names
  const DuplicateStamps duplicates = o.duplicates == "error"        ? DuplicateStamps::kError
                                     : o.duplicates == "keep-first" ? DuplicateStamps::kKeepFirst
                                                                    : DuplicateStamps::kKeepLast;
  s.gt_read = {parse_format_option(o.gt_format), duplicates};
  s.est_read = {parse_format_option(o.est_format), duplicates};
  s.association.max_difference_ns = parse_seconds_option("--max-diff", o.max_diff);
  s.association.offset_ns = parse_seconds_option("--offset", o.offset);
  if (s.association.max_difference_ns <= 0) throw InputError("--max-diff", "must be positive");
  // Bounded so that stamps plus these stay within int64 nanoseconds (1e10 s wrapped to a negative time).
  constexpr TimeNs kMaxSpanNs = 1'000'000LL * 1'000'000'000LL;  // 1e6 s
  if (s.association.max_difference_ns > kMaxSpanNs) throw InputError("--max-diff", "must be at most 1e6 s");
  if (s.association.offset_ns > 1000 * kMaxSpanNs || s.association.offset_ns < -1000 * kMaxSpanNs) {
    throw InputError("--offset", "must be within +-1e9 s");
  }
  s.rpe = {o.rpe_delta, *rpe_unit_from_string(o.rpe_unit)};
  if (!(o.rpe_delta > 0.0) || !std::isfinite(o.rpe_delta)) throw InputError("--rpe-delta", "must be positive");
  if (o.rpe_delta > 1e6) throw InputError("--rpe-delta", "must be at most 1e6 (seconds, metres or frames)");
  if (s.rpe.unit == RpeUnit::kFrames && std::floor(o.rpe_delta) != o.rpe_delta) {
    throw InputError("--rpe-delta", "a delta in frames must be a whole number");
  }
  return s;
}

TrajectoryFile read_input(const std::string& path, const TrajectoryReadOptions& options) {
  TrajectoryFile file = read_trajectory_file(path, options);
  if (file.duplicates_dropped > 0) {
    std::cerr << "fleetslam: warning: " << at_line(path, file.first_duplicate_line) << ": "
              << file.duplicates_dropped << " repeated timestamp(s); kept the "
              << (options.duplicate_stamps == DuplicateStamps::kKeepFirst ? "first" : "last")
              << " pose of each (as the TUM tools do)\n";
  }
  return file;
}

// KITTI files have no time: their poses pair by index.
// auto pairs by index when both files lack time (KITTI); a file with stamps against one without is
// refused: index pairing would match poses of unrelated times unless the user says both start together.
bool by_index(const EvalOptions& o, const TrajectoryFile& gt, const TrajectoryFile& est) {
  if (o.associate != "auto") return o.associate == "index";
  const bool gt_untimed = gt.format == TrajectoryFormat::kKitti;
  const bool est_untimed = est.format == TrajectoryFormat::kKitti;
  if (gt_untimed != est_untimed) {
    const std::string& untimed = gt_untimed ? o.gt_path : o.est_path;
    const std::string& timed = gt_untimed ? o.est_path : o.gt_path;
    throw InputError(untimed, "has no time stamps (KITTI) and " + timed + " has (" +
                                  to_string(gt_untimed ? est.format : gt.format) +
                                  "): they cannot be paired by time; --associate index pairs them by position in "
                                  "the files, if both start at the same frame");
  }
  return gt_untimed;
}

// Refuses results that would be meaningless, naming the estimate file.
void check_ate(const AteResult& ate, const EvalOptions& o, bool indexed) {
  if (ate.pairs.empty()) {
    throw InputError(o.est_path, indexed ? "no poses to pair by index"
                                         : "no pose is within " + o.max_diff + " s of a ground-truth pose of " +
                                               o.gt_path + " (check --offset, --max-diff and the files)");
  }
  if (ate.alignment.status == AlignmentStatus::kTooFewPairs) {
    throw InputError(o.est_path, "only " + std::to_string(ate.pairs.size()) + " pose(s) paired with " + o.gt_path +
                                     ": " + o.align + " alignment needs at least 3 (try --align none)");
  }
  if (ate.alignment.status == AlignmentStatus::kDegenerate) {
    std::cerr << "fleetslam: warning: " << o.est_path << ": " << to_string(ate.alignment.status)
              << "; the ATE is still the least-squares minimum, but the alignment is not unique\n";
  }
}

nlohmann::json stats_json(const ErrorStats& s, double factor = 1.0) {
  return {{"count", s.count},       {"rmse", s.rmse * factor}, {"mean", s.mean * factor},
          {"median", s.median * factor}, {"std", s.std * factor},   {"min", s.min * factor},
          {"max", s.max * factor}};
}

nlohmann::json file_json(const std::string& path, const TrajectoryFile& f) {
  return {{"path", path},
          {"format", to_string(f.format)},
          {"poses", f.trajectory.size()},
          {"duplicate_stamps_dropped", f.duplicates_dropped}};
}

nlohmann::json alignment_json(const Alignment& a) {
  const Eigen::Matrix3d R = a.T_gt_est.linear();
  const Eigen::Vector3d t = a.T_gt_est.translation();
  return {{"mode", to_string(a.mode)},
          {"status", a.ok() ? "ok" : to_string(a.status)},
          {"scale", a.scale},
          {"rotation_gt_est", {{R(0, 0), R(0, 1), R(0, 2)}, {R(1, 0), R(1, 1), R(1, 2)}, {R(2, 0), R(2, 1), R(2, 2)}}},
          {"translation_gt_est_m", {t.x(), t.y(), t.z()}}};
}

nlohmann::json per_pair_json(const std::vector<TimeNs>& t_ns, const std::vector<double>& values, const char* name) {
  nlohmann::json times = nlohmann::json::array(), errors = nlohmann::json::array();
  for (std::size_t i = 0; i < values.size(); ++i) {
    times.push_back(ns_to_seconds(t_ns[i]));
    errors.push_back(values[i]);
  }
  return {{"t_s", times}, {name, errors}};
}

nlohmann::json metrics_json(const EvalOptions& o, const TimeAssociationConfig& s, const TrajectoryFile& gt,
                            const TrajectoryFile& est, bool indexed, const AteResult& ate, const RpeResult& rpe) {
  nlohmann::json j;
  j["command"] = "fleetslam eval";
  j["groundtruth"] = file_json(o.gt_path, gt);
  j["estimate"] = file_json(o.est_path, est);
  j["association"] = {{"method", indexed ? "index" : "time"}, {"pairs", ate.pairs.size()}};
  if (!indexed) {
    j["association"]["max_difference_s"] = ns_to_seconds(s.max_difference_ns);
    j["association"]["offset_s"] = ns_to_seconds(s.offset_ns);
  }
  j["alignment"] = alignment_json(ate.alignment);
  j["ate_m"] = stats_json(ate.stats);
  j["rpe"] = {{"delta", rpe.config.delta},
              {"unit", to_string(rpe.config.unit)},
              {"translation_m", stats_json(rpe.translation_m)},
              {"rotation_deg", stats_json(rpe.rotation_rad, kDegreesPerRadian)},
              {"rotation_rad", stats_json(rpe.rotation_rad)},
              {"skipped_across_gaps", rpe.skipped_across_gaps}};
  j["ate_per_pair"] = per_pair_json(ate.t_ns, ate.errors_m, "error_m");
  return j;
}

void print_stats(const char* name, const ErrorStats& s, double factor, int decimals) {
  std::printf("  %-22s rmse %.*f  mean %.*f  median %.*f  std %.*f  min %.*f  max %.*f  (n=%zu)\n", name, decimals,
              s.rmse * factor, decimals, s.mean * factor, decimals, s.median * factor, decimals, s.std * factor,
              decimals, s.min * factor, decimals, s.max * factor, s.count);
}

void print_report(const EvalOptions& o, const TrajectoryFile& gt, const TrajectoryFile& est, bool indexed,
                  const AteResult& ate, const RpeResult& rpe) {
  std::printf("ground truth: %s (%s, %zu poses)\n", o.gt_path.c_str(), to_string(gt.format).c_str(),
              gt.trajectory.size());
  std::printf("estimate:     %s (%s, %zu poses)\n", o.est_path.c_str(), to_string(est.format).c_str(),
              est.trajectory.size());
  if (indexed) {
    std::printf("pairs:        %zu (by index)\n", ate.pairs.size());
  } else {
    std::printf("pairs:        %zu (by time, max difference %s s, offset %s s)\n", ate.pairs.size(),
                o.max_diff.c_str(), o.offset.c_str());
  }
  std::printf("alignment:    %s", o.align.c_str());
  if (ate.alignment.mode == AlignmentMode::kSim3) std::printf(", scale %.6f", ate.alignment.scale);
  std::printf("\n");
  print_stats("ATE [m]", ate.stats, 1.0, 6);
  const std::string rpe_name = "RPE/" + number_text(rpe.config.delta) + " " + to_string(rpe.config.unit);
  print_stats((rpe_name + " trans [m]").c_str(), rpe.translation_m, 1.0, 6);
  print_stats((rpe_name + " rot [deg]").c_str(), rpe.rotation_rad, kDegreesPerRadian, 4);
  if (rpe.skipped_across_gaps > 0) {
    std::printf("  RPE left out %zu pair(s) whose partner lies across a gap in the stamps (a step over twice the "
                "median)\n",
                rpe.skipped_across_gaps);
  }
}

void write_json(const fs::path& path, const nlohmann::json& j) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw InputError(path.string(), "cannot open the file for writing");
  out << j.dump(2) << "\n";
  if (!out.flush()) throw InputError(path.string(), "write failed");
}

void run_eval(const EvalOptions& o, const GlobalOptions& global) {
  const EvalSettings s = settings_from(o);
  const TrajectoryFile gt = read_input(o.gt_path, s.gt_read);
  const TrajectoryFile est = read_input(o.est_path, s.est_read);
  const bool indexed = by_index(o, gt, est);
  if (indexed && s.rpe.unit == RpeUnit::kSeconds) {
    throw InputError("--rpe-unit", "s needs time stamps, and these poses pair by index (KITTI has none): use frames or m");
  }
  // Pairing by index takes the first min(n, m) poses of each: with counts that differ, say so (a partial run
  // pairs correctly only when both files start at the same frame).
  if (indexed && gt.trajectory.size() != est.trajectory.size()) {
    std::cerr << "fleetslam: warning: pairing by index: " << o.gt_path << " has " << gt.trajectory.size() << " poses, "
              << o.est_path << " " << est.trajectory.size() << "; only the first "
              << std::min(gt.trajectory.size(), est.trajectory.size()) << " of each are paired\n";
  }
  const auto pairs = indexed ? associate_by_index(gt.trajectory, est.trajectory)
                             : associate_by_time(gt.trajectory, est.trajectory, s.association);
  const AteResult ate = compute_ate(gt.trajectory, est.trajectory, pairs, s.align);
  check_ate(ate, o, indexed);
  const RpeResult rpe = compute_rpe(gt.trajectory, est.trajectory, pairs, s.rpe, ate.alignment.scale);
  if (rpe.translation_errors_m.empty()) {
    std::cerr << "fleetslam: warning: no two paired poses are " << o.rpe_delta << " " << o.rpe_unit
              << " apart (--rpe-delta, --rpe-unit): no RPE\n";
  }
  // The output folder first: a refused one ends with its one line, not after the whole report.
  const fs::path out_dir = o.out_dir;
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) throw InputError(o.out_dir, "cannot create the output folder: " + ec.message());
  if (!global.quiet) print_report(o, gt, est, indexed, ate, rpe);
  write_json(out_dir / "metrics.json", metrics_json(o, s.association, gt, est, indexed, ate, rpe));
  const Trajectory aligned = apply_alignment(ate.alignment, est.trajectory);
  // KITTI in, KITTI out: its poses have no time, and TUM lines would carry their indices as stamps.
  write_trajectory(out_dir / "estimate_aligned.txt", aligned,
                   est.format == TrajectoryFormat::kKitti ? TrajectoryFormat::kKitti : TrajectoryFormat::kTum);
  TrajectoryPlotLabels labels;
  labels.title = fs::path(o.est_path).filename().string() + " vs " + fs::path(o.gt_path).filename().string();
  labels.subtitle = o.align + " alignment, " + std::to_string(ate.pairs.size()) + " pairs, ATE RMSE " +
                    number_text(ate.stats.rmse) + " m";
  labels.errors_over_time = !indexed;
  write_trajectory_svg(out_dir / "trajectories.svg", gt.trajectory, aligned, ate, labels);
  if (!global.quiet) std::printf("wrote:        %s/{metrics.json,estimate_aligned.txt,trajectories.svg}\n", o.out_dir.c_str());
}

}  // namespace

void add_eval_command(CLI::App& app, const GlobalOptions& global) {
  auto options = std::make_shared<EvalOptions>();
  CLI::App* cmd = app.add_subcommand(
      "eval",
      "Evaluate an estimated trajectory against ground truth: ATE (as the TUM benchmark's evaluate_ate.py) and "
      "RPE. Writes metrics.json, estimate_aligned.txt (TUM; KITTI for a KITTI estimate) and trajectories.svg to --out.");
  cmd->add_option("--gt", options->gt_path, "Ground-truth trajectory file")->required();
  cmd->add_option("--est", options->est_path, "Estimated trajectory file")->required();
  cmd->add_option("--align", options->align, "Alignment of the estimate onto the ground truth")
      ->check(CLI::IsMember({"se3", "sim3", "none"}))
      ->capture_default_str();
  cmd->add_option("--format", options->est_format, "Format of the estimate (auto: detected from the content)")
      ->check(CLI::IsMember({"auto", "tum", "euroc", "kitti"}))
      ->capture_default_str();
  cmd->add_option("--gt-format", options->gt_format, "Format of the ground truth (auto: detected)")
      ->check(CLI::IsMember({"auto", "tum", "euroc", "kitti"}))
      ->capture_default_str();
  cmd->add_option("--associate", options->associate, "Pairing of poses (auto: by index when a file is KITTI)")
      ->check(CLI::IsMember({"auto", "time", "index"}))
      ->capture_default_str();
  cmd->add_option("--max-diff", options->max_diff, "Largest stamp difference of a pair, seconds")->capture_default_str();
  cmd->add_option("--offset", options->offset, "Seconds added to the estimate's stamps")->capture_default_str();
  cmd->add_option("--rpe-delta", options->rpe_delta, "RPE step, in --rpe-unit")->capture_default_str();
  cmd->add_option("--rpe-unit", options->rpe_unit, "RPE step unit: frames (pairs), m (along ground truth) or s")
      ->check(CLI::IsMember({"frames", "m", "s"}))
      ->capture_default_str();
  cmd->add_option("--duplicates", options->duplicates,
                  "Repeated timestamps in a file: keep-last (as the TUM tools), keep-first, or error")
      ->check(CLI::IsMember({"keep-last", "keep-first", "error"}))
      ->capture_default_str();
  cmd->add_option("--out", options->out_dir, "Output folder (created)")->capture_default_str();
  cmd->callback([options, &global] { run_eval(*options, global); });
}

}  // namespace fleetslam::tools
