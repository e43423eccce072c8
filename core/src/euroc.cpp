// EuRoC / TUM-VI reader: image lists, stereo pairing, IMU and ground truth.

#include "fleetslam/core/euroc.hpp"

#include <system_error>

#include <spdlog/logger.h>

#include "dataset_internal.hpp"
#include "fleetslam/core/error.hpp"

namespace fleetslam::core {

using namespace dataset_detail;

namespace {

bool file_exists(const std::filesystem::path& path) {
  std::error_code ec;
  return std::filesystem::exists(path, ec);
}

std::vector<ImageRow> read_camera_rows(const std::filesystem::path& mav0, const std::string& camera,
                                       const DatasetConfig& config, DatasetInfo& info, const Logger& logger,
                                       std::size_t* listed = nullptr) {
  std::vector<ImageRow> rows = read_image_list(mav0 / camera / "data.csv", StampUnit::kNanoseconds,
                                               mav0 / camera / "data", camera + " image list");
  if (listed) *listed = rows.size();
  return drop_absent_images(std::move(rows), config.skip_unreadable_frames, info.skipped, logger);
}

FrameEntry mono_entry(const ImageRow& row) {
  FrameEntry entry;
  entry.t_ns = row.t_ns;
  entry.image = {row.image, row.where};
  return entry;
}

// Left and right images pair by identical stamps; a row without its partner is skipped with a warning.
std::vector<FrameEntry> pair_stereo(const std::vector<ImageRow>& left, const std::vector<ImageRow>& right,
                                    DatasetInfo& info, const Logger& logger) {
  std::vector<FrameEntry> entries;
  std::size_t i = 0, j = 0;
  const auto skip = [&](const ImageRow& row, const char* other) {
    info.skipped.push_back({row.where, std::string("no ") + other + " image with the same stamp"});
    logger->warn("{}: {}; frame skipped", row.where, info.skipped.back().why);
  };
  while (i < left.size() || j < right.size()) {
    if (j == right.size() || (i < left.size() && left[i].t_ns < right[j].t_ns)) {
      skip(left[i++], "cam1");
    } else if (i == left.size() || right[j].t_ns < left[i].t_ns) {
      skip(right[j++], "cam0");
    } else {
      FrameEntry entry = mono_entry(left[i++]);
      entry.right = {right[j].image, right[j].where};
      ++j;
      entries.push_back(std::move(entry));
    }
  }
  return entries;
}

// imu0/data.csv: "t_ns,wx,wy,wz,ax,ay,az".
std::vector<ImuSample> read_imu_csv(const std::filesystem::path& file) {
  std::vector<ImuSample> samples;
  static const char* kColumns[] = {"w_x", "w_y", "w_z", "a_x", "a_y", "a_z"};
  for (const TextRow& row : read_text_rows(file, "IMU list")) {
    const std::string where = at_line(file.string(), row.line);
    if (row.fields.size() != 7) {
      throw InputError(where, "expected 7 fields (t_ns, 3 gyro, 3 accel), found " + std::to_string(row.fields.size()));
    }
    const std::optional<TimeNs> t_ns = parse_nanoseconds(row.fields[0]);
    if (!t_ns) {
      throw InputError(where, "timestamp '" + row.fields[0] + "' is not integer nanoseconds (EuRoC's IMU stamps are; "
                              "one with a fraction is in seconds)");
    }
    if (!samples.empty() && *t_ns <= samples.back().t_ns) throw InputError(where, "timestamp does not increase");
    double v[6];
    for (std::size_t k = 0; k < 6; ++k) v[k] = parse_number(row.fields[k + 1], where, kColumns[k]);
    ImuSample sample;
    sample.t_ns = *t_ns;
    sample.gyro_radps = {v[0], v[1], v[2]};
    sample.accel_mps2 = {v[3], v[4], v[5]};
    samples.push_back(sample);
  }
  return samples;
}

void attach_imu(RecordedSequence& sequence, const std::filesystem::path& file) {
  sequence.imu = read_imu_csv(file);
  // An inertial rig without a sample could never initialise its IMU, and nothing would say why.
  if (sequence.imu.empty()) throw InputError(file.string(), "lists no IMU samples (leave out imu0/, or load_imu off)");
  sequence.info.imu_file = file.string();
  sequence.info.imu_samples = sequence.imu.size();
  sequence.info.imu_rate_hz = mean_rate_hz(sequence.imu);
}

// Calibration: the caller's rig, else the sensor.yaml files (TUM-VI often needs the former).
SensorRig euroc_rig(const std::filesystem::path& mav0, const DatasetConfig& config, bool stereo, bool inertial,
                    DatasetInfo& info) {
  if (config.rig) {
    info.calibration_source = config.rig_source.empty() ? "rig given by the caller" : config.rig_source;
    return *config.rig;
  }
  const std::filesystem::path cam0_yaml = mav0 / "cam0" / "sensor.yaml";
  if (!file_exists(cam0_yaml)) {
    throw InputError(cam0_yaml.string(), "missing camera calibration (TUM-VI exports may lack it); give the "
                                         "calibration as a rig (DatasetConfig::rig, e.g. an ORB-SLAM settings file)");
  }
  info.calibration_source = cam0_yaml.string();
  return read_euroc_rig(mav0, stereo, inertial);
}

// Ground truth: the caller's file (camera poses unless said otherwise), else the dataset's body poses.
// Body poses become camera poses through the rig's T_body_cam0, else cam0/sensor.yaml's T_BS (a rig from
// an ORB-SLAM settings file without IMU keys has none): never through an identity nobody gave.
void euroc_groundtruth(RecordedSequence& sequence, const std::filesystem::path& mav0, DatasetFormat format,
                       const DatasetConfig& config, const Logger& logger) {
  std::optional<Eigen::Isometry3d> T_body_cam0 = config.rig ? config.rig->T_body_cam0 : std::nullopt;
  const std::filesystem::path cam0_yaml = mav0 / "cam0" / "sensor.yaml";
  if (!T_body_cam0 && file_exists(cam0_yaml)) T_body_cam0 = read_euroc_T_BS(cam0_yaml);
  if (!config.groundtruth_file.empty()) {
    if (config.groundtruth_in_body_frame && !T_body_cam0) {
      throw InputError(config.groundtruth_file, "holds body poses (--groundtruth-body; groundtruth_in_body_frame), but the body-to-camera "
                                                "transform is unknown: the calibration has no T_body_cam0 (IMU.T_b_c1 "
                                                "or Tbc) and there is no cam0/sensor.yaml with T_BS");
    }
    attach_groundtruth(sequence, config.groundtruth_file,
                       config.groundtruth_in_body_frame ? T_body_cam0 : std::nullopt, sequence.rig.T_body_cam0, config,
                       true, logger);
    return;
  }
  std::vector<std::filesystem::path> candidates = {mav0 / "state_groundtruth_estimate0" / "data.csv",
                                                   mav0 / "mocap0" / "data.csv"};
  if (format == DatasetFormat::kTumVi) std::swap(candidates[0], candidates[1]);
  for (const std::filesystem::path& file : candidates) {
    if (!file_exists(file)) continue;
    if (!T_body_cam0) {
      logger->warn("{}: body poses left out, no ground truth: the body-to-camera transform is unknown (the "
                   "calibration has no T_body_cam0, IMU.T_b_c1 or Tbc, and there is no cam0/sensor.yaml with T_BS); "
                   "give one, or camera poses as the ground-truth file",
                   file.string());
      return;
    }
    attach_groundtruth(sequence, file, T_body_cam0, sequence.rig.T_body_cam0, config, false, logger);
    return;
  }
  logger->info("{}: no ground truth (no state_groundtruth_estimate0/ or mocap0/ data.csv; a ground-truth "
               "file can be given)", mav0.string());
}

}  // namespace

std::unique_ptr<FrameSource> open_euroc(const std::filesystem::path& root, DatasetFormat format,
                                        const DatasetConfig& config, Logger logger) {
  logger = or_null(std::move(logger));
  const std::filesystem::path mav0 = find_mav0(root);
  RecordedSequence sequence;
  sequence.info.format = format;
  sequence.info.root = root;
  sequence.image_kind = ImageKind::kGray;
  const bool has_cam1 = config.stereo && file_exists(mav0 / "cam1" / "data.csv");
  const bool has_imu = config.load_imu && file_exists(mav0 / "imu0" / "data.csv");
  const bool imu_yaml = has_imu && file_exists(mav0 / "imu0" / "sensor.yaml");
  if (has_imu && !imu_yaml && !config.rig) logger->warn("{}: imu0/sensor.yaml absent: default IMU noise", mav0.string());
  sequence.rig = euroc_rig(mav0, config, has_cam1, imu_yaml, sequence.info);
  const bool stereo = has_cam1 && sequence.rig.cam1.has_value();
  if (has_imu && !config.rig && !sequence.rig.imu) {
    sequence.rig.imu = ImuNoise{};
    sequence.rig.mode = stereo ? SensorMode::kStereoInertial : SensorMode::kMonoInertial;
  }
  if (has_cam1 && !stereo) logger->info("{}: the rig has no cam1: reading cam0 only", mav0.string());

  const std::vector<ImageRow> left =
      read_camera_rows(mav0, "cam0", config, sequence.info, logger, &sequence.info.listed_frames);
  if (stereo) {
    const std::vector<ImageRow> right = read_camera_rows(mav0, "cam1", config, sequence.info, logger);
    sequence.entries = pair_stereo(left, right, sequence.info, logger);
    if (sequence.entries.empty() && !left.empty() && !right.empty()) {
      throw InputError((mav0 / "cam1" / "data.csv").string(),
                       "no image shares its timestamp with one of cam0/data.csv (stereo pairs need identical stamps): "
                       "no stereo frames; read cam0 alone (monocular) or fix the stamps");
    }
  } else {
    for (const ImageRow& row : left) sequence.entries.push_back(mono_entry(row));
  }
  if (has_imu) attach_imu(sequence, mav0 / "imu0" / "data.csv");
  euroc_groundtruth(sequence, mav0, format, config, logger);
  return make_recorded_source(std::move(sequence), config, std::move(logger));
}

}  // namespace fleetslam::core
