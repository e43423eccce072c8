#include "fleetslam/core/log.hpp"

#include <spdlog/logger.h>
#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/null_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>

#include "fleetslam/core/error.hpp"

namespace fleetslam::core {
namespace {

spdlog::level::level_enum to_spdlog(LogLevel level) {
  switch (level) {
    case LogLevel::kTrace: return spdlog::level::trace;
    case LogLevel::kDebug: return spdlog::level::debug;
    case LogLevel::kInfo: return spdlog::level::info;
    case LogLevel::kWarn: return spdlog::level::warn;
    case LogLevel::kError: return spdlog::level::err;
    case LogLevel::kOff: return spdlog::level::off;
  }
  return spdlog::level::info;
}

}  // namespace

Logger make_logger(const std::string& name, LogLevel level, const std::string& file) {
  std::vector<spdlog::sink_ptr> sinks;
  sinks.push_back(std::make_shared<spdlog::sinks::stderr_color_sink_mt>());
  if (!file.empty()) {
    try {
      sinks.push_back(std::make_shared<spdlog::sinks::basic_file_sink_mt>(file, /*truncate=*/true));
    } catch (const spdlog::spdlog_ex& e) {
      throw InputError(file, std::string("cannot open log file: ") + e.what());
    }
  }
  auto logger = std::make_shared<spdlog::logger>(name, sinks.begin(), sinks.end());
  logger->set_level(to_spdlog(level));
  logger->set_pattern("[%H:%M:%S.%e] [%n] [%^%l%$] %v");
  return logger;
}

Logger null_logger() {
  auto logger = std::make_shared<spdlog::logger>("null", std::make_shared<spdlog::sinks::null_sink_mt>());
  logger->set_level(spdlog::level::off);
  return logger;
}

Progress::Progress(std::string label, std::size_t total, Sink sink, Config config)
    : label_(std::move(label)), total_(total), sink_(std::move(sink)), config_(config) {
  if (config_.step <= 0.0) config_.step = 0.1;
}

void Progress::update(std::size_t done) {
  if (done <= done_ && !(done == 0 && next_report_ == 0.0)) return;
  done_ = std::min(done, total_);
  const double share = total_ == 0 ? 1.0 : static_cast<double>(done_) / static_cast<double>(total_);
  if (share + 1e-12 < next_report_ && done_ != total_) return;
  while (next_report_ <= share + 1e-12) next_report_ += config_.step;
  if (sink_) sink_(done_, total_, label_);
}

Progress::Sink Progress::log_sink(Logger logger) {
  return [logger = std::move(logger)](std::size_t done, std::size_t total, const std::string& label) {
    const double percent = total == 0 ? 100.0 : 100.0 * static_cast<double>(done) / static_cast<double>(total);
    logger->info("{}: {}/{} ({:.0f} %)", label, done, total, percent);
  };
}

}  // namespace fleetslam::core
