// The FrameSource over an indexed recording: selection, then one frame decoded per next().

#include <algorithm>
#include <optional>
#include <system_error>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <spdlog/logger.h>

#include "dataset_internal.hpp"
#include "fleetslam/core/error.hpp"

namespace fleetslam::core::dataset_detail {
namespace {

std::string size_text(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

// Decodes one image; every failure is an InputError at the list row naming the image.
cv::Mat decode(const ImageRef& ref, int flags) {
  std::error_code ec;
  if (!std::filesystem::exists(ref.path, ec)) throw InputError(ref.where, "image " + ref.path.string() + " is absent");
  cv::Mat image;
  try {
    image = cv::imread(ref.path.string(), flags);
  } catch (const cv::Exception& e) {
    throw InputError(ref.where, "cannot decode image " + ref.path.string() + ": " + e.err);
  }
  if (image.empty()) {
    throw InputError(ref.where, "cannot decode image " + ref.path.string() + " (corrupt or not an image)");
  }
  return image;
}

void check_size(const cv::Mat& image, const PinholeCamera& camera, const ImageRef& ref) {
  if (image.cols == camera.width() && image.rows == camera.height()) return;
  throw InputError(ref.where, "image " + ref.path.string() + " is " + size_text(image.cols, image.rows) +
                                  " but the calibration says " + size_text(camera.width(), camera.height()));
}

// 16-bit raw depth -> metres; raw 0 (no measurement) stays 0.
cv::Mat decode_depth(const ImageRef& ref, double depth_scale) {
  const cv::Mat raw = decode(ref, cv::IMREAD_ANYDEPTH);
  if (raw.type() != CV_16UC1) {
    throw InputError(ref.where, "depth image " + ref.path.string() + " is not a 16-bit single-channel PNG");
  }
  cv::Mat depth_m;
  raw.convertTo(depth_m, CV_32FC1, 1.0 / depth_scale);
  return depth_m;
}

// Keeps the entries the config selects: index range, then time range, then stride.
std::vector<FrameEntry> select_entries(std::vector<FrameEntry> entries, const DatasetConfig& config) {
  if (entries.empty()) return entries;
  const TimeNs t_first = entries.front().t_ns;
  // Compared in nanoseconds: a frame 150000000 ns after the first is 0.15000000000000002 s in seconds,
  // past a stop offset of 0.15, and was dropped.
  const TimeNs start_ns = seconds_to_ns(config.start_offset_s);
  const bool has_stop = config.stop_offset_s >= 0.0;
  const TimeNs stop_ns = has_stop ? seconds_to_ns(config.stop_offset_s) : 0;
  const auto n = static_cast<std::int64_t>(entries.size());
  const std::int64_t stop = config.stop_index < 0 ? n : std::min(config.stop_index, n);
  std::vector<FrameEntry> selected;
  std::int64_t kept = 0;
  for (std::int64_t i = std::clamp<std::int64_t>(config.start_index, 0, n); i < stop; ++i) {
    FrameEntry& entry = entries[static_cast<std::size_t>(i)];
    const TimeNs offset_ns = entry.t_ns - t_first;
    if (offset_ns < start_ns) continue;
    if (has_stop && offset_ns > stop_ns) break;
    if (kept++ % config.stride == 0) selected.push_back(std::move(entry));
  }
  return selected;
}

class RecordedSource final : public FrameSource {
 public:
  RecordedSource(RecordedSequence sequence, const DatasetConfig& config, Logger logger)
      : seq_(std::move(sequence)), config_(config), logger_(or_null(std::move(logger))) {
    if (config_.stride < 1) throw InputError("dataset config:stride", "must be at least 1");
    seq_.entries = select_entries(std::move(seq_.entries), config_);
    fill_info();
    // The first frame has no previous frame: it gets the IMU samples of one frame period before it.
    std::vector<TimeNs> stamps;
    for (const FrameEntry& entry : seq_.entries) stamps.push_back(entry.t_ns);
    if (!stamps.empty()) last_t_ns_ = stamps.front() - median_interval_ns(stamps);
  }

  std::optional<SensorFrame> next() override {
    while (cursor_ < seq_.entries.size()) {
      const FrameEntry& entry = seq_.entries[cursor_++];
      SensorFrame frame = frame_without_images(entry);
      try {
        if (config_.load_images) load_images(entry, frame);
      } catch (const InputError& e) {
        if (!config_.skip_unreadable_frames) throw;
        // The IMU samples of a skipped frame go to the next frame so that integration has no hole.
        logger_->warn("{}; frame skipped", e.what());
        unreadable_.push_back({e.where(), e.why()});
        continue;
      }
      take_imu_until(entry.t_ns, frame);
      frame.sequence = yielded_++;
      return frame;
    }
    return std::nullopt;
  }

  std::size_t size() const override { return seq_.entries.size(); }
  const SensorRig& rig() const override { return seq_.rig; }
  const DatasetInfo& info() const override { return seq_.info; }
  const std::vector<SkippedRow>& unreadable_frames() const override { return unreadable_; }

 private:
  void fill_info() {
    DatasetInfo& info = seq_.info;
    info.frames = seq_.entries.size();
    info.frames_with_groundtruth = static_cast<std::size_t>(std::count_if(
        seq_.entries.begin(), seq_.entries.end(), [](const FrameEntry& e) { return e.T_world_cam_gt.has_value(); }));
    if (!seq_.entries.empty()) {
      info.first_t_ns = seq_.entries.front().t_ns;
      info.last_t_ns = seq_.entries.back().t_ns;
    }
  }

  SensorFrame frame_without_images(const FrameEntry& entry) const {
    SensorFrame frame;
    frame.robot_id = config_.robot_id;
    frame.t_ns = entry.t_ns;
    frame.T_world_cam_gt = entry.T_world_cam_gt;
    frame.imu_state_gt = entry.imu_state_gt;
    frame.image_path = entry.image.path.string();
    return frame;
  }

  void load_images(const FrameEntry& entry, SensorFrame& frame) const {
    const int flags = seq_.image_kind == ImageKind::kColour ? cv::IMREAD_COLOR : cv::IMREAD_GRAYSCALE;
    frame.image = decode(entry.image, flags);
    check_size(frame.image, seq_.rig.cam0, entry.image);
    if (!entry.right.empty()) {
      frame.right = decode(entry.right, flags);
      check_size(frame.right, seq_.rig.cam1 ? *seq_.rig.cam1 : seq_.rig.cam0, entry.right);
    }
    if (!entry.depth.empty()) {
      frame.depth_m = decode_depth(entry.depth, seq_.rig.depth_scale);
      check_size(frame.depth_m, seq_.rig.cam0, entry.depth);
    }
  }

  // The IMU samples with t in (last frame handed out, t_ns] into frame.imu, and the truth at those of them
  // where the sequence knows it into frame.imu_truth.
  void take_imu_until(TimeNs t_ns, SensorFrame& frame) {
    const auto by_time = [](TimeNs t, const ImuSample& s) { return t < s.t_ns; };
    const auto begin = std::upper_bound(seq_.imu.begin(), seq_.imu.end(), last_t_ns_, by_time);
    const auto end = std::upper_bound(begin, seq_.imu.end(), t_ns, by_time);
    last_t_ns_ = t_ns;
    frame.imu.assign(begin, end);
    if (seq_.imu_truth.empty() || begin == end) return;
    const auto first = seq_.imu_truth.begin() + (begin - seq_.imu.begin());
    const auto last = seq_.imu_truth.begin() + (end - seq_.imu.begin());
    for (auto it = first; it != last; ++it) {
      if (*it) frame.imu_truth.push_back(**it);
    }
  }

  RecordedSequence seq_;
  DatasetConfig config_;
  Logger logger_;
  std::vector<SkippedRow> unreadable_;
  std::size_t cursor_ = 0;
  std::int64_t yielded_ = 0;
  TimeNs last_t_ns_ = 0;
};

}  // namespace

std::unique_ptr<FrameSource> make_recorded_source(RecordedSequence sequence, const DatasetConfig& config,
                                                  Logger logger) {
  return std::make_unique<RecordedSource>(std::move(sequence), config, std::move(logger));
}

}  // namespace fleetslam::core::dataset_detail
