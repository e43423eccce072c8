#pragma once
// Logging goes through one spdlog logger that the caller passes in (no global logger is used by the
// libraries). Components take a Logger in their constructor; a null logger discards everything.

#include <cstddef>
#include <functional>
#include <memory>
#include <string>

namespace spdlog {
class logger;
}

namespace fleetslam::core {

using Logger = std::shared_ptr<spdlog::logger>;

enum class LogLevel { kTrace, kDebug, kInfo, kWarn, kError, kOff };

// A logger writing to stderr (and to `file` too when not empty). Throws InputError if the file
// cannot be opened. Loggers are independent objects; nothing is registered globally.
Logger make_logger(const std::string& name, LogLevel level = LogLevel::kInfo, const std::string& file = "");

// A logger that drops every message.
Logger null_logger();

// Progress of long work, reported through a callback (the CLI draws a bar; libraries log).
// Reports happen when the share done crosses each `step` (deterministic, no clock involved).
class Progress {
 public:
  struct Config {
    double step = 0.1;  // report every 10 % by default
  };
  // Called with (done, total, label).
  using Sink = std::function<void(std::size_t, std::size_t, const std::string&)>;

  Progress(std::string label, std::size_t total, Sink sink, Config config);
  Progress(std::string label, std::size_t total, Sink sink) : Progress(std::move(label), total, std::move(sink), Config{}) {}

  // Records that `done` items are finished (monotonic; smaller values are ignored).
  void update(std::size_t done);
  void finish() { update(total_); }
  std::size_t done() const { return done_; }

  // A sink that logs "label: done/total (p %)" at info level.
  static Sink log_sink(Logger logger);

 private:
  std::string label_;
  std::size_t total_;
  Sink sink_;
  Config config_;
  std::size_t done_ = 0;
  double next_report_ = 0.0;
};

}  // namespace fleetslam::core
