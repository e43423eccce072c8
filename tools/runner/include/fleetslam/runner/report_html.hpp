#pragma once
// report.html of `fleetslam run`: one self-contained page (inline CSS and SVG, no script, no external
// resource) showing the verdict with its pass/fail criteria, the robots' counts and accuracy, a top-down
// view of the merged map with every robot's trajectories, plans and goals, ATE and coverage over time,
// the keyframe policy's decisions and the stage timings. Every key of the input may be missing or have an
// odd type: what is there is shown, the rest is said to be "not available". Same JSON, same bytes.
//
// Input (every key optional):
//   {"title": str,
//    "metrics": {scenario, seed, simulated_s, wall_s, real_time_factor,
//                verdict: {passed, criteria: [{name, robot, value, limit, comparison, passed, note}]},
//                robots: [{name, status, frames, tracked, lost, keyframes, collisions, goals_reached,
//                          goals_total, ate_world_m: {rmse, mean, max}, timings_ms: {stage: {mean, median, p95}}}],
//                merged_map_accuracy: {map_points, mean_m, median_m, p95_m, completeness},
//                coverage: {final, free_cells_truth}, central_timings_ms: {stage: ms}},
//    "series": {robots: [{name, estimated_xy: [[t_s, x, y]], truth_xy: [[t_s, x, y]], ate_over_time: [[t_s, m]],
//                         keyframe_decisions: [[t_s, score, inserted]], plans: [{t_s, status, path_xy: [[x, y]]}],
//                         goals_xy: [[x, y]]}],
//               coverage_over_time: [[t_s, share]], map_points: [[x, y, z, r, g, b]]}}   (world frame, metres)

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

namespace fleetslam::runner {

// The whole page as one string.
std::string render_report_html(const nlohmann::json& report);

// Writes render_report_html(report) to `file` (its folder must exist); throws InputError naming the file
// when it cannot be written.
void write_report_html(const std::filesystem::path& file, const nlohmann::json& report);

}  // namespace fleetslam::runner
