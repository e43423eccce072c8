// TUM RGB-D writer and the camera.yaml calibration file beside a sequence.

#include <cmath>
#include <fstream>
#include <stdexcept>

#include <opencv2/core.hpp>
#include <spdlog/logger.h>

#include "dataset_internal.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/core/tum_rgbd.hpp"

namespace fleetslam::core {

using namespace dataset_detail;

namespace {

double optional_number(const SettingsFile& file, const std::string& key, double fallback) {
  return file.has(key) ? file.number(key) : fallback;
}

int whole_number(const SettingsFile& file, const std::string& key) {
  const double value = file.number(key);
  if (value != std::floor(value) || value < 1.0 || value > 1e5) {
    throw InputError(file.where(key), "expected a positive whole number of pixels");
  }
  return static_cast<int>(value);
}

// Metres -> raw 16-bit units. NaN, negative and zero mean no measurement (0); depths past the 16-bit
// range become 0 too rather than a wrong saturated value, and are counted.
cv::Mat depth_to_raw(const cv::Mat& depth_m, double scale, std::size_t& out_of_range) {
  cv::Mat raw(depth_m.size(), CV_16UC1);
  for (int r = 0; r < depth_m.rows; ++r) {
    const float* src = depth_m.ptr<float>(r);
    auto* dst = raw.ptr<std::uint16_t>(r);
    for (int c = 0; c < depth_m.cols; ++c) {
      const double value = static_cast<double>(src[c]) * scale;
      const bool valid = std::isfinite(value) && value > 0.0;
      const bool in_range = value < 65535.5;
      if (valid && !in_range) ++out_of_range;
      dst[c] = valid && in_range ? static_cast<std::uint16_t>(std::lround(value)) : 0;
    }
  }
  return raw;
}

// Sub-microsecond stamps keep all nine decimals so that reading back gives the same nanoseconds.
std::string stamp_text(TimeNs t_ns) { return format_seconds(t_ns, t_ns % 1000 == 0 ? 6 : 9); }

std::string frame_name(const SensorFrame& frame) {
  return "frame " + std::to_string(frame.sequence) + " (t " + format_seconds(frame.t_ns) + " s)";
}

void check_frame(const SensorFrame& frame) {
  if (frame.image.empty()) throw InputError(frame_name(frame), "has no image");
  if (frame.image.type() != CV_8UC3 && frame.image.type() != CV_8UC1) {
    throw InputError(frame_name(frame), "image must be 8-bit colour or gray");
  }
  if (frame.depth_m.empty()) {
    throw InputError(frame_name(frame), "has no depth map: the TUM RGB-D layout needs RGB-D frames");
  }
  if (frame.depth_m.type() != CV_32FC1 || frame.depth_m.size() != frame.image.size()) {
    throw InputError(frame_name(frame), "depth map must be CV_32FC1 metres of the image's size");
  }
}

}  // namespace

SensorRig read_tum_camera_file(const std::filesystem::path& path) {
  const SettingsFile file(path);
  const RadTan distortion{optional_number(file, "Camera.k1", 0.0), optional_number(file, "Camera.k2", 0.0),
                          optional_number(file, "Camera.p1", 0.0), optional_number(file, "Camera.p2", 0.0),
                          optional_number(file, "Camera.k3", 0.0)};
  SensorRig rig;
  rig.mode = SensorMode::kRgbd;
  try {
    rig.cam0 = PinholeCamera(whole_number(file, "Camera.width"), whole_number(file, "Camera.height"),
                             file.number("Camera.fx"), file.number("Camera.fy"), file.number("Camera.cx"),
                             file.number("Camera.cy"), distortion);
  } catch (const std::invalid_argument& e) {
    throw InputError(file.file(), std::string("invalid camera: ") + e.what());
  }
  rig.fps = optional_number(file, "Camera.fps", 30.0);
  rig.bf = optional_number(file, "Camera.bf", 40.0);
  rig.rgb_order = optional_number(file, "Camera.RGB", 0.0) != 0.0;
  rig.depth_scale = optional_number(file, "DepthMapFactor", 5000.0);
  if (!(rig.depth_scale > 0.0)) throw InputError(file.where("DepthMapFactor"), "must be positive");
  return rig;
}

void write_tum_camera_file(const std::filesystem::path& path, const SensorRig& rig) {
  std::ofstream out(path);
  const PinholeCamera& c = rig.cam0;
  const RadTan& d = c.distortion();
  out << "%YAML:1.0\n# Calibration of this sequence, written by fleetslam (ORB-SLAM settings keys).\n"
      << "Camera.type: \"PinHole\"\n"
      << "Camera.fx: " << exact(c.fx()) << "\nCamera.fy: " << exact(c.fy()) << "\nCamera.cx: " << exact(c.cx())
      << "\nCamera.cy: " << exact(c.cy()) << "\nCamera.k1: " << exact(d.k1) << "\nCamera.k2: " << exact(d.k2)
      << "\nCamera.p1: " << exact(d.p1) << "\nCamera.p2: " << exact(d.p2) << "\nCamera.k3: " << exact(d.k3)
      << "\nCamera.width: " << c.width() << "\nCamera.height: " << c.height() << "\nCamera.fps: " << exact(rig.fps)
      << "\nCamera.bf: " << exact(rig.bf) << "\nCamera.RGB: " << (rig.rgb_order ? 1 : 0)
      << "\nDepthMapFactor: " << exact(rig.depth_scale) << "\n";
  if (!out) throw InputError(path.string(), "cannot write the calibration file");
}

struct TumRgbdWriter::Files {
  std::ofstream rgb;
  std::ofstream depth;
  std::ofstream accelerometer;  // opened with the first IMU sample
  Trajectory groundtruth;
};

TumRgbdWriter::TumRgbdWriter(const std::filesystem::path& root, const SensorRig& rig, Logger logger)
    : root_(root), rig_(rig), logger_(or_null(std::move(logger))), files_(std::make_unique<Files>()) {
  if (!(rig_.depth_scale > 0.0)) throw InputError(root.string(), "the rig's depth scale must be positive");
  create_output_folder(root_);
  std::filesystem::create_directories(root_ / "rgb");
  std::filesystem::create_directories(root_ / "depth");
  write_tum_camera_file(root_ / kTumCameraFile, rig_);
  files_->rgb.open(root_ / "rgb.txt");
  files_->depth.open(root_ / "depth.txt");
  files_->rgb << "# color images\n# written by fleetslam\n# timestamp filename\n";
  files_->depth << "# depth maps\n# written by fleetslam\n# timestamp filename\n";
  if (!files_->rgb || !files_->depth) throw InputError(root_.string(), "cannot write the image lists");
}

TumRgbdWriter::~TumRgbdWriter() {
  try {
    close();
  } catch (const std::exception& e) {
    logger_->error("{}: closing the sequence failed: {}", root_.string(), e.what());
  }
}

void TumRgbdWriter::write(const SensorFrame& frame) {
  FLEETSLAM_CHECK(!closed_, "write() after close()");
  check_frame(frame);
  if (frames_ > 0 && frame.t_ns <= last_t_ns_) throw InputError(frame_name(frame), "stamp does not increase");
  const std::string stamp = stamp_text(frame.t_ns);
  write_image(root_ / "rgb" / (stamp + ".png"), frame.image);
  write_image(root_ / "depth" / (stamp + ".png"), depth_to_raw(frame.depth_m, rig_.depth_scale, depth_out_of_range_));
  files_->rgb << stamp << " rgb/" << stamp << ".png\n";
  files_->depth << stamp << " depth/" << stamp << ".png\n";
  if (!frame.imu.empty() && !files_->accelerometer.is_open()) {
    files_->accelerometer.open(root_ / "accelerometer.txt");
    files_->accelerometer << "# accelerometer data\n# written by fleetslam\n# timestamp ax ay az\n";
  }
  for (const ImuSample& s : frame.imu) {
    files_->accelerometer << stamp_text(s.t_ns) << ' ' << exact(s.accel_mps2.x()) << ' '
                          << exact(s.accel_mps2.y()) << ' ' << exact(s.accel_mps2.z()) << '\n';
  }
  if (frame.T_world_cam_gt) files_->groundtruth.push_back({frame.t_ns, *frame.T_world_cam_gt});
  last_t_ns_ = frame.t_ns;
  ++frames_;
}

void TumRgbdWriter::close() {
  if (closed_) return;
  closed_ = true;
  for (std::ofstream* out : {&files_->rgb, &files_->depth, &files_->accelerometer}) {
    if (out->is_open()) out->close();
    if (out->fail()) throw InputError(root_.string(), "cannot write the lists");
  }
  if (!files_->groundtruth.empty()) {
    write_trajectory(root_ / "groundtruth.txt", files_->groundtruth, TrajectoryFormat::kTum);
  }
  if (depth_out_of_range_ > 0) {
    logger_->warn("{}: {} depth values beyond the 16-bit range written as 0 (no measurement)", root_.string(),
                  depth_out_of_range_);
  }
  logger_->info("{}: wrote {} RGB-D frames", root_.string(), frames_);
}

}  // namespace fleetslam::core
