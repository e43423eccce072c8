#pragma once
// Descriptor matching between two frames A and B.
//  - Brute force (reference): every pair, Hamming distance, ratio test.
//  - Projection ("grid registration"): with T_A_B known or predicted, each feature of B that has a 3D
//    point is projected into A and matched within a radius on A's feature grid, with ORB-SLAM's distance
//    threshold, ratio test and rotation-consistency histogram.
//  - Cross-validation (PAPER.md section 2): the projection match (stage 1, radius r1), then each matched
//    feature of A is projected back into B with T_B_A = T_A_B^-1 using A's own 3D point and searched
//    within r2 = r2_over_r1 * r1; the pair is kept only if stage 2's best candidate is the same feature
//    of B. A feature of A without a 3D point cannot be checked and is kept (monocular), counted apart.

#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>

#include "fleetslam/core/config.hpp"
#include "fleetslam/slam/frame.hpp"

namespace fleetslam::slam {

// Hamming distance of two 256-bit ORB descriptors (32 bytes each).
int hamming_distance(const std::uint8_t* a, const std::uint8_t* b);

struct MatcherConfig {
  double radius_px = 15.0;        // r1, at level 0 (scaled by the level's scale factor)
  int max_distance = 100;         // ORB-SLAM's TH_HIGH
  double nn_ratio = 0.9;          // best / second-best distance ratio (1 disables the test)
  bool check_orientation = true;  // rotation-consistency histogram (30 bins, keep the 3 largest)
  bool cross_validation = true;   // the paper's two-stage check
  double r2_over_r1 = 0.5;

  template <class V>
  void visit(V& v) {
    v("radius_px", radius_px, core::Limits<double>{0.5, 500.0});
    v("max_distance", max_distance, core::Limits<int>{0, 256});
    v("nn_ratio", nn_ratio, core::Limits<double>{0.1, 1.0});
    v("check_orientation", check_orientation);
    v("cross_validation", cross_validation);
    v("r2_over_r1", r2_over_r1, core::Limits<double>{0.05, 1.0});
  }
};

struct Match {
  int a = -1;  // feature index in A
  int b = -1;  // feature index in B
  int distance = 0;
};

struct MatchResult {
  std::vector<Match> matches;  // at most one per feature of A and per feature of B
  int stage1_matches = 0;      // before cross-validation (== matches.size() without it)
  int rejected_by_cross_check = 0;
  int unchecked = 0;           // kept without a 3D point in A to check them
};

// Per-feature 3D points in a frame's camera frame (nullopt where unknown).
using FeaturePoints = std::vector<std::optional<Eigen::Vector3d>>;

// Points from each feature's own depth (RGB-D / stereo).
FeaturePoints points_from_depth(const Frame& frame);

MatchResult match_brute_force(const Frame& a, const Frame& b, const MatcherConfig& config);

// Projection matching (and cross-validation when config.cross_validation). p_b: 3D points of B's
// features in B's camera frame; p_a: those of A (used by stage 2 only). T_a_b maps B-frame points to A.
MatchResult match_by_projection(const Frame& a, const FeaturePoints& p_a, const Frame& b, const FeaturePoints& p_b,
                                const Eigen::Isometry3d& T_a_b, const MatcherConfig& config);

// Stereo stripe search for rectified pairs (no cross-validation here, PAPER.md): for each left feature,
// right features on rows within +-2 sigma of its level, disparity in [0, bf / min_depth], best Hamming
// distance under max_distance, then sub-pixel refinement by SAD over an 11x11 window and a parabola fit.
// Fills depth_m and u_right of `left` (left.uv must be those of the rectified images).
struct StereoMatchConfig {
  int max_distance = 75;  // (TH_HIGH + TH_LOW) / 2
  double min_depth_m = 0.05;
  int window_half_px = 5;
  int search_half_px = 5;

  template <class V>
  void visit(V& v) {
    v("max_distance", max_distance, core::Limits<int>{0, 256});
    v("min_depth_m", min_depth_m, core::Limits<double>{0.001, 100.0});
    v("window_half_px", window_half_px, core::Limits<int>{1, 20});
    v("search_half_px", search_half_px, core::Limits<int>{1, 20});
  }
};
// left_image/right_image: rectified gray pyramids' level-0 images (CV_8UC1); right_keypoints and
// right_descriptors: the right image's ORB features. Returns the number of left features given depth.
int match_stereo(Frame& left, const cv::Mat& left_image, const std::vector<cv::KeyPoint>& right_keypoints,
                 const cv::Mat& right_descriptors, const cv::Mat& right_image, const StereoMatchConfig& config);

// RGB-D: depth of each feature from the registered depth image (metres, 0 = none) at its raw keypoint
// position, and the virtual right coordinate u - bf / depth. Returns the number of features given depth.
int assign_rgbd_depth(Frame& frame, const cv::Mat& depth_m, double min_depth_m, double max_depth_m);

}  // namespace fleetslam::slam
