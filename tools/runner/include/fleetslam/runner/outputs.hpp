#pragma once
// Writing a run's outputs: text files with a clear error, and the JSON forms of what the agents report.

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "fleetslam/slam/loop_closing.hpp"

namespace fleetslam::runner {

// Creates `dir` and its parents when missing; InputError naming it when that fails.
void create_output_folder(const std::filesystem::path& dir);

// Removes the regular files of these names directly in `folder` (nothing else: an earlier run's outputs
// before a new run writes its own); returns how many were removed. Failures are ignored.
std::size_t remove_files_named(const std::filesystem::path& folder, const std::vector<std::string>& names);

// Writes `text` to `path` (truncating); InputError naming the file when that fails.
void write_text_file(const std::filesystem::path& path, const std::string& text);

// A sample of per-frame timings (ms) as metrics.json reports it: count, mean, median, p90, p95, max (the
// value at index floor(q * (n - 1)) of the sorted sample); null when empty.
nlohmann::json timing_stats_json(std::vector<double> values_ms);

// A loop closure as metrics.json reports it: keyframes, time, score, matches, the correction's size.
nlohmann::json loop_event_json(const slam::LoopEvent& event);
// Verified loop candidates the guards refused, by reason.
nlohmann::json loop_rejections_json(const slam::LoopRejections& rejections);

}  // namespace fleetslam::runner
