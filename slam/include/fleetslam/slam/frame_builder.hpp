#pragma once
// The agent's front end: a core::SensorFrame in, a slam::Frame out (ORB features with undistorted
// coordinates, per-feature depth, grid). Reads top to bottom in build(): check the input, convert to
// gray, (stereo: rectify), extract, undistort, depth (RGB-D lookup or stereo matching), finalize.
//
// Cameras, per rig mode:
//  - monocular / mono-inertial: features of cam0, undistorted into cam0.undistorted(); no depth.
//  - RGB-D: the same, plus the registered depth at each raw keypoint position (u_right = u - bf / d
//    with the rig's virtual bf).
//  - stereo / stereo-inertial: when the rig is already rectified (no distortion on either camera,
//    identical intrinsics, T_cam0_cam1 a pure +x translation) both images are used as they come and
//    bf = rig.bf (or baseline * fx when the rig gives none); otherwise both images are rectified with
//    core::compute_stereo_rectification (computed once, here) and the frame lives in the rectified
//    left camera rect0: frame.camera = the rectified intrinsics, keypoints are in the rectified left
//    image, and a pose T_world_rect0 reports in cam0 as T_world_rect0 * T_cam0_rect0().inverse().
// Depth kept: [min_depth_m, max_depth_m] for RGB-D readings; stereo depths >= min_depth_m (and below
// stereo_max_depth_baselines * baseline when that is > 0). close_depth_m = close_depth_baselines *
// baseline (ORB-SLAM's ThDepth; baseline = bf / fx) for RGB-D and stereo, 0 for monocular.
//
// Bad input never throws and never crashes: build() returns the frame with a status and a reason.
//   kEmptyImage           image empty                                  -> no features
//   kUnsupportedImage     image not CV_8UC1 / CV_8UC3 / CV_8UC4        -> no features
//   kWrongImageSize       image size differs from rig.cam0's           -> no features
//   kNoDepth              RGB-D: depth empty, not CV_32FC1, of another size than the image, or
//                         without a single valid reading at a feature; stereo: no feature with a
//                         stereo match in range                        -> features, no depth
//   kBadRightImage        stereo: right image missing, of another size than the left or of a type
//                         not listed above (each image is made gray on its own)
//                         -> features of the left image, no depth
// In each "no features" case the frame still has its camera, pyramid, bf, close depth, stamp and an
// (empty) grid, so the agent can treat it like a frame in which nothing was seen. A rig the builder
// cannot work with (stereo without cam1 or with cameras that cannot be rectified, RGB-D with bf <= 0, a
// fisheye cam0 outside stereo) is a configuration error: the constructor throws InputError("sensor rig",
// why); so is an RGB-D depth range that keeps nothing (min_depth_m >= max_depth_m).

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/sensor_frame.hpp"
#include "fleetslam/core/sensor_rig.hpp"
#include "fleetslam/core/stereo_rectify.hpp"
#include "fleetslam/slam/frame.hpp"
#include "fleetslam/slam/matcher.hpp"
#include "fleetslam/slam/orb_extractor.hpp"

namespace fleetslam::slam {

struct FrameBuilderConfig {
  OrbExtractorConfig orb;
  StereoMatchConfig stereo;
  double min_depth_m = 0.1;    // nearer depths are dropped (RGB-D readings and stereo matches)
  double max_depth_m = 8.0;    // RGB-D: farther readings are dropped (Kinect-class noise grows as z^2)
  // Stereo: depths beyond this many baselines are dropped; 0 keeps every positive disparity, as
  // ORB-SLAM does (points beyond close_depth_m are then "far" points).
  double stereo_max_depth_baselines = 0.0;
  double close_depth_baselines = 40.0;  // ORB-SLAM's ThDepth (35 in its EuRoC settings, 40 for TUM)

  template <class V>
  void visit(V& v) {
    v("orb", orb);
    v("stereo", stereo);
    v("min_depth_m", min_depth_m, core::Limits<double>{0.0, 1000.0});
    v("max_depth_m", max_depth_m, core::Limits<double>{0.01, 10000.0});
    v("stereo_max_depth_baselines", stereo_max_depth_baselines, core::Limits<double>{0.0, 1e6});
    v("close_depth_baselines", close_depth_baselines, core::Limits<double>{0.0, 1e6});
  }
};

enum class FrameBuildStatus { kOk, kEmptyImage, kUnsupportedImage, kWrongImageSize, kNoDepth, kBadRightImage };

// "ok", "empty_image", "unsupported_image", "wrong_image_size", "no_depth", "bad_right_image".
std::string to_string(FrameBuildStatus status);

struct FrameBuildResult {
  Frame frame;
  FrameBuildStatus status = FrameBuildStatus::kOk;
  std::string reason;           // empty when ok; otherwise one line naming the frame and what was wrong
  int features_with_depth = 0;  // features given depth (RGB-D or stereo)
  int right_features = 0;       // stereo: features extracted from the right image

  bool ok() const { return status == FrameBuildStatus::kOk; }
};

class FrameBuilder {
 public:
  // Throws InputError for a rig it cannot work with (see the file comment) and for bad config values.
  FrameBuilder(const FrameBuilderConfig& config, const core::SensorRig& rig);

  // Never throws for bad input (see the file comment). frame.id = sensor.sequence, frame.t_ns = sensor.t_ns.
  FrameBuildResult build(const core::SensorFrame& sensor) const;

  const FrameBuilderConfig& config() const { return config_; }
  const core::SensorRig& rig() const { return rig_; }
  // The camera frames live in (undistorted cam0, or the rectified left camera).
  const core::PinholeCamera& camera() const { return camera_; }
  double bf() const { return bf_; }
  bool rectifies() const { return rectification_.has_value(); }
  // Pose of the frame's camera in the raw cam0 frame: identity unless the stereo pair is rectified,
  // then the pure rotation R_rect0_cam0^T (core::StereoRectification::T_cam0_rect0).
  const Eigen::Isometry3d& T_cam0_rect0() const { return T_cam0_rect0_; }
  const std::optional<core::StereoRectification>& rectification() const { return rectification_; }

 private:
  bool is_stereo() const;
  bool is_rgbd() const;
  Frame empty_frame(const core::SensorFrame& sensor) const;
  cv::Mat to_gray(const cv::Mat& image) const;
  void build_monocular(FrameBuildResult& result, const core::SensorFrame& sensor, const cv::Mat& gray) const;
  void build_stereo(FrameBuildResult& result, const core::SensorFrame& sensor, const cv::Mat& gray) const;
  void add_features(Frame& frame, const OrbFeatures& features, bool undistort) const;
  void add_rgbd_depth(FrameBuildResult& result, const core::SensorFrame& sensor) const;

  FrameBuilderConfig config_;
  core::SensorRig rig_;
  OrbExtractor extractor_;
  core::PinholeCamera camera_;
  ImageBounds bounds_;
  double bf_ = 0.0;
  double close_depth_m_ = 0.0;
  std::optional<core::StereoRectification> rectification_;
  Eigen::Isometry3d T_cam0_rect0_ = Eigen::Isometry3d::Identity();
};

}  // namespace fleetslam::slam
