#include "cli_util.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iostream>

#include "fleetslam/core/error.hpp"
#include "fleetslam/core/se3.hpp"
#include "fleetslam/core/time.hpp"

namespace fleetslam::tools {

core::Logger make_cli_logger(const std::string& command, const GlobalOptions& global) {
  const core::LogLevel level =
      global.quiet ? core::LogLevel::kWarn : (global.verbose ? core::LogLevel::kDebug : core::LogLevel::kInfo);
  return core::make_logger(command, level);
}

nlohmann::json skipped_row_json(const core::SkippedRow& row) { return {{"where", row.where}, {"why", row.why}}; }

nlohmann::json skipped_rows_json(const std::vector<core::SkippedRow>& rows) {
  nlohmann::json json = nlohmann::json::array();
  for (const core::SkippedRow& row : rows) json.push_back(skipped_row_json(row));
  return json;
}

core::Progress make_progress(std::size_t total, const std::string& label, const core::Logger& logger) {
  if (::isatty(::fileno(stderr)) == 0) return core::Progress(label, total, core::Progress::log_sink(logger));
  const core::Progress::Sink bar = [](std::size_t done, std::size_t all, const std::string& what) {
    constexpr std::size_t kWidth = 40;
    const std::size_t filled = all > 0 ? std::min(kWidth, done * kWidth / all) : kWidth;
    std::cerr << "\r[" << std::string(filled, '#') << std::string(kWidth - filled, ' ') << "] "
              << (all > 0 ? done * 100 / all : 100) << " % (" << done << "/" << all << " " << what << ")"
              << (done >= all ? "\n" : "") << std::flush;
  };
  return core::Progress(label, total, bar, core::Progress::Config{0.01});
}

}  // namespace fleetslam::tools
