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

void write_text_file(const std::filesystem::path& path, const std::string& text) {
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  if (!file) throw InputError(path.string(), "cannot open the file for writing");
  file << text;
  if (!file.flush()) throw InputError(path.string(), "write failed");
}

nlohmann::json loop_event_json(const slam::LoopEvent& e) {
  return {{"t_s", core::ns_to_seconds(e.t_ns)}, {"keyframe", e.current}, {"loop_keyframe", e.loop}, {"score", e.score},
          {"bow_matches", e.bow_matches}, {"ransac_inliers", e.ransac_inliers}, {"inliers", e.inliers},
          {"fused_points", e.fused_points}, {"moved_keyframes", e.moved_keyframes}, {"global_ba", e.global_ba},
          {"correction_m", e.correction.translation().norm()},
          {"correction_deg", core::rotation_angle_rad(e.correction.linear()) * 180.0 / 3.14159265358979323846}};
}

}  // namespace fleetslam::tools
