#pragma once
// ORB features over a scale pyramid with an even spatial distribution (ORB-SLAM's scheme): FAST per
// grid cell on every level with a fallback threshold, a quadtree that keeps the strongest corner per
// node until the level's share of features is reached, intensity-centroid orientation and rBRIEF
// descriptors (OpenCV's building blocks where they fit).

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

struct OrbFeatures {
  std::vector<cv::KeyPoint> keypoints;  // level-0 pixel coordinates, octave = level, angle in degrees
  cv::Mat descriptors;                  // N x 32, CV_8UC1
};

class OrbExtractor {
 public:
  explicit OrbExtractor(const OrbExtractorConfig& config);
  // gray: CV_8UC1 (colour is converted). An empty or texture-less image gives no features, not an error.
  OrbFeatures extract(const cv::Mat& image) const;
  const ScalePyramid& pyramid() const { return pyramid_; }

 private:
  OrbExtractorConfig config_;
  ScalePyramid pyramid_;
  std::vector<int> features_per_level_;
};

}  // namespace fleetslam::slam
