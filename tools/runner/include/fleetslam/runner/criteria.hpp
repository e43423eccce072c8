#pragma once
// Judging a run: each enabled pass criterion (run_config.hpp CriteriaConfig) against the run's metrics.json.
//
// The verdict, as written to metrics.json["verdict"]:
//   {"passed": bool, "criteria": [{"name", "robot" ("" for run-wide), "value" (null when not measured),
//                                  "limit", "comparison" ("<=" | ">="), "passed", "note"}]}
// A criterion whose value could not be measured (a robot without a trajectory, no merged map) fails,
// with a note saying why; there is no silent pass.

#include <nlohmann/json.hpp>

#include "fleetslam/runner/run_config.hpp"

namespace fleetslam::runner {

// metrics: {"robots": [{"name", "frames", "tracked" (frames with a pose), "collisions", "planned", "goals_total", "goals_reached",
//            "goals_reached_true_distance_m" (one per goal reached), "ate_world_m": {"rmse"}}],
//            "merged_map_accuracy": {"mean_m", "p95_m", "completeness"},
//            "coverage": {"final"}, "real_time_factor"}
nlohmann::json judge(const CriteriaConfig& criteria, const nlohmann::json& metrics);

}  // namespace fleetslam::runner
