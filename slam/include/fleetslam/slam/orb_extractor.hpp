#pragma once
// ORB features over a scale pyramid with an even spatial distribution (ORB-SLAM's scheme): FAST per
// grid cell on every level with a fallback threshold, a quadtree that keeps the strongest corner per
// node until the level's share of features is reached, intensity-centroid orientation and rBRIEF
// descriptors (OpenCV's building blocks where they fit).
//
// Pyramid: level l is cv::resize (INTER_LINEAR) of level l-1 to round(size0 / scale_factor^l). Pixel
// centres map between levels as cv::resize maps them, x_l = (x_0 + 0.5) * r - 0.5 with r the actual
// size ratio per axis (see to_level / to_level0), not ORB-SLAM's plain x_0 = x_l * scale, which puts
// coarse-level keypoints up to ~scale/2 px off their image content.
// Detection: corners lie at least kOrbEdgePx from every level's border, where the orientation disc fits
// and the rotated 31x31 descriptor patch nearly does (cv::ORB pads the last pixels by reflection, as
// ORB-SLAM). Per level the FAST corners (9/16, non-maximum suppression) of every cell_size_px cell are
// those with a score >= ini_fast_threshold, or >= min_fast_threshold for cells with none. FAST runs once
// at ini_fast_threshold over the level, then at min_fast_threshold on each empty cell (plus a margin that
// makes its suppression agree with a whole-level pass); this gives the corners of FAST per cell without
// ORB-SLAM's duplicates where cell windows overlap.
// Level l gets the share N (1 - 1/s) / (1 - 1/s^L) / s^l of N features (the last level the rest);
// a level with fewer corners than its share keeps them all (no carry-over, as ORB-SLAM).
// Deterministic: the same image gives the same features in the same order (level, then quadtree node).

#include <vector>

#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

#include "fleetslam/core/config.hpp"
#include "fleetslam/slam/frame.hpp"

namespace fleetslam::slam {

struct OrbExtractorConfig {
  int num_features = 1000;
  double scale_factor = 1.2;
  int num_levels = 8;
  int ini_fast_threshold = 20;
  int min_fast_threshold = 7;
  int cell_size_px = 30;  // FAST detection cell size on each level

  template <class V>
  void visit(V& v) {
    v("num_features", num_features, core::Limits<int>{10, 100000});
    v("scale_factor", scale_factor, core::Limits<double>{1.01, 4.0});
    v("num_levels", num_levels, core::Limits<int>{1, 20});
    v("ini_fast_threshold", ini_fast_threshold, core::Limits<int>{1, 255});
    v("min_fast_threshold", min_fast_threshold, core::Limits<int>{1, 255});
    v("cell_size_px", cell_size_px, core::Limits<int>{8, 200});
  }
};

// Corners closer than this to a level image's border are not detected (ORB-SLAM's EDGE_THRESHOLD).
inline constexpr int kOrbEdgePx = 19;
// Radius of the intensity-centroid disc (ORB's half patch size).
inline constexpr int kOrbOrientationRadiusPx = 15;

struct OrbFeatures {
  // Level-0 pixel coordinates, octave = level, angle in degrees [0, 360), response = FAST score,
  // size = 31 * scale of the level, class_id = -1.
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;                  // N x 32, CV_8UC1
  std::vector<cv::Mat> levels;          // the gray pyramid (unblurred), level 0 first; empty for no image
};

// The gray pyramid OrbExtractor works on: level 0 is `gray` (CV_8UC1, shared, not copied), level l is
// cv::resize (INTER_LINEAR) of level l-1 to round(size0 * pyramid.inv_scale[l]) (at least 1x1).
std::vector<cv::Mat> build_image_pyramid(const cv::Mat& gray, const ScalePyramid& pyramid);

// The corners the extractor distributes on one level image (CV_8UC1), in its coordinates: FAST corners
// at least kOrbEdgePx from the border, per cell_size_px cell those scoring >= ini_fast_threshold, or
// >= min_fast_threshold in cells without any (response = FAST score).
std::vector<cv::KeyPoint> detect_level_corners(const cv::Mat& level, const OrbExtractorConfig& config);

// Level-0 point -> the level image of size `level_size` (cv::resize's pixel-centre mapping), and back.
cv::Point2d to_level(const cv::Point2d& p0, const cv::Size& size0, const cv::Size& level_size);
cv::Point2d to_level0(const cv::Point2d& p, const cv::Size& size0, const cv::Size& level_size);

class OrbExtractor {
 public:
  // Throws InputError when min_fast_threshold > ini_fast_threshold or a field is out of its limits.
  explicit OrbExtractor(const OrbExtractorConfig& config);
  // image: CV_8UC1, or CV_8UC3 (BGR) / CV_8UC4 (BGRA), converted to gray. An empty or texture-less image
  // gives no features, not an error; any other type is an InputError.
  OrbFeatures extract(const cv::Mat& image) const;
  const ScalePyramid& pyramid() const { return pyramid_; }
  const OrbExtractorConfig& config() const { return config_; }
  // Target number of features of each level (sums to num_features).
  const std::vector<int>& features_per_level() const { return features_per_level_; }

 private:
  OrbExtractorConfig config_;
  ScalePyramid pyramid_;
  std::vector<int> features_per_level_;
};

}  // namespace fleetslam::slam
