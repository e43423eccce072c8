// EuRoC and TUM-VI writer: a mav0 folder with cameras, IMU, calibration and body ground truth.

#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <spdlog/logger.h>

#include "dataset_internal.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/core/euroc.hpp"

namespace fleetslam::core {

using namespace dataset_detail;

namespace {

std::string matrix_row_major(const Eigen::Isometry3d& T) {
  std::string text;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) {
      if (!text.empty()) text += (c == 0 ? ",\n         " : ", ");
      text += exact(T.matrix()(r, c));
    }
  }
  return text;
}

void write_text(const std::filesystem::path& file, const std::string& text) {
  std::ofstream out(file);
  out << text;
  if (!out) throw InputError(file.string(), "cannot write the file");
}

void write_camera_yaml(const std::filesystem::path& file, const PinholeCamera& camera,
                       const Eigen::Isometry3d& T_body_cam, double rate_hz) {
  const Distortion& d = camera.distortion();
  std::string coefficients = d.is_equidistant()
                                 ? exact(d.k1) + ", " + exact(d.k2) + ", " + exact(d.k3) + ", " + exact(d.k4)
                                 : exact(d.k1) + ", " + exact(d.k2) + ", " + exact(d.p1) + ", " + exact(d.p2);
  if (!d.is_equidistant() && d.k3 != 0.0) coefficients += ", " + exact(d.k3);
  write_text(file, "%YAML:1.0\nsensor_type: camera\ncomment: written by fleetslam\n\nT_BS:\n  cols: 4\n  rows: 4\n"
                   "  data: [" + matrix_row_major(T_body_cam) + "]\n\nrate_hz: " + exact(rate_hz) +
                       "\nresolution: [" + std::to_string(camera.width()) + ", " + std::to_string(camera.height()) +
                       "]\ncamera_model: pinhole\nintrinsics: [" + exact(camera.fx()) + ", " + exact(camera.fy()) +
                       ", " + exact(camera.cx()) + ", " + exact(camera.cy()) +
                       "]\ndistortion_model: " + to_string(d.model) + "\ndistortion_coefficients: [" + coefficients +
                       "]\n");
}

void write_imu_yaml(const std::filesystem::path& file, const ImuNoise& noise) {
  write_text(file, "%YAML:1.0\nsensor_type: imu\ncomment: written by fleetslam\n\nT_BS:\n  cols: 4\n  rows: 4\n"
                   "  data: [" + matrix_row_major(Eigen::Isometry3d::Identity()) + "]\nrate_hz: " +
                       exact(noise.rate_hz) + "\n\ngyroscope_noise_density: " + exact(noise.gyro_noise_density) +
                       "\ngyroscope_random_walk: " + exact(noise.gyro_random_walk) +
                       "\naccelerometer_noise_density: " + exact(noise.accel_noise_density) +
                       "\naccelerometer_random_walk: " + exact(noise.accel_random_walk) + "\n");
}

// EuRoC's state ground truth: each body pose with the body's velocity in the world and the IMU biases.
void write_states(const std::filesystem::path& file, const Trajectory& body_poses, const std::vector<ImuStateGt>& states) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  std::string header = trajectory_file_header(TrajectoryFormat::kEuroc);
  header.pop_back();  // its newline: the state's columns follow
  out << header
      << ",v_RS_R_x [m s^-1],v_RS_R_y [m s^-1],v_RS_R_z [m s^-1],b_w_RS_S_x [rad s^-1],b_w_RS_S_y [rad s^-1],"
         "b_w_RS_S_z [rad s^-1],b_a_RS_S_x [m s^-2],b_a_RS_S_y [m s^-2],b_a_RS_S_z [m s^-2]\n";
  for (std::size_t i = 0; i < body_poses.size(); ++i) {
    std::string line = format_trajectory_line(body_poses[i], TrajectoryFormat::kEuroc);
    line.pop_back();  // its newline
    for (const Eigen::Vector3d* v : {&states[i].v_world_mps, &states[i].gyro_bias_radps, &states[i].accel_bias_mps2}) {
      for (int k = 0; k < 3; ++k) line += ',' + exact((*v)(k));
    }
    out << line << '\n';
  }
  out.flush();
  if (!out) throw InputError(file.string(), "cannot write the file");
}

std::string frame_name(const SensorFrame& frame) {
  return "frame " + std::to_string(frame.sequence) + " (t " + std::to_string(frame.t_ns) + " ns)";
}

// The frames' ground truth and the truth at their IMU samples merged in time order, one row per instant
// (a frame's own row where both have one).
void merge_truth(Trajectory& body_poses, std::vector<ImuStateGt>& states, bool with_states,
                 const std::vector<ImuTruth>& imu_truth) {
  std::vector<TimeNs> frame_t(body_poses.size());
  std::vector<TimeNs> sample_t(imu_truth.size());
  for (std::size_t i = 0; i < body_poses.size(); ++i) frame_t[i] = body_poses[i].t_ns;
  for (std::size_t i = 0; i < imu_truth.size(); ++i) sample_t[i] = imu_truth[i].t_ns;
  Trajectory poses;
  std::vector<ImuStateGt> merged_states;
  for (const MergedRow& row : merge_in_time(frame_t, sample_t)) {
    if (row.from_first) {
      poses.push_back(body_poses[row.index]);
      if (with_states) merged_states.push_back(states[row.index]);
    } else {
      poses.push_back({imu_truth[row.index].t_ns, imu_truth[row.index].T_world_body});
      if (with_states) merged_states.push_back(*imu_truth[row.index].state);
    }
  }
  body_poses = std::move(poses);
  states = std::move(merged_states);
}

}  // namespace

struct EurocWriter::Files {
  std::ofstream cam0;
  std::ofstream cam1;
  std::ofstream imu;
  TimeNs last_imu_t_ns = 0;
  bool any_imu = false;
  Trajectory body_poses;
  std::vector<ImuStateGt> states;  // one per body pose while every posed frame brought one
  bool all_states = true;
  std::vector<ImuTruth> imu_truth;  // the truth at the IMU samples of the frames that brought it
  bool all_truth_states = true;     // every entry of imu_truth has the IMU's state
};

EurocWriter::EurocWriter(const std::filesystem::path& root, const SensorRig& rig, Logger logger, DatasetFormat layout)
    : root_(root), layout_(layout), rig_(rig), logger_(or_null(std::move(logger))), files_(std::make_unique<Files>()) {
  FLEETSLAM_CHECK(layout_ == DatasetFormat::kEuroc || layout_ == DatasetFormat::kTumVi,
                  "EurocWriter writes the EuRoC or the TUM-VI layout");
  staging_ = begin_staged_folder(root);
  mav0_ = staging_ / "mav0";
  const Eigen::Isometry3d T_body_cam0 = rig_.T_body_cam0.value_or(Eigen::Isometry3d::Identity());
  const char* kImageHeader = "#timestamp [ns],filename\n";
  std::filesystem::create_directories(mav0_ / "cam0" / "data");
  write_camera_yaml(mav0_ / "cam0" / "sensor.yaml", rig_.cam0, T_body_cam0, rig_.fps);
  files_->cam0.open(mav0_ / "cam0" / "data.csv");
  files_->cam0 << kImageHeader;
  if (rig_.cam1) {
    std::filesystem::create_directories(mav0_ / "cam1" / "data");
    write_camera_yaml(mav0_ / "cam1" / "sensor.yaml", *rig_.cam1, T_body_cam0 * rig_.T_cam0_cam1, rig_.fps);
    files_->cam1.open(mav0_ / "cam1" / "data.csv");
    files_->cam1 << kImageHeader;
  }
  if (rig_.imu) {
    std::filesystem::create_directories(mav0_ / "imu0");
    write_imu_yaml(mav0_ / "imu0" / "sensor.yaml", *rig_.imu);
    files_->imu.open(mav0_ / "imu0" / "data.csv");
    files_->imu << "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
                   "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n";
  }
  write_text(mav0_ / "body.yaml", "%YAML:1.0\ncomment: written by fleetslam\n");
  if (!files_->cam0 || (rig_.cam1 && !files_->cam1) || (rig_.imu && !files_->imu)) {
    throw InputError(mav0_.string(), "cannot write the lists");
  }
}

EurocWriter::~EurocWriter() {
  if (closed_) return;
  logger_->warn("{}: the sequence was not completed ({} frames written); it is left there, not in {}",
                staging_.string(), frames_, root_.string());
}

void EurocWriter::write_images(const SensorFrame& frame) {
  // Both images are checked (and converted) before either is written.
  const auto gray = [&](const cv::Mat& image, const PinholeCamera& camera, const char* which) {
    if (image.cols != camera.width() || image.rows != camera.height()) {
      throw InputError(frame_name(frame), std::string(which) + " image size differs from the rig's camera");
    }
    if (image.type() == CV_8UC1) return image;
    if (image.type() != CV_8UC3) throw InputError(frame_name(frame), "image must be 8-bit colour or gray");
    if (!warned_colour_) {
      logger_->warn("{}: colour images converted to gray ({} layout)", mav0_.string(), to_string(layout_));
    }
    warned_colour_ = true;
    cv::Mat converted;
    cv::cvtColor(image, converted, cv::COLOR_BGR2GRAY);
    return converted;
  };
  const cv::Mat left = gray(frame.image, rig_.cam0, "left");
  cv::Mat right;
  if (rig_.cam1) {
    if (!frame.is_stereo()) throw InputError(frame_name(frame), "has no right image but the rig is stereo");
    right = gray(frame.right, *rig_.cam1, "right");
  }
  const std::string name = std::to_string(frame.t_ns) + ".png";
  write_image(mav0_ / "cam0" / "data" / name, left);
  if (rig_.cam1) write_image(mav0_ / "cam1" / "data" / name, right);
  files_->cam0 << frame.t_ns << ',' << name << '\n';
  if (rig_.cam1) files_->cam1 << frame.t_ns << ',' << name << '\n';
}

void EurocWriter::write(const SensorFrame& frame) {
  FLEETSLAM_CHECK(!closed_, "write() after close()");
  if (frame.image.empty()) throw InputError(frame_name(frame), "has no image");
  if (frames_ > 0 && frame.t_ns <= last_t_ns_) throw InputError(frame_name(frame), "stamp does not increase");
  if (rig_.imu) {
    std::optional<TimeNs> last_imu = files_->any_imu ? std::optional<TimeNs>(files_->last_imu_t_ns) : std::nullopt;
    for (const ImuSample& s : frame.imu) {
      if (last_imu && s.t_ns <= *last_imu) throw InputError(frame_name(frame), "IMU stamps do not increase");
      last_imu = s.t_ns;
    }
    check_imu_truth_pairs(frame, frame_name(frame));
  }
  write_images(frame);
  if (frame.has_depth() && !warned_depth_) {
    logger_->warn("{}: depth maps dropped ({} layout)", mav0_.string(), to_string(layout_));
  }
  warned_depth_ = warned_depth_ || frame.has_depth();
  if (!rig_.imu && !frame.imu.empty() && !warned_imu_) {
    logger_->warn("{}: IMU samples dropped: the rig has no IMU", mav0_.string());
    warned_imu_ = true;
  }
  if (rig_.imu) {
    for (const ImuSample& s : frame.imu) {  // their order was checked above
      files_->imu << s.t_ns << ',' << exact(s.gyro_radps.x()) << ',' << exact(s.gyro_radps.y()) << ','
                  << exact(s.gyro_radps.z()) << ',' << exact(s.accel_mps2.x()) << ',' << exact(s.accel_mps2.y())
                  << ',' << exact(s.accel_mps2.z()) << '\n';
      files_->last_imu_t_ns = s.t_ns;
      files_->any_imu = true;
    }
    for (const ImuTruth& truth : frame.imu_truth) {
      files_->imu_truth.push_back(truth);
      files_->all_truth_states = files_->all_truth_states && truth.state.has_value();
    }
  }
  if (frame.T_world_cam_gt) {
    const Eigen::Isometry3d T_body_cam0 = rig_.T_body_cam0.value_or(Eigen::Isometry3d::Identity());
    files_->body_poses.push_back({frame.t_ns, *frame.T_world_cam_gt * T_body_cam0.inverse()});
    files_->all_states = files_->all_states && frame.imu_state_gt.has_value();
    if (files_->all_states) files_->states.push_back(*frame.imu_state_gt);
  }
  last_t_ns_ = frame.t_ns;
  ++frames_;
}

void EurocWriter::close() {
  if (closed_) return;
  closed_ = true;
  for (std::ofstream* out : {&files_->cam0, &files_->cam1, &files_->imu}) {
    if (out->is_open()) out->close();
    if (out->fail()) throw InputError(mav0_.string(), "cannot write the lists");
  }
  if (rig_.imu && !files_->any_imu) {
    logger_->warn("{}: the rig has an IMU but no frame brought a sample: imu0/ left out", mav0_.string());
    std::filesystem::remove_all(mav0_ / "imu0");
  }
  const bool with_states =
      files_->all_states && files_->all_truth_states && rig_.imu && layout_ == DatasetFormat::kEuroc;
  if (rig_.imu && !files_->imu_truth.empty()) {
    merge_truth(files_->body_poses, files_->states, with_states, files_->imu_truth);
  }
  if (!files_->body_poses.empty()) {
    const char* folder = layout_ == DatasetFormat::kTumVi ? "mocap0" : "state_groundtruth_estimate0";
    std::filesystem::create_directories(mav0_ / folder);
    const std::filesystem::path file = mav0_ / folder / "data.csv";
    if (with_states) {
      write_states(file, files_->body_poses, files_->states);
    } else {
      write_trajectory(file, files_->body_poses, TrajectoryFormat::kEuroc);
    }
  }
  commit_staged_folder(staging_, root_);
  mav0_ = root_ / "mav0";
  logger_->info("{}: wrote {} {} frames ({} layout)", mav0_.string(), frames_, rig_.cam1 ? "stereo" : "monocular",
                to_string(layout_));
}

}  // namespace fleetslam::core
