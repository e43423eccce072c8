#pragma once
// TUM RGB-D benchmark sequences (https://cvg.cit.tum.de/data/datasets/rgbd-dataset/file_formats):
//   rgb.txt / depth.txt    "timestamp filename" (decimal seconds, '#' comments), images under rgb/, depth/
//   groundtruth.txt        "timestamp tx ty tz qx qy qz qw", pose of the colour camera's optical centre
//   accelerometer.txt      "timestamp ax ay az" (Kinect accelerometer, m/s^2), optional
//   depth PNG              16-bit, metres = raw / 5000, 0 = no measurement
// RGB and depth are not synchronised; they are paired the way the benchmark's associate.py does.

#include <cstddef>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "fleetslam/core/dataset.hpp"

namespace fleetslam::core {

// Calibration beside a sequence, optional in a TUM folder: an ORB-SLAM RGB-D settings file. The writer
// writes it with write_orbslam_settings (ORB-SLAM3 v1.0 layout, RGB-D, no IMU: the layout has no gyro;
// a rig without a virtual baseline gets ORB-SLAM's TUM bf of 40, ThDepth is 40); the reader reads it with
// read_orbslam_settings in RGB-D mode, so ORB-SLAM2's TUM1.yaml-style files read too.
inline constexpr const char* kTumCameraFile = "camera.yaml";

// Pairs stamps of `a` and `b` closer than max_difference_ns, greedily from the closest pair on, each
// stamp used once (TUM associate.py with offset 0). Both lists are sorted increasing. Returns index pairs
// (i into a, j into b) sorted by i.
std::vector<std::pair<std::size_t, std::size_t>> associate_stamps(const std::vector<TimeNs>& a,
                                                                  const std::vector<TimeNs>& b,
                                                                  TimeNs max_difference_ns);

// The Kinect of the benchmark's freiburg1/2/3 sequences (640x480, intrinsics and distortion published
// with the dataset). `freiburg` is 1, 2 or 3; anything else throws std::invalid_argument.
SensorRig tum_freiburg_rig(int freiburg);
// 1, 2 or 3 when a folder name says "freiburg1" / "fr1" etc.; nullopt otherwise.
std::optional<int> freiburg_from_name(const std::string& folder_name);

// Opens a TUM RGB-D folder. Calibration: config.rig, else camera.yaml in the folder, else the
// freiburg defaults named by the folder; none of them is an InputError.
std::unique_ptr<FrameSource> open_tum_rgbd(const std::filesystem::path& root, const DatasetConfig& config,
                                           Logger logger);

// Writes frames as a TUM RGB-D folder: rgb/ and depth/ PNGs (16-bit, raw = round(depth_m * scale)),
// rgb.txt, depth.txt, groundtruth.txt (frames with poses; with the camera's poses at the IMU samples
// of the frames that brought their truth too, SensorFrame::imu_truth, when the rig has T_body_cam0),
// accelerometer.txt (frames with IMU samples), camera.yaml. Every frame needs an image and a depth map. The sequence is written to
// root + ".partial" and renamed to root by close(); a writer destroyed without close() (a write that
// failed) leaves the .partial folder and says so.
class TumRgbdWriter final : public FrameSink {
 public:
  TumRgbdWriter(const std::filesystem::path& root, const SensorRig& rig, Logger logger);
  ~TumRgbdWriter() override;

  void write(const SensorFrame& frame) override;
  void close() override;
  std::size_t frames_written() const override { return frames_; }

 private:
  struct Files;
  std::filesystem::path root_;
  std::filesystem::path staging_;  // where the sequence is written until close()
  SensorRig rig_;
  Logger logger_;
  std::unique_ptr<Files> files_;
  std::size_t frames_ = 0;
  std::size_t depth_out_of_range_ = 0;
  TimeNs last_t_ns_ = 0;
  std::optional<TimeNs> last_imu_t_ns_;  // the accelerometer list's stamps must increase, as the reader wants
  bool closed_ = false;
};

}  // namespace fleetslam::core
