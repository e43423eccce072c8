// Writing a run's outputs (outputs.hpp).

#include "fleetslam/runner/outputs.hpp"

#include <algorithm>
#include <fstream>
#include <system_error>

#include "fleetslam/core/error.hpp"
#include "fleetslam/core/se3.hpp"

namespace fleetslam::runner {

void create_output_folder(const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw InputError(dir.string(), "cannot create the output folder: " + ec.message());
}

std::size_t remove_files_named(const std::filesystem::path& folder, const std::vector<std::string>& names) {
  std::size_t removed = 0;
  for (const std::string& name : names) {
    std::error_code ec;
    if (std::filesystem::is_regular_file(folder / name, ec) && std::filesystem::remove(folder / name, ec)) ++removed;
  }
  return removed;
}

void write_text_file(const std::filesystem::path& path, const std::string& text) {
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  if (!file) throw InputError(path.string(), "cannot open the file for writing");
  file << text;
  if (!file.flush()) throw InputError(path.string(), "write failed");
}

nlohmann::json timing_stats_json(std::vector<double> values_ms) {
  if (values_ms.empty()) return nullptr;
  std::sort(values_ms.begin(), values_ms.end());
  double sum = 0.0;
  for (double v : values_ms) sum += v;
  const auto at = [&](double q) { return values_ms[static_cast<std::size_t>(q * static_cast<double>(values_ms.size() - 1))]; };
  return {{"count", values_ms.size()}, {"mean", sum / static_cast<double>(values_ms.size())}, {"median", at(0.5)},
          {"p90", at(0.9)}, {"p95", at(0.95)}, {"max", values_ms.back()}};
}

nlohmann::json loop_event_json(const slam::LoopEvent& e) {
  return {{"t_s", core::ns_to_seconds(e.t_ns)}, {"keyframe", e.current}, {"loop_keyframe", e.loop}, {"score", e.score},
          {"bow_matches", e.bow_matches}, {"ransac_inliers", e.ransac_inliers}, {"inliers", e.inliers},
          {"fused_points", e.fused_points}, {"moved_keyframes", e.moved_keyframes}, {"global_ba", e.global_ba},
          {"correction_m", e.correction.translation().norm()}, {"camera_shift_m", e.camera_shift_m},
          {"path_m", e.path_m}, {"confirmations", e.confirmations},
          {"correction_deg", core::rotation_angle_rad(e.correction.linear()) * 180.0 / 3.14159265358979323846}};
}

nlohmann::json loop_rejections_json(const slam::LoopRejections& r) {
  return {{"implausible_correction", r.implausible_correction}, {"unconfirmed", r.unconfirmed}};
}

}  // namespace fleetslam::runner
