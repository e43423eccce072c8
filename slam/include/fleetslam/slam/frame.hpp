#pragma once
// A frame as the agent sees it: ORB features with undistorted coordinates, per-feature depth (RGB-D or
// stereo), a grid for radius search, and the map points its features are matched to.

#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

#include "fleetslam/core/camera.hpp"
#include "fleetslam/core/time.hpp"

namespace fleetslam::slam {

using MapPointId = std::int64_t;
using KeyframeId = std::int64_t;
inline constexpr MapPointId kNoMapPoint = -1;

// Scale of each pyramid level: scale[l] = scale_factor^l; sigma2[l] = scale[l]^2 (the variance of a
// keypoint's position at that level, in level-0 pixels^2). make() throws std::invalid_argument for
// levels < 1 or a scale_factor that is not finite and >= 1.
struct ScalePyramid {
  int levels = 8;
  double scale_factor = 1.2;
  std::vector<double> scale;
  std::vector<double> inv_scale;
  std::vector<double> sigma2;
  std::vector<double> inv_sigma2;

  static ScalePyramid make(int levels, double scale_factor);
};

// The region undistorted pixel coordinates of an image can fall in: [min_u, max_u) x [min_v, max_v).
struct ImageBounds {
  double min_u = 0.0;
  double max_u = 0.0;
  double min_v = 0.0;
  double max_v = 0.0;

  bool empty() const { return !(max_u > min_u && max_v > min_v); }
  // The pixel area of a distortion-free image: [-0.5, width - 0.5) x [-0.5, height - 0.5).
  static ImageBounds of_image(int width, int height);
};

// Bounding box of the raw image's border (sampled every few pixels, pixel edges included) mapped into
// the undistorted camera: every raw pixel undistorts inside it (ORB-SLAM undistorts only the four
// corners, which cuts off the bulging edges of barrel distortion). Border points whose undistortion
// fails are skipped; a camera without distortion gives ImageBounds::of_image.
ImageBounds undistorted_image_bounds(const core::PinholeCamera& raw);

// Buckets of feature indices over the undistorted image for radius queries (ORB-SLAM's 64x48 grid).
// The grid borrows nothing: queries take the same uv (and level) vectors it was built from.
// Stored contiguously (compressed rows): the indices of all cells in one array, cell by cell in row-major
// order and ascending within a cell, and each cell's start in it; a query scans one slice per grid row.
class FeatureGrid {
 public:
  FeatureGrid() = default;
  // Features outside [min_u, max_u) x [min_v, max_v) (and non-finite ones) are not indexed. An empty
  // area (max <= min) is widened to one pixel so that the grid stays valid.
  FeatureGrid(const std::vector<Eigen::Vector2d>& uv, double min_u, double max_u, double min_v, double max_v,
              int cols = 64, int rows = 48);
  FeatureGrid(const std::vector<Eigen::Vector2d>& uv, const ImageBounds& bounds, int cols = 64, int rows = 48)
      : FeatureGrid(uv, bounds.min_u, bounds.max_u, bounds.min_v, bounds.max_v, cols, rows) {}

  // Indices of indexed features at distance <= radius_px of (u, v) (cells overlapping the query square,
  // then the exact distance), optionally only those whose level is in [min_level, max_level] (-1: no
  // bound; `level` may be empty when neither bound is given). Sorted ascending. A non-finite query or
  // a negative radius gives no features.
  std::vector<int> features_in_area(const std::vector<Eigen::Vector2d>& uv, const std::vector<int>& level,
                                    double u, double v, double radius_px, int min_level = -1,
                                    int max_level = -1) const;
  // The same features, appended to `found` (its contents are kept; no allocation once its capacity
  // suffices, so one vector can serve many queries) in grid order: by cell row, then cell column,
  // ascending within a cell, so NOT sorted across cells (sort the appended range for index order).
  // Returns how many were appended.
  std::size_t features_in_area(const std::vector<Eigen::Vector2d>& uv, const std::vector<int>& level, double u,
                               double v, double radius_px, int min_level, int max_level,
                               std::vector<int>& found) const;
  bool empty() const { return cell_start_.empty(); }

 private:
  template <bool kCheckLevel>
  void append_in_area(const std::vector<Eigen::Vector2d>& uv, const std::vector<int>& level, double u, double v,
                      double radius_px, int min_level, int max_level, std::vector<int>& found) const;

  int cols_ = 0;
  int rows_ = 0;
  double min_u_ = 0.0, min_v_ = 0.0;
  double cell_w_ = 1.0, cell_h_ = 1.0;
  // Cell c (row-major, y * cols + x) holds indices_[cell_start_[c], cell_start_[c + 1]); cols * rows + 1
  // entries once built, none for a default-constructed grid.
  std::vector<int> cell_start_;
  std::vector<int> indices_;
};

struct Frame {
  std::int64_t id = -1;
  core::TimeNs t_ns = 0;
  core::PinholeCamera camera;  // distortion-free intrinsics the undistorted coordinates live in
  ScalePyramid pyramid;
  double bf = 0.0;             // baseline * fx (stereo: real; RGB-D: virtual); 0 monocular
  double close_depth_m = 0.0;  // features nearer than this are "close" (ORB-SLAM ThDepth in metres)
  ImageBounds bounds;          // where uv can lie (empty: finalize() uses camera's image area)

  // As detected in the image features were extracted from: the raw image, or the rectified left image
  // of a stereo rig that needed rectification (octave = level, angle in degrees).
  std::vector<cv::KeyPoint> keypoints;
  std::vector<Eigen::Vector2d> uv;      // undistorted pixel coordinates
  std::vector<int> level;               // pyramid level of each feature
  cv::Mat descriptors;                  // N x 32, CV_8UC1 (rBRIEF)
  std::vector<double> depth_m;          // depth along the optical axis; <= 0 when unknown
  std::vector<double> u_right;          // right-image u (stereo, or virtual for RGB-D); < 0 when unknown
  FeatureGrid grid;

  std::vector<MapPointId> map_points;   // per feature, kNoMapPoint when unmatched
  std::vector<bool> outlier;            // per feature, set by pose optimisation

  std::optional<Eigen::Isometry3d> T_world_cam;  // estimated pose, once known

  std::size_t size() const { return uv.size(); }
  bool has_depth(std::size_t i) const { return depth_m[i] > 0.0; }
  // Camera-frame point of feature i from its depth and uv; nullopt without depth. i < size() (checked).
  std::optional<Eigen::Vector3d> unproject(std::size_t i) const;
  // Makes the per-feature vectors consistent and builds the grid: depth_m / u_right left empty are
  // filled with "unknown" (-1), map_points/outlier are reset to one unmatched inlier entry per feature,
  // and the grid covers `bounds` (or the camera's image area when bounds is empty, or the features'
  // bounding box when the camera has no size). Throws InvariantError when keypoints, uv, level,
  // descriptors rows, depth_m or u_right disagree in size.
  void finalize();
};

}  // namespace fleetslam::slam
