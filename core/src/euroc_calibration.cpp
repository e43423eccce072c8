// EuRoC / TUM-VI sensor.yaml files -> camera, IMU and rig calibration.

#include <cmath>
#include <stdexcept>
#include <system_error>

#include <Eigen/SVD>

#include "dataset_internal.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/core/euroc.hpp"

namespace fleetslam::core {

using namespace dataset_detail;

namespace {

constexpr const char* kUseRig =
    "give the calibration as a rig instead (DatasetConfig::rig, e.g. from an ORB-SLAM settings file)";

// T_BS "data": 16 numbers, row-major 4x4. The rotation is checked, then projected onto SO(3) so that
// products and inverses of extrinsics stay rigid.
Eigen::Isometry3d read_T_BS(const SettingsFile& file) {
  const std::vector<double> v = file.numbers("T_BS", {16}, "data");
  Eigen::Matrix4d M;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) M(r, c) = v[static_cast<std::size_t>(4 * r + c)];
  }
  const Eigen::Matrix3d R = M.topLeftCorner<3, 3>();
  const bool rigid = (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() < 1e-5 && R.determinant() > 0.0 &&
                     M.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1));
  if (!rigid) throw InputError(file.where("T_BS"), "is not a rigid transform");
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = svd.matrixU() * svd.matrixV().transpose();
  T.translation() = M.topRightCorner<3, 1>();
  return T;
}

void check_models(const SettingsFile& file) {
  const std::string model = file.has("camera_model") ? file.text("camera_model") : "pinhole";
  if (model != "pinhole") {
    throw InputError(file.where("camera_model"), "camera model '" + model + "' is not supported (pinhole only); " + kUseRig);
  }
  const std::string distortion = file.has("distortion_model") ? file.text("distortion_model") : "radial-tangential";
  if (distortion != "radial-tangential" && distortion != "radtan" && distortion != "plumb_bob" &&
      distortion != "equidistant") {
    throw InputError(file.where("distortion_model"), "distortion model '" + distortion +
                                                         "' is not supported (radial-tangential or equidistant); " +
                                                         kUseRig);
  }
}

bool is_equidistant(const SettingsFile& file) {
  return file.has("distortion_model") && file.text("distortion_model") == "equidistant";
}

double positive(const SettingsFile& file, const std::string& key, double fallback) {
  const double value = file.has(key) ? file.number(key) : fallback;
  if (!(value > 0.0)) throw InputError(file.where(key), "must be positive");
  return value;
}

}  // namespace

EurocCameraCalibration read_euroc_camera_yaml(const std::filesystem::path& path) {
  const SettingsFile file(path);
  check_models(file);
  const std::vector<double> size = file.numbers("resolution", {2});
  const std::vector<double> k = file.numbers("intrinsics", {4});
  const bool equidistant = is_equidistant(file);
  const std::vector<double> d =
      equidistant ? file.numbers("distortion_coefficients", {4}) : file.numbers("distortion_coefficients", {4, 5});
  const Distortion distortion = equidistant ? Distortion::equidistant(d[0], d[1], d[2], d[3])
                                            : Distortion{d[0], d[1], d[2], d[3], d.size() == 5 ? d[4] : 0.0};
  for (double pixels : size) {
    if (pixels != std::floor(pixels) || pixels < 1.0 || pixels > 1e5) {
      throw InputError(file.where("resolution"), "expected two positive whole numbers");
    }
  }
  EurocCameraCalibration calibration;
  try {
    calibration.camera = PinholeCamera(static_cast<int>(size[0]), static_cast<int>(size[1]), k[0], k[1], k[2], k[3],
                                       distortion);
  } catch (const std::invalid_argument& e) {
    throw InputError(file.where("intrinsics"), e.what());
  }
  calibration.T_body_cam = read_T_BS(file);
  calibration.rate_hz = positive(file, "rate_hz", 20.0);
  return calibration;
}

Eigen::Isometry3d read_euroc_T_BS(const std::filesystem::path& path) { return read_T_BS(SettingsFile(path)); }

EurocImuCalibration read_euroc_imu_yaml(const std::filesystem::path& path) {
  const SettingsFile file(path);
  EurocImuCalibration calibration;
  ImuNoise& noise = calibration.noise;
  noise.gyro_noise_density = positive(file, "gyroscope_noise_density", noise.gyro_noise_density);
  noise.gyro_random_walk = positive(file, "gyroscope_random_walk", noise.gyro_random_walk);
  noise.accel_noise_density = positive(file, "accelerometer_noise_density", noise.accel_noise_density);
  noise.accel_random_walk = positive(file, "accelerometer_random_walk", noise.accel_random_walk);
  noise.rate_hz = positive(file, "rate_hz", noise.rate_hz);
  if (file.has("T_BS")) calibration.T_body_imu = read_T_BS(file);
  return calibration;
}

SensorRig read_euroc_rig(const std::filesystem::path& mav0, bool stereo, bool inertial) {
  const EurocCameraCalibration cam0 = read_euroc_camera_yaml(mav0 / "cam0" / "sensor.yaml");
  SensorRig rig;
  rig.cam0 = cam0.camera;
  rig.fps = cam0.rate_hz;
  rig.rgb_order = false;
  rig.T_body_cam0 = cam0.T_body_cam;
  if (stereo) {
    const EurocCameraCalibration cam1 = read_euroc_camera_yaml(mav0 / "cam1" / "sensor.yaml");
    rig.cam1 = cam1.camera;
    rig.T_cam0_cam1 = cam0.T_body_cam.inverse() * cam1.T_body_cam;
    rig.bf = rig.T_cam0_cam1.translation().norm() * cam0.camera.fx();
  }
  if (inertial) {
    const EurocImuCalibration imu = read_euroc_imu_yaml(mav0 / "imu0" / "sensor.yaml");
    rig.imu = imu.noise;
    // The IMU defines the body frame of SensorRig; EuRoC's body frame B usually is the IMU already.
    rig.T_body_cam0 = imu.T_body_imu.inverse() * cam0.T_body_cam;
  }
  if (stereo) {
    rig.mode = inertial ? SensorMode::kStereoInertial : SensorMode::kStereo;
  } else {
    rig.mode = inertial ? SensorMode::kMonoInertial : SensorMode::kMonocular;
  }
  return rig;
}

std::filesystem::path find_mav0(const std::filesystem::path& root) {
  std::error_code ec;
  if (!std::filesystem::is_directory(root, ec)) {
    throw InputError(root.string(), std::filesystem::exists(root, ec) ? "is a file; give the sequence's folder"
                                                                       : "no such folder");
  }
  if (std::filesystem::is_directory(root / "mav0", ec)) return root / "mav0";
  if (std::filesystem::is_directory(root / "cam0", ec)) return root;
  throw InputError(root.string(), "not a EuRoC/TUM-VI sequence (no mav0/ or cam0/ folder)");
}

}  // namespace fleetslam::core
