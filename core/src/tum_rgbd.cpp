// TUM RGB-D reader: lists, RGB/depth association, calibration, ground truth and accelerometer.

#include "fleetslam/core/tum_rgbd.hpp"

#include <algorithm>
#include <stdexcept>
#include <system_error>
#include <tuple>

#include <spdlog/logger.h>

#include "dataset_internal.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/core/orbslam_settings.hpp"

namespace fleetslam::core {

using namespace dataset_detail;

std::vector<std::pair<std::size_t, std::size_t>> associate_stamps(const std::vector<TimeNs>& a,
                                                                  const std::vector<TimeNs>& b,
                                                                  TimeNs max_difference_ns) {
  // Candidates are pairs strictly closer than the limit, as in associate.py; b is sorted, so each a
  // only looks at the window of b around it.
  std::vector<std::tuple<TimeNs, std::size_t, std::size_t>> candidates;
  for (std::size_t i = 0; i < a.size(); ++i) {
    auto j = std::upper_bound(b.begin(), b.end(), saturating_add(a[i], -max_difference_ns));
    for (; j != b.end() && *j < saturating_add(a[i], max_difference_ns); ++j) {
      const TimeNs difference = *j > a[i] ? *j - a[i] : a[i] - *j;
      candidates.emplace_back(difference, i, static_cast<std::size_t>(j - b.begin()));
    }
  }
  // Closest pairs first; ties go to the earlier stamps (the tuple order of associate.py).
  std::sort(candidates.begin(), candidates.end());
  std::vector<bool> used_a(a.size(), false);
  std::vector<bool> used_b(b.size(), false);
  std::vector<std::pair<std::size_t, std::size_t>> matches;
  for (const auto& [difference, i, j] : candidates) {
    if (used_a[i] || used_b[j]) continue;
    used_a[i] = used_b[j] = true;
    matches.emplace_back(i, j);
  }
  std::sort(matches.begin(), matches.end());
  return matches;
}

namespace {

// The benchmark's published Kinect calibrations (ROS default intrinsics for freiburg3, which
// comes undistorted).
struct FreiburgCamera {
  double fx, fy, cx, cy;
  Distortion distortion;
};

const FreiburgCamera& freiburg_camera(int freiburg) {
  static const FreiburgCamera kCameras[] = {
      {517.3, 516.5, 318.6, 255.3, {0.2624, -0.9531, -0.0054, 0.0026, 1.1633}},
      {520.9, 521.0, 325.1, 249.7, {0.2312, -0.7849, -0.0033, -0.0001, 0.9172}},
      {535.4, 539.2, 320.1, 247.6, {}},
  };
  if (freiburg < 1 || freiburg > 3) throw std::invalid_argument("freiburg camera must be 1, 2 or 3");
  return kCameras[freiburg - 1];
}

std::string folder_name(const std::filesystem::path& root) {
  std::filesystem::path normal = std::filesystem::absolute(root).lexically_normal();
  if (normal.filename().empty()) normal = normal.parent_path();
  return normal.filename().string();
}

// Calibration: the caller's rig, else camera.yaml, else the freiburg defaults the folder name names.
SensorRig tum_rig(const std::filesystem::path& root, const DatasetConfig& config, DatasetInfo& info) {
  std::error_code ec;
  SensorRig rig;
  if (config.rig) {
    rig = *config.rig;
    info.calibration_source = config.rig_source.empty() ? "rig given by the caller" : config.rig_source;
  } else if (std::filesystem::exists(root / kTumCameraFile, ec)) {
    rig = read_orbslam_settings(root / kTumCameraFile, SensorMode::kRgbd).rig;
    info.calibration_source = (root / kTumCameraFile).string();
  } else if (const std::optional<int> freiburg = freiburg_from_name(folder_name(root))) {
    rig = tum_freiburg_rig(*freiburg);
    info.calibration_source = "freiburg" + std::to_string(*freiburg) + " defaults (from the folder name)";
  } else {
    throw InputError(root.string(), std::string("cannot tell the camera: no ") + kTumCameraFile +
                                        " and the folder name names no freiburg1/2/3 sequence; give a "
                                        "calibration (an ORB-SLAM settings file)");
  }
  if (config.depth_scale > 0.0) rig.depth_scale = config.depth_scale;
  if (!(rig.depth_scale > 0.0)) throw InputError(info.calibration_source, "depth scale must be positive");
  rig.mode = SensorMode::kRgbd;
  return rig;
}

std::vector<FrameEntry> pair_rgb_depth(const std::vector<ImageRow>& rgb, const std::vector<ImageRow>& depth,
                                       const DatasetConfig& config, DatasetInfo& info, const Logger& logger) {
  std::vector<TimeNs> rgb_t, depth_t;
  for (const ImageRow& row : rgb) rgb_t.push_back(row.t_ns);
  for (const ImageRow& row : depth) depth_t.push_back(row.t_ns);
  const auto matches = associate_stamps(rgb_t, depth_t, seconds_to_ns(config.max_association_difference_s));
  std::vector<FrameEntry> entries;
  std::vector<bool> matched(rgb.size(), false);
  for (const auto& [i, j] : matches) {
    matched[i] = true;
    FrameEntry entry;
    entry.t_ns = rgb[i].t_ns;
    entry.image = {rgb[i].image, rgb[i].where};
    entry.depth = {depth[j].image, depth[j].where};
    entries.push_back(std::move(entry));
  }
  for (std::size_t i = 0; i < rgb.size(); ++i) {
    if (matched[i]) continue;
    info.skipped.push_back({rgb[i].where, "no depth image within " +
                                              std::to_string(config.max_association_difference_s) + " s"});
    logger->debug("{}: {}", info.skipped.back().where, info.skipped.back().why);
  }
  if (entries.empty() && !rgb.empty()) {
    throw InputError((info.root / "rgb.txt").string() + ", " + (info.root / "depth.txt").string(),
                     "no RGB image has a depth image within " + std::to_string(config.max_association_difference_s) +
                         " s (max_association_difference_s): nothing to read; are the lists of the same recording?");
  }
  if (matches.size() < rgb.size()) {
    logger->info("{}: {} of {} RGB images have no depth image to pair with", info.root.string(),
                 rgb.size() - matches.size(), rgb.size());
  }
  return entries;
}

// accelerometer.txt: "timestamp ax ay az"; the Kinect has no gyroscope, so gyro stays zero.
std::vector<ImuSample> read_accelerometer(const std::filesystem::path& file) {
  std::vector<ImuSample> samples;
  for (const TextRow& row : read_text_rows(file, "accelerometer list")) {
    const std::string where = at_line(file.string(), row.line);
    if (row.fields.size() != 4) {
      throw InputError(where, "expected 4 fields (timestamp ax ay az), found " + std::to_string(row.fields.size()));
    }
    const std::optional<TimeNs> t_ns = parse_seconds(row.fields[0]);
    if (!t_ns) throw InputError(where, "timestamp '" + row.fields[0] + "' is not a valid time");
    if (!samples.empty() && *t_ns <= samples.back().t_ns) throw InputError(where, "timestamp does not increase");
    ImuSample sample;
    sample.t_ns = *t_ns;
    sample.accel_mps2 = {parse_number(row.fields[1], where, "ax"), parse_number(row.fields[2], where, "ay"),
                         parse_number(row.fields[3], where, "az")};
    samples.push_back(sample);
  }
  return samples;
}

void attach_accelerometer(RecordedSequence& sequence, const std::filesystem::path& file) {
  sequence.imu = read_accelerometer(file);
  sequence.info.imu_file = file.string();
  sequence.info.imu_samples = sequence.imu.size();
  sequence.info.imu_rate_hz = mean_rate_hz(sequence.imu);
  sequence.info.accelerometer_only = true;
}

}  // namespace

SensorRig tum_freiburg_rig(int freiburg) {
  const FreiburgCamera& c = freiburg_camera(freiburg);
  SensorRig rig;
  rig.mode = SensorMode::kRgbd;
  rig.cam0 = PinholeCamera(640, 480, c.fx, c.fy, c.cx, c.cy, c.distortion);
  rig.depth_scale = 5000.0;
  rig.bf = 40.0;  // ORB-SLAM's virtual baseline for the Kinect
  rig.fps = 30.0;
  rig.rgb_order = false;  // frames hold OpenCV's BGR order
  return rig;
}

std::optional<int> freiburg_from_name(const std::string& folder_name) {
  for (int n = 1; n <= 3; ++n) {
    const std::string digit = std::to_string(n);
    if (folder_name.find("freiburg" + digit) != std::string::npos ||
        folder_name.find("fr" + digit) != std::string::npos) {
      return n;
    }
  }
  return std::nullopt;
}

std::unique_ptr<FrameSource> open_tum_rgbd(const std::filesystem::path& root, const DatasetConfig& config,
                                           Logger logger) {
  logger = or_null(std::move(logger));
  std::error_code ec;
  if (!std::filesystem::is_directory(root, ec)) {
    throw InputError(root.string(), std::filesystem::exists(root, ec) ? "is a file; give the sequence's folder"
                                                                       : "no such folder");
  }
  RecordedSequence sequence;
  sequence.info.format = DatasetFormat::kTumRgbd;
  sequence.info.root = root;
  sequence.image_kind = ImageKind::kColour;
  sequence.rig = tum_rig(root, config, sequence.info);
  // The Kinect's accelerometer is all a TUM RGB-D sequence has: a calibration's IMU (one written for
  // another sensor) would have the agent integrate its zero gyro readings as rotations.
  if (sequence.rig.imu) {
    logger->warn("{}: the calibration ({}) describes an IMU, but a TUM RGB-D sequence has no gyroscope: not used",
                 root.string(), sequence.info.calibration_source);
    sequence.rig.imu.reset();
  }

  std::vector<ImageRow> rgb = read_image_list(root / "rgb.txt", StampUnit::kSeconds, root, "RGB image list");
  sequence.info.listed_frames = rgb.size();
  rgb = drop_absent_images(std::move(rgb), config.skip_unreadable_frames, sequence.info.skipped, logger);
  std::vector<ImageRow> depth =
      read_image_list(root / "depth.txt", StampUnit::kSeconds, root, "depth image list");
  depth = drop_absent_images(std::move(depth), config.skip_unreadable_frames, sequence.info.skipped, logger);
  sequence.entries = pair_rgb_depth(rgb, depth, config, sequence.info, logger);

  // The accelerometer first: the ground truth gives its samples their truth too.
  if (config.load_imu && std::filesystem::exists(root / "accelerometer.txt", ec)) {
    attach_accelerometer(sequence, root / "accelerometer.txt");
  }
  const std::filesystem::path gt_file =
      config.groundtruth_file.empty() ? root / "groundtruth.txt" : std::filesystem::path(config.groundtruth_file);
  if (!config.groundtruth_file.empty() || std::filesystem::exists(gt_file, ec)) {
    if (config.groundtruth_in_body_frame && !sequence.rig.T_body_cam0) {
      throw InputError(gt_file.string(), "holds body poses (--groundtruth-body; groundtruth_in_body_frame), but the calibration has no "
                                         "body-to-camera transform (T_body_cam0: IMU.T_b_c1 or Tbc)");
    }
    attach_groundtruth(sequence, gt_file, config.groundtruth_in_body_frame ? sequence.rig.T_body_cam0 : std::nullopt,
                       sequence.rig.T_body_cam0, config, !config.groundtruth_file.empty(), logger);
  }
  return make_recorded_source(std::move(sequence), config, std::move(logger));
}

}  // namespace fleetslam::core
