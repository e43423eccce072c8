#pragma once
// EuRoC MAV / ASL sequences, and TUM-VI in the same layout:
//   mav0/cam0/data.csv    "t_ns,filename" with images under cam0/data/ (8-bit gray PNG)
//   mav0/cam1/...         right camera; frames pair with cam0 by identical stamps
//   mav0/<sensor>/sensor.yaml   calibration (OpenCV FileStorage YAML): T_BS (sensor in body frame),
//                         resolution, intrinsics [fu fv cu cv], radial-tangential or (TUM-VI) equidistant
//                         distortion, rate_hz;
//                         for imu0 the noise densities and random walks
//   mav0/imu0/data.csv    "t_ns,wx,wy,wz,ax,ay,az" (rad/s, m/s^2)
//   mav0/state_groundtruth_estimate0/data.csv (EuRoC) or mav0/mocap0/data.csv (TUM-VI): body poses
// Every frame carries the IMU samples with t in (previous frame, this frame].

#include <filesystem>
#include <memory>
#include <optional>

#include <Eigen/Geometry>

#include "fleetslam/core/dataset.hpp"

namespace fleetslam::core {

// One camera's sensor.yaml.
struct EurocCameraCalibration {
  PinholeCamera camera;
  Eigen::Isometry3d T_body_cam = Eigen::Isometry3d::Identity();  // T_BS
  double rate_hz = 20.0;
};

// One IMU's sensor.yaml.
struct EurocImuCalibration {
  ImuNoise noise;
  Eigen::Isometry3d T_body_imu = Eigen::Isometry3d::Identity();  // T_BS
};

// Readers of sensor.yaml. Unsupported models (camera_model other than pinhole, distortion_model other
// than radial-tangential or equidistant) are InputErrors that say to pass a rig.
EurocCameraCalibration read_euroc_camera_yaml(const std::filesystem::path& file);
EurocImuCalibration read_euroc_imu_yaml(const std::filesystem::path& file);
// T_BS of a sensor.yaml alone (any camera model): where the sensor sits in the body frame.
Eigen::Isometry3d read_euroc_T_BS(const std::filesystem::path& file);

// The rig of a mav0 folder from its sensor.yaml files (cam1 and imu0 when present and asked for):
// T_body_cam0 is cam0 in the IMU frame, T_cam0_cam1 = T_B_cam0^-1 * T_B_cam1, bf = baseline * fx.
SensorRig read_euroc_rig(const std::filesystem::path& mav0, bool stereo, bool inertial);

// The mav0 folder of a sequence: root/mav0, or root itself when it holds cam0/. InputError otherwise.
std::filesystem::path find_mav0(const std::filesystem::path& root);

// Opens a EuRoC or TUM-VI sequence (`format` only changes the wording and the ground-truth folder
// searched first). Calibration: config.rig, else the sensor.yaml files. The dataset's ground truth holds
// body poses: they become camera poses through the rig's T_body_cam0, else cam0/sensor.yaml's T_BS; with
// neither the sequence has no ground truth (a warning says why) rather than body poses taken for the
// camera's. A ground-truth file given in the body frame without either is an InputError. Body-pose
// ground truth also gives the frames the truth at their IMU samples (SensorFrame::imu_truth, with
// EuRoC's state where its file has the columns), interpolated within max_groundtruth_gap_s; samples
// outside the ground truth (before it, after it, in a drop-out) get none. The truth at the samples is the
// IMU's pose (the rig's body): EuRoC's body frame B is moved to the IMU through cam0's and imu0's T_BS.
std::unique_ptr<FrameSource> open_euroc(const std::filesystem::path& root, DatasetFormat format,
                                        const DatasetConfig& config, Logger logger);

// Writes frames as a EuRoC (or TUM-VI) mav0 folder under root: cam0/ (and cam1/ for stereo frames) with
// data.csv, data/<t_ns>.png and sensor.yaml; imu0/ when the rig has an IMU; body.yaml; and the body
// poses (body = IMU frame) when frames carry poses: EuRoC's state_groundtruth_estimate0/data.csv, with
// EuRoC's velocity and bias columns when the rig has an IMU and every posed frame and every truth at an
// IMU sample brought its state (SensorFrame::imu_state_gt, ImuTruth::state, as the simulator's frames
// and EuRoC's own ground truth do), the 8 pose columns otherwise; TUM-VI's mocap0/data.csv, the 8 pose
// columns. When the rig has an IMU, the frames that brought the truth at their IMU samples
// (SensorFrame::imu_truth: the simulator's, and those of a sequence read with body-pose ground truth)
// add a row at each of those samples (EuRoC's ground truth runs at the IMU's rate): the rows merged in
// time, a frame's own where both have an instant.
// Colour images are converted to gray; depth maps are dropped (with one warning). A rig with an IMU
// whose frames brought no sample gets no imu0/ (with a warning): the reader refuses an empty IMU list.
// A frame is checked whole before any of it is written. The sequence is written to root + ".partial"
// and renamed to root by close(); a writer destroyed without close() (a write that failed) leaves the
// .partial folder and says so.
class EurocWriter final : public FrameSink {
 public:
  // layout: kEuroc or kTumVi (InvariantError otherwise, before anything is created).
  EurocWriter(const std::filesystem::path& root, const SensorRig& rig, Logger logger,
              DatasetFormat layout = DatasetFormat::kEuroc);
  ~EurocWriter() override;

  void write(const SensorFrame& frame) override;
  void close() override;
  std::size_t frames_written() const override { return frames_; }

 private:
  struct Files;
  void write_images(const SensorFrame& frame);
  std::filesystem::path root_;
  DatasetFormat layout_;
  std::filesystem::path staging_;  // where the sequence is written until close()
  std::filesystem::path mav0_;     // staging_ / "mav0"
  SensorRig rig_;
  Logger logger_;
  std::unique_ptr<Files> files_;
  std::size_t frames_ = 0;
  TimeNs last_t_ns_ = 0;
  bool warned_colour_ = false;
  bool warned_depth_ = false;
  bool warned_imu_ = false;
  bool closed_ = false;
};

}  // namespace fleetslam::core
