#pragma once
// Dense mapping (PAPER.md §1): keyframes with depth become a coloured point cloud that follows the
// keyframes' poses.
//   keyframe_cloud   back-projects a keyframe's depth (RGB-D: the registered depth image; stereo: a
//                    semi-global block-matching disparity of the rectified pair) into points in the
//                    keyframe's camera frame, every `pixel_stride`-th pixel, within the depth limits,
//                    skipping "flying pixels" at depth discontinuities;
//   add_keyframe     keeps only the points that fall into voxels (`voxel_size_m`, world frame at
//                    insertion) no earlier keyframe occupies, so the stored cloud grows with the
//                    explored volume, not with time: revisiting a room adds nothing;
//   remove_keyframe  a culled keyframe hands its points to the keyframe that inherits its relative
//                    poses (its live parent), so no surface is lost when the map is thinned;
//   cloud_world      every keyframe's points mapped by the keyframe's current pose: local BA and loop
//                    closing move the cloud with the keyframes.
// Points are stored relative to their keyframe in the camera the agent's frames live in (the rectified
// left camera when the front end rectifies a stereo pair, cam0 otherwise).
// Not thread-safe: the agent serialises access (threaded mode computes keyframe clouds on a worker and
// inserts them under its lock).

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <unordered_set>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/point_cloud.hpp"
#include "fleetslam/core/sensor_frame.hpp"
#include "fleetslam/slam/frame.hpp"
#include "fleetslam/slam/frame_builder.hpp"

namespace fleetslam::slam {

struct DenseMappingConfig {
  bool enabled = true;
  int pixel_stride = 4;             // back-project every n-th pixel of every n-th row
  double min_depth_m = 0.2;
  double max_depth_m = 4.0;         // farther depth is too noisy for a map (RGB-D noise grows as z^2)
  double max_depth_step = 0.05;     // relative depth jump to a neighbour sample that marks a flying pixel
  double voxel_size_m = 0.02;       // a keyframe keeps only points in voxels not yet occupied (0: keep all)
  // Stereo: OpenCV's semi-global block matching on the rectified pair.
  int stereo_disparities = 64;      // search range in pixels (rounded up to a multiple of 16)
  int stereo_block_size = 5;        // odd
  int stereo_uniqueness_percent = 15;

  template <class V>
  void visit(V& v) {
    v("enabled", enabled);
    v("pixel_stride", pixel_stride, core::Limits<int>{1, 64});
    v("min_depth_m", min_depth_m, core::Limits<double>{0.0, 1000.0});
    v("max_depth_m", max_depth_m, core::Limits<double>{0.01, 10000.0});
    v("max_depth_step", max_depth_step, core::Limits<double>{0.0, 10.0});
    v("voxel_size_m", voxel_size_m, core::Limits<double>{0.0, 10.0});
    v("stereo_disparities", stereo_disparities, core::Limits<int>{16, 512});
    v("stereo_block_size", stereo_block_size, core::Limits<int>{1, 31});
    v("stereo_uniqueness_percent", stereo_uniqueness_percent, core::Limits<int>{0, 100});
  }
};

struct DenseStats {
  std::size_t keyframes = 0;
  std::size_t points = 0;            // stored (after voxel de-duplication)
  std::size_t back_projected = 0;    // before de-duplication, over all keyframes added
  std::size_t occupied_voxels = 0;
};

class DenseMapper {
 public:
  // Cameras and stereo rectification come from the agent's front end. Throws InputError for bad
  // config values (depth limits the wrong way round, an even stereo block size).
  DenseMapper(const DenseMappingConfig& config, const FrameBuilder& builder);

  // Points of one keyframe in its camera frame (see the file comment), coloured from the image (gray
  // images give gray points). Empty when the frame has no usable depth: no depth image (or one of the
  // wrong size/type) for RGB-D, no right image for stereo, or a monocular rig. Never throws for bad input.
  core::PointCloud keyframe_cloud(const core::SensorFrame& sensor) const;

  // Stores the keyframe's points that add new voxels (world frame from T_world_cam); returns how many.
  // Adding an id again replaces nothing and returns 0.
  std::size_t add_keyframe(KeyframeId id, const Eigen::Isometry3d& T_world_cam, const core::PointCloud& cloud_cam);
  // Hands a culled keyframe's points to `heir` (with T_heir_kf, the culled keyframe's pose in the
  // heir's frame), also when the heir has no cloud of its own yet (a keyframe of a loaded map, or one the
  // dense stage has not reached: its own points still come); without an heir they are dropped and their
  // voxels freed for later keyframes. Unknown ids are ignored.
  void remove_keyframe(KeyframeId id, const std::optional<std::pair<KeyframeId, Eigen::Isometry3d>>& heir);

  // Every keyframe's points in the world frame, keyframes in id order. `pose` gives a keyframe's current
  // pose (nullopt: its points are skipped).
  using PoseLookup = std::function<std::optional<Eigen::Isometry3d>(KeyframeId)>;
  core::PointCloud cloud_world(const PoseLookup& pose) const;

  const std::map<KeyframeId, core::PointCloud>& keyframe_clouds() const { return clouds_; }
  const core::PointCloud* keyframe_cloud_of(KeyframeId id) const;
  DenseStats stats() const;
  const DenseMappingConfig& config() const { return config_; }

 private:
  core::PointCloud back_project(const cv::Mat& depth_m, const cv::Mat& image) const;
  cv::Mat stereo_depth(const core::SensorFrame& sensor, cv::Mat& left_color) const;
  std::int64_t voxel_key(const Eigen::Vector3f& p_world) const;

  DenseMappingConfig config_;
  core::SensorMode mode_;
  core::PinholeCamera camera_;  // the camera the depth image lives in (raw cam0 for RGB-D, rectified for stereo)
  double bf_ = 0.0;
  std::optional<core::StereoRectification> rectification_;
  std::vector<Eigen::Vector2f> rays_;  // per sampled pixel: undistorted normalised (x/z, y/z), row-major
  int sample_cols_ = 0;
  int sample_rows_ = 0;

  std::map<KeyframeId, core::PointCloud> clouds_;  // own points and those inherited from culled keyframes
  std::set<KeyframeId> added_;                      // keyframes whose own points were added
  std::map<KeyframeId, std::vector<std::int64_t>> voxels_;  // the voxels each cloud's points took
  std::unordered_set<std::int64_t> occupied_;
  std::size_t back_projected_ = 0;
};

}  // namespace fleetslam::slam
