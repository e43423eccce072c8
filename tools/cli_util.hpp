#pragma once
// What every subcommand of the CLI shares: its logger, its progress display, writing text outputs, and
// reading an optional config file into a typed config.

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "fleetslam/core/config.hpp"
#include "fleetslam/core/dataset.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/runner/outputs.hpp"

namespace fleetslam::tools {

// A logger named after the command, at the level --quiet / --verbose ask for.
core::Logger make_cli_logger(const std::string& command, const GlobalOptions& global);

// On a terminal, a bar redrawn in place ("[####    ] 45 % (450/1000 frames)"); otherwise a log line
// per 10 %.
core::Progress make_progress(std::size_t total, const std::string& label, const core::Logger& logger);

// A list row a reader dropped or skipped, as {"where": "file:line", "why": ...}; rows as an array.
nlohmann::json skipped_row_json(const core::SkippedRow& row);
nlohmann::json skipped_rows_json(const std::vector<core::SkippedRow>& rows);

// Shared with the runner library: creating output folders, writing text outputs, timings and loop closures as JSON.
using runner::create_output_folder;
using runner::loop_event_json;
using runner::loop_rejections_json;
using runner::remove_files_named;
using runner::timing_stats_json;
using runner::write_text_file;

// Whole numbers at least `min` (0 or 1 in practice), with a message that says so: CLI11's PositiveNumber
// and NonNegativeNumber print their range as "0.000000 to 1797693134862315708...".
inline CLI::Validator whole_number_at_least(long long min) {
  return CLI::Validator(
      [min](std::string& text) -> std::string {
        std::size_t used = 0;
        long long value = 0;
        try {
          value = std::stoll(text, &used);
        } catch (const std::exception&) {
          used = 0;
        }
        if (used == 0 || used != text.size()) return "must be a whole number, got '" + text + "'";
        if (value < min) return "must be at least " + std::to_string(min) + ", got " + text;
        return std::string();
      },
      min > 0 ? "POSITIVE" : "NONNEGATIVE");
}

// The config's defaults overridden by `file` (every key checked; none when `file` is empty).
template <class Config>
Config read_config_file(const std::string& file, Config config = Config{}) {
  if (file.empty()) return config;
  core::ConfigReader reader = core::ConfigReader::from_file(file).section("");
  config.visit(reader);
  reader.finish();
  return config;
}

}  // namespace fleetslam::tools
