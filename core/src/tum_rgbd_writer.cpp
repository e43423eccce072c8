// TUM RGB-D writer: images, lists, ground truth, accelerometer and camera.yaml.

#include <cmath>
#include <fstream>

#include <opencv2/core.hpp>
#include <spdlog/logger.h>

#include "dataset_internal.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/core/orbslam_settings.hpp"
#include "fleetslam/core/tum_rgbd.hpp"

namespace fleetslam::core {

using namespace dataset_detail;

namespace {

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

// camera.yaml: the rig as an ORB-SLAM3 RGB-D settings file. A rig without a virtual baseline gets the
// one of ORB-SLAM's TUM settings (TUM1.yaml: Camera.bf 40), and the close-depth threshold is theirs too.
constexpr double kTumVirtualBf = 40.0;
constexpr double kTumThDepthBaselines = 40.0;

OrbSlamSettings tum_camera_settings(const SensorRig& rig) {
  OrbSlamSettings s;
  s.rig = rig;
  s.rig.mode = SensorMode::kRgbd;
  s.rig.cam1.reset();
  s.rig.T_cam0_cam1 = Eigen::Isometry3d::Identity();
  // The layout keeps only an accelerometer (no gyro), so the file describes no IMU.
  s.rig.imu.reset();
  s.rig.T_body_cam0.reset();
  if (!(s.rig.bf > 0.0)) s.rig.bf = kTumVirtualBf;
  s.th_depth = kTumThDepthBaselines;
  return s;
}

}  // namespace

struct TumRgbdWriter::Files {
  std::ofstream rgb;
  std::ofstream depth;
  std::ofstream accelerometer;  // opened with the first IMU sample
  Trajectory groundtruth;
  Trajectory imu_groundtruth;  // camera poses at the IMU samples of the frames that brought their truth
};

TumRgbdWriter::TumRgbdWriter(const std::filesystem::path& root, const SensorRig& rig, Logger logger)
    : root_(root), rig_(rig), logger_(or_null(std::move(logger))), files_(std::make_unique<Files>()) {
  if (!(rig_.depth_scale > 0.0)) throw InputError(root.string(), "the rig's depth scale must be positive");
  staging_ = begin_staged_folder(root_);
  std::filesystem::create_directories(staging_ / "rgb");
  std::filesystem::create_directories(staging_ / "depth");
  write_orbslam_settings(staging_ / kTumCameraFile, tum_camera_settings(rig_));
  files_->rgb.open(staging_ / "rgb.txt");
  files_->depth.open(staging_ / "depth.txt");
  files_->rgb << "# color images\n# written by fleetslam\n# timestamp filename\n";
  files_->depth << "# depth maps\n# written by fleetslam\n# timestamp filename\n";
  if (!files_->rgb || !files_->depth) throw InputError(staging_.string(), "cannot write the image lists");
}

TumRgbdWriter::~TumRgbdWriter() {
  if (closed_) return;
  logger_->warn("{}: the sequence was not completed ({} frames written); it is left there, not in {}",
                staging_.string(), frames_, root_.string());
}

void TumRgbdWriter::write(const SensorFrame& frame) {
  FLEETSLAM_CHECK(!closed_, "write() after close()");
  check_frame(frame);
  if (frames_ > 0 && frame.t_ns <= last_t_ns_) throw InputError(frame_name(frame), "stamp does not increase");
  // What the reader would refuse is refused here, before anything of the frame is written.
  if (frame.image.cols != rig_.cam0.width() || frame.image.rows != rig_.cam0.height()) {
    throw InputError(frame_name(frame), "image is " + std::to_string(frame.image.cols) + "x" +
                                            std::to_string(frame.image.rows) + " but the rig's camera is " +
                                            std::to_string(rig_.cam0.width()) + "x" + std::to_string(rig_.cam0.height()));
  }
  std::optional<TimeNs> last_imu = last_imu_t_ns_;
  for (const ImuSample& s : frame.imu) {
    if (last_imu && s.t_ns <= *last_imu) throw InputError(frame_name(frame), "accelerometer stamps do not increase");
    last_imu = s.t_ns;
  }
  check_imu_truth_pairs(frame, frame_name(frame));
  last_imu_t_ns_ = last_imu;
  const std::string stamp = stamp_text(frame.t_ns);
  write_image(staging_ / "rgb" / (stamp + ".png"), frame.image);
  write_image(staging_ / "depth" / (stamp + ".png"), depth_to_raw(frame.depth_m, rig_.depth_scale, depth_out_of_range_));
  files_->rgb << stamp << " rgb/" << stamp << ".png\n";
  files_->depth << stamp << " depth/" << stamp << ".png\n";
  if (!frame.imu.empty() && !files_->accelerometer.is_open()) {
    files_->accelerometer.open(staging_ / "accelerometer.txt");
    files_->accelerometer << "# accelerometer data\n# written by fleetslam\n# timestamp ax ay az\n";
  }
  for (const ImuSample& s : frame.imu) {
    files_->accelerometer << stamp_text(s.t_ns) << ' ' << exact(s.accel_mps2.x()) << ' '
                          << exact(s.accel_mps2.y()) << ' ' << exact(s.accel_mps2.z()) << '\n';
  }
  if (frame.T_world_cam_gt) files_->groundtruth.push_back({frame.t_ns, *frame.T_world_cam_gt});
  if (rig_.T_body_cam0) {
    for (const ImuTruth& truth : frame.imu_truth) {
      files_->imu_groundtruth.push_back({truth.t_ns, truth.T_world_body * *rig_.T_body_cam0});
    }
  }
  last_t_ns_ = frame.t_ns;
  ++frames_;
}

void TumRgbdWriter::close() {
  if (closed_) return;
  closed_ = true;
  for (std::ofstream* out : {&files_->rgb, &files_->depth, &files_->accelerometer}) {
    if (out->is_open()) out->close();
    if (out->fail()) throw InputError(staging_.string(), "cannot write the lists");
  }
  if (!files_->imu_groundtruth.empty()) {
    // The camera's poses at the IMU samples too (TUM's motion capture runs faster than the camera).
    std::vector<TimeNs> frame_t;
    std::vector<TimeNs> sample_t;
    for (const StampedPose& p : files_->groundtruth) frame_t.push_back(p.t_ns);
    for (const StampedPose& p : files_->imu_groundtruth) sample_t.push_back(p.t_ns);
    Trajectory merged;
    for (const MergedRow& row : merge_in_time(frame_t, sample_t)) {
      merged.push_back(row.from_first ? files_->groundtruth[row.index] : files_->imu_groundtruth[row.index]);
    }
    files_->groundtruth = std::move(merged);
  }
  if (!files_->groundtruth.empty()) {
    write_trajectory(staging_ / "groundtruth.txt", files_->groundtruth, TrajectoryFormat::kTum);
  }
  commit_staged_folder(staging_, root_);
  if (depth_out_of_range_ > 0) {
    logger_->warn("{}: {} depth values beyond the 16-bit range written as 0 (no measurement)", root_.string(),
                  depth_out_of_range_);
  }
  logger_->info("{}: wrote {} RGB-D frames", root_.string(), frames_);
}

}  // namespace fleetslam::core
