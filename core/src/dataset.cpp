// Dataset formats: names, layout detection, and the reader / writer factories.

#include "fleetslam/core/dataset.hpp"

#include <system_error>

#include <spdlog/logger.h>

#include "dataset_internal.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/core/euroc.hpp"
#include "fleetslam/core/tum_rgbd.hpp"

namespace fleetslam::core {

std::string to_string(DatasetFormat format) {
  switch (format) {
    case DatasetFormat::kTumRgbd: return "tum_rgbd";
    case DatasetFormat::kEuroc: return "euroc";
    case DatasetFormat::kTumVi: return "tumvi";
  }
  return "unknown";
}

std::optional<DatasetFormat> dataset_format_from_string(const std::string& name) {
  for (DatasetFormat format : {DatasetFormat::kTumRgbd, DatasetFormat::kEuroc, DatasetFormat::kTumVi}) {
    if (to_string(format) == name) return format;
  }
  return std::nullopt;
}

double DatasetInfo::rate_hz() const {
  if (frames < 2 || last_t_ns <= first_t_ns) return 0.0;
  return static_cast<double>(frames - 1) / duration_s();
}

DatasetFormat detect_dataset_format(const std::filesystem::path& root) {
  std::error_code ec;
  if (!std::filesystem::is_directory(root, ec)) {
    throw InputError(root.string(), std::filesystem::exists(root, ec) ? "is a file; give the sequence's folder"
                                                                       : "no such folder");
  }
  if (std::filesystem::exists(root / "rgb.txt", ec)) return DatasetFormat::kTumRgbd;
  for (const std::filesystem::path& mav0 : {root / "mav0", root}) {
    if (!std::filesystem::is_directory(mav0 / "cam0", ec)) continue;
    // TUM-VI records motion capture in mocap0/; EuRoC has state_groundtruth_estimate0/ (or vicon0/).
    return std::filesystem::exists(mav0 / "mocap0", ec) ? DatasetFormat::kTumVi : DatasetFormat::kEuroc;
  }
  throw InputError(root.string(), "unknown dataset layout (expected rgb.txt of TUM RGB-D, or mav0/cam0/ of "
                                  "EuRoC / TUM-VI)");
}

std::unique_ptr<FrameSource> open_dataset(const std::filesystem::path& root, std::optional<DatasetFormat> format,
                                          const DatasetConfig& config, Logger logger) {
  const DatasetFormat chosen = format ? *format : detect_dataset_format(root);
  if (chosen == DatasetFormat::kTumRgbd) return open_tum_rgbd(root, config, std::move(logger));
  return open_euroc(root, chosen, config, std::move(logger));
}

std::unique_ptr<FrameSink> make_dataset_writer(const std::filesystem::path& root, DatasetFormat format,
                                               const SensorRig& rig, Logger logger) {
  if (format == DatasetFormat::kTumRgbd) return std::make_unique<TumRgbdWriter>(root, rig, std::move(logger));
  return std::make_unique<EurocWriter>(root, rig, std::move(logger), format);
}

std::size_t copy_frames(FrameSource& source, FrameSink& sink, Logger logger) {
  logger = dataset_detail::or_null(std::move(logger));
  Progress progress("frames", source.size(), Progress::log_sink(logger));
  std::size_t done = 0;
  while (std::optional<SensorFrame> frame = source.next()) {
    sink.write(*frame);
    progress.update(++done);
  }
  progress.finish();  // frames skipped as unreadable leave the count short of size()
  sink.close();
  return sink.frames_written();
}

}  // namespace fleetslam::core
