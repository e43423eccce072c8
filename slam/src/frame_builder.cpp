#include "fleetslam/slam/frame_builder.hpp"

#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>

#include <opencv2/imgproc.hpp>

#include "fleetslam/core/error.hpp"

namespace fleetslam::slam {
namespace {

// Two cameras count as one when their intrinsics agree to this (pixels): far below feature noise.
constexpr double kSameIntrinsicsPx = 1e-6;
// A rotation within this of identity, and a baseline this close to the x axis, count as rectified.
constexpr double kRectifiedTolerance = 1e-9;

std::string size_text(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

std::string frame_name(const core::SensorFrame& sensor) {
  std::string name = "robot " + std::to_string(sensor.robot_id) + " frame " + std::to_string(sensor.sequence);
  if (!sensor.image_path.empty()) name += " (" + sensor.image_path + ")";
  return name;
}

bool supported_type(int type) { return type == CV_8UC1 || type == CV_8UC3 || type == CV_8UC4; }

bool same_intrinsics(const core::PinholeCamera& a, const core::PinholeCamera& b) {
  return a.width() == b.width() && a.height() == b.height() && std::abs(a.fx() - b.fx()) < kSameIntrinsicsPx &&
         std::abs(a.fy() - b.fy()) < kSameIntrinsicsPx && std::abs(a.cx() - b.cx()) < kSameIntrinsicsPx &&
         std::abs(a.cy() - b.cy()) < kSameIntrinsicsPx;
}

// The right camera and its pose: cam1, or cam0 shifted by bf / fx when the rig gives only bf (a
// rectified pair described ORB-SLAM's old way).
std::pair<core::PinholeCamera, Eigen::Isometry3d> right_camera(const core::SensorRig& rig) {
  if (rig.cam1) return {*rig.cam1, rig.T_cam0_cam1};
  if (!(rig.bf > 0.0)) throw InputError("sensor rig", "a stereo rig needs cam1 or a positive bf");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation().x() = rig.bf / rig.cam0.fx();
  return {rig.cam0, T};
}

bool already_rectified(const core::PinholeCamera& cam0, const core::PinholeCamera& cam1, const Eigen::Isometry3d& T) {
  const Eigen::Vector3d t = T.translation();
  const double rotation_error = (T.linear() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  return cam0.distortion().is_zero() && cam1.distortion().is_zero() && same_intrinsics(cam0, cam1) &&
         rotation_error < kRectifiedTolerance && t.x() > 0.0 && std::abs(t.y()) <= kRectifiedTolerance * t.x() &&
         std::abs(t.z()) <= kRectifiedTolerance * t.x();
}

// Why an image cannot be used as the rig's cam0 image; nullopt when it can.
std::optional<std::pair<FrameBuildStatus, std::string>> image_problem(const cv::Mat& image,
                                                                      const core::PinholeCamera& camera) {
  if (image.empty()) return std::make_pair(FrameBuildStatus::kEmptyImage, std::string("the image is empty"));
  if (!supported_type(image.type())) {
    return std::make_pair(FrameBuildStatus::kUnsupportedImage,
                          "image type " + std::to_string(image.type()) + " is not 8-bit gray, BGR or BGRA");
  }
  if (image.cols != camera.width() || image.rows != camera.height()) {
    return std::make_pair(FrameBuildStatus::kWrongImageSize, "the image is " + size_text(image.cols, image.rows) +
                                                                 ", the camera " +
                                                                 size_text(camera.width(), camera.height()));
  }
  return std::nullopt;
}

std::optional<std::string> right_problem(const core::SensorFrame& sensor) {
  if (sensor.right.empty()) return std::string("the stereo rig's right image is missing");
  // Each image is converted to gray on its own: a colour left and a gray right image make a pair.
  if (!supported_type(sensor.right.type())) {
    return "the right image's type " + std::to_string(sensor.right.type()) + " is not 8-bit gray, BGR or BGRA";
  }
  if (sensor.right.size() != sensor.image.size()) {
    return "the right image is " + size_text(sensor.right.cols, sensor.right.rows) + ", the left " +
           size_text(sensor.image.cols, sensor.image.rows);
  }
  return std::nullopt;
}

std::optional<std::string> depth_problem(const core::SensorFrame& sensor) {
  if (sensor.depth_m.empty()) return std::string("the RGB-D frame has no depth image");
  if (sensor.depth_m.type() != CV_32FC1) {
    return "the depth image has type " + std::to_string(sensor.depth_m.type()) + ", not CV_32FC1 (metres)";
  }
  if (sensor.depth_m.size() != sensor.image.size()) {
    return "the depth image is " + size_text(sensor.depth_m.cols, sensor.depth_m.rows) + ", the image " +
           size_text(sensor.image.cols, sensor.image.rows);
  }
  return std::nullopt;
}

// Clears the depth of features outside [min_depth_m, max_depth_m] (max <= 0: no upper bound).
int keep_depths_in_range(Frame& frame, double min_depth_m, double max_depth_m) {
  int kept = 0;
  for (std::size_t i = 0; i < frame.depth_m.size(); ++i) {
    const double d = frame.depth_m[i];
    if (!(d > 0.0)) continue;
    if (d < min_depth_m || (max_depth_m > 0.0 && d > max_depth_m)) {
      frame.depth_m[i] = -1.0;
      frame.u_right[i] = -1.0;
    } else {
      ++kept;
    }
  }
  return kept;
}

void set_status(FrameBuildResult& result, FrameBuildStatus status, const core::SensorFrame& sensor,
                const std::string& why) {
  result.status = status;
  result.reason = frame_name(sensor) + ": " + why;
}

}  // namespace

std::string to_string(FrameBuildStatus status) {
  switch (status) {
    case FrameBuildStatus::kOk: return "ok";
    case FrameBuildStatus::kEmptyImage: return "empty_image";
    case FrameBuildStatus::kUnsupportedImage: return "unsupported_image";
    case FrameBuildStatus::kWrongImageSize: return "wrong_image_size";
    case FrameBuildStatus::kNoDepth: return "no_depth";
    case FrameBuildStatus::kBadRightImage: return "bad_right_image";
  }
  return "unknown";
}

FrameBuilder::FrameBuilder(const FrameBuilderConfig& config, const core::SensorRig& rig)
    : config_(config), rig_(rig), extractor_(config.orb) {
  if (is_rgbd() && !(config.min_depth_m < config.max_depth_m)) {
    throw InputError("frontend", "min_depth_m (" + std::to_string(config.min_depth_m) +
                                     ") must be below max_depth_m (" + std::to_string(config.max_depth_m) +
                                     "): no depth reading could be kept");
  }
  // Monocular and RGB-D undistort cam0 into a pinhole camera, which cannot hold a fisheye's field of view
  // (its image area would reach hundreds of thousands of pixels); stereo rectifies a fisheye pair instead.
  if (rig.cam0.distortion().is_equidistant() && !is_stereo()) {
    throw InputError("sensor rig", "a fisheye (equidistant) cam0 is used through stereo rectification only; "
                                   "this rig's mode is " + std::string(core::to_string(rig.mode)));
  }
  camera_ = rig.cam0.undistorted();
  bounds_ = undistorted_image_bounds(rig.cam0);
  if (is_rgbd()) {
    if (!(rig.bf > 0.0)) throw InputError("sensor rig", "RGB-D needs a positive (virtual) bf, got " + std::to_string(rig.bf));
    bf_ = rig.bf;
  } else if (is_stereo()) {
    const auto [cam1, T_cam0_cam1] = right_camera(rig);
    if (already_rectified(rig.cam0, cam1, T_cam0_cam1)) {
      bf_ = rig.bf > 0.0 ? rig.bf : T_cam0_cam1.translation().x() * rig.cam0.fx();
    } else {
      try {
        rectification_ = core::compute_stereo_rectification(rig.cam0, cam1, T_cam0_cam1);
      } catch (const std::invalid_argument& e) {
        throw InputError("sensor rig", e.what());
      }
      camera_ = rectification_->rig.camera;
      bounds_ = ImageBounds::of_image(camera_.width(), camera_.height());
      bf_ = rectification_->rig.bf();
      T_cam0_rect0_ = rectification_->T_cam0_rect0();
    }
  }
  close_depth_m_ = config.close_depth_baselines * bf_ / camera_.fx();
}

bool FrameBuilder::is_stereo() const {
  return rig_.mode == core::SensorMode::kStereo || rig_.mode == core::SensorMode::kStereoInertial;
}

bool FrameBuilder::is_rgbd() const { return rig_.mode == core::SensorMode::kRgbd; }

Frame FrameBuilder::empty_frame(const core::SensorFrame& sensor) const {
  Frame frame;
  frame.id = sensor.sequence;
  frame.t_ns = sensor.t_ns;
  frame.camera = camera_;
  frame.pyramid = extractor_.pyramid();
  frame.bf = bf_;
  frame.close_depth_m = close_depth_m_;
  frame.bounds = bounds_;
  frame.descriptors = cv::Mat(0, 32, CV_8UC1);
  return frame;
}

cv::Mat FrameBuilder::to_gray(const cv::Mat& image) const {
  if (image.type() == CV_8UC1) return image;
  cv::Mat gray;
  if (image.type() == CV_8UC3) {
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);  // SensorFrame images are BGR
  } else {
    cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY);
  }
  return gray;
}

FrameBuildResult FrameBuilder::build(const core::SensorFrame& sensor) const {
  FrameBuildResult result;
  result.frame = empty_frame(sensor);
  if (const auto problem = image_problem(sensor.image, rig_.cam0)) {
    set_status(result, problem->first, sensor, problem->second);
  } else if (is_stereo()) {
    build_stereo(result, sensor, to_gray(sensor.image));
  } else {
    build_monocular(result, sensor, to_gray(sensor.image));
  }
  result.frame.finalize();
  return result;
}

void FrameBuilder::build_monocular(FrameBuildResult& result, const core::SensorFrame& sensor,
                                   const cv::Mat& gray) const {
  add_features(result.frame, extractor_.extract(gray), true);
  if (is_rgbd()) add_rgbd_depth(result, sensor);
}

void FrameBuilder::build_stereo(FrameBuildResult& result, const core::SensorFrame& sensor, const cv::Mat& gray) const {
  const std::optional<std::string> problem = right_problem(sensor);
  cv::Mat left = gray;
  cv::Mat right;
  if (problem) {
    set_status(result, FrameBuildStatus::kBadRightImage, sensor, *problem);
    if (rectification_) {
      // Into a new image: `left` may share the caller's pixels (to_gray returns a gray image as it is),
      // and remap would write the rectified view over them.
      cv::Mat rectified;
      cv::remap(gray, rectified, rectification_->map0_x, rectification_->map0_y, cv::INTER_LINEAR,
                cv::BORDER_CONSTANT);
      left = rectified;
    }
  } else if (rectification_) {
    std::tie(left, right) = core::rectify_images(*rectification_, gray, to_gray(sensor.right));
  } else {
    right = to_gray(sensor.right);
  }
  const OrbFeatures left_features = extractor_.extract(left);
  // Rectified (or already distortion-free) images: the keypoints are the frame's coordinates.
  add_features(result.frame, left_features, false);
  if (right.empty()) return;
  const OrbFeatures right_features = extractor_.extract(right);
  result.right_features = static_cast<int>(right_features.keypoints.size());
  match_stereo_levels(result.frame, left_features.levels, right_features.keypoints, right_features.descriptors,
                      right_features.levels, config_.stereo);
  const double baseline_m = bf_ / camera_.fx();
  const double max_depth_m = config_.stereo_max_depth_baselines * baseline_m;
  result.features_with_depth = keep_depths_in_range(result.frame, config_.min_depth_m, max_depth_m);
  if (result.features_with_depth == 0 && result.frame.size() > 0) {
    set_status(result, FrameBuildStatus::kNoDepth, sensor,
               "no stereo match at " + std::to_string(config_.min_depth_m) + " m or farther" +
                   (max_depth_m > 0.0 ? " (and within " + std::to_string(max_depth_m) + " m)" : std::string()) +
                   " for any of " + std::to_string(result.frame.size()) + " features (" +
                   std::to_string(result.right_features) + " in the right image)");
  }
}

void FrameBuilder::add_features(Frame& frame, const OrbFeatures& features, bool undistort) const {
  std::vector<Eigen::Vector2d> raw;
  raw.reserve(features.keypoints.size());
  for (const cv::KeyPoint& k : features.keypoints) {
    raw.emplace_back(static_cast<double>(k.pt.x), static_cast<double>(k.pt.y));
  }
  const std::vector<Eigen::Vector2d> uv = undistort ? rig_.cam0.undistort_points(raw) : raw;
  std::vector<cv::Mat> rows;
  for (std::size_t i = 0; i < uv.size(); ++i) {
    // A keypoint whose undistortion does not converge (outside the calibrated region) is dropped.
    if (!uv[i].allFinite()) continue;
    frame.keypoints.push_back(features.keypoints[i]);
    frame.uv.push_back(uv[i]);
    frame.level.push_back(features.keypoints[i].octave);
    rows.push_back(features.descriptors.row(static_cast<int>(i)));
  }
  if (!rows.empty()) cv::vconcat(rows, frame.descriptors);
}

void FrameBuilder::add_rgbd_depth(FrameBuildResult& result, const core::SensorFrame& sensor) const {
  Frame& frame = result.frame;
  if (const std::optional<std::string> problem = depth_problem(sensor)) {
    set_status(result, FrameBuildStatus::kNoDepth, sensor, *problem);
    return;
  }
  result.features_with_depth = assign_rgbd_depth(frame, sensor.depth_m, config_.min_depth_m, config_.max_depth_m);
  if (result.features_with_depth == 0 && frame.size() > 0) {
    set_status(result, FrameBuildStatus::kNoDepth, sensor,
               "no valid depth reading in [" + std::to_string(config_.min_depth_m) + ", " +
                   std::to_string(config_.max_depth_m) + "] m at any of " + std::to_string(frame.size()) +
                   " features");
  }
}

}  // namespace fleetslam::slam
