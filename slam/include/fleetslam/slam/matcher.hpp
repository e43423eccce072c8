#pragma once
// Descriptor matching between two frames A and B.
//  - Brute force (reference): every pair, Hamming distance, distance threshold, ratio test, one-to-one
//    (no rotation check: a pure descriptor baseline).
//  - Projection ("grid registration"): with T_A_B known or predicted, each feature of B that has a 3D
//    point is projected into A and matched within a radius on A's feature grid, with ORB-SLAM's distance
//    threshold, ratio test and rotation-consistency histogram.
//  - Cross-validation (PAPER.md section 2): the projection match (stage 1, radius r1), then each matched
//    feature of A is projected back into B with T_B_A = T_A_B^-1 using A's own 3D point and searched
//    within r2 = r2_over_r1 * r1; the pair is kept only if stage 2's best candidate is the same feature
//    of B. A feature of A without a 3D point cannot be checked and is kept (monocular), counted apart.
//
// Details of the projection search (both stages; "seen" is the frame the point comes from, "searched"
// the frame whose grid is queried):
//  - Radius: radius_px * scale[level of the seen feature] (stage 2: r2_over_r1 times that, with A's level).
//  - Levels: ORB-SLAM's scale prediction from the feature's own level, predicted = level +
//    log(distance seen / distance searched) / log(scale_factor), clamped to the pyramid; candidates at
//    levels within 1.5 of it (the predicted level +-1 when it is an integer; the window is symmetric, so
//    with agreeing depths stage 2's window holds the level of the B feature stage 1 chose).
//  - A point behind the searched camera or projecting outside its frame area (Frame::bounds, or the
//    image) has no candidates: in stage 1 the B feature stays unmatched, in stage 2 the pair is rejected.
//  - Stage 1 keeps the closest candidate when its distance <= max_distance and <= nn_ratio * the second
//    closest (another feature); then one-to-one (several B features on one A feature: the closest wins,
//    the first in B order on ties); then the rotation histogram: 30 bins of the keypoint angle difference
//    (bin 0 centred on no rotation), matches outside the three fullest bins dropped (the second and third
//    only count with >= 10 % of the first's matches, as in ORB-SLAM).
//  - Stage 2 keeps the pair when its B feature is among the candidates and none is strictly closer to A's
//    descriptor (a tie cannot tell them apart, so it does not overrule stage 1); no threshold or ratio.
// Deterministic: results depend only on the inputs. Frames must be finalize()d (their grids are used).

#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>

#include "fleetslam/core/config.hpp"
#include "fleetslam/slam/frame.hpp"

namespace fleetslam::slam {

// Hamming distance of two 256-bit ORB descriptors (32 bytes each, any alignment): four 64-bit popcounts,
// with the POPCNT instruction where the CPU has it (chosen at load time on x86-64 Linux).
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
  std::vector<Match> matches;  // at most one per feature of A and per feature of B; sorted by A index
  int stage1_matches = 0;      // before cross-validation (== matches.size() without it)
  int rejected_by_cross_check = 0;  // stage1_matches == matches.size() + rejected_by_cross_check
  int unchecked = 0;           // kept without a 3D point in A to check them (included in matches)
};

// Per-feature 3D points in a frame's camera frame (nullopt where unknown).
using FeaturePoints = std::vector<std::optional<Eigen::Vector3d>>;

// Points from each feature's own depth (RGB-D / stereo): Frame::unproject of every feature.
FeaturePoints points_from_depth(const Frame& frame);

// Each feature of B against every feature of A (radius_px, check_orientation, cross_validation and
// r2_over_r1 unused). stage1_matches == matches.size().
MatchResult match_brute_force(const Frame& a, const Frame& b, const MatcherConfig& config);

// Projection matching (and cross-validation when config.cross_validation). p_b: 3D points of B's
// features in B's camera frame; p_a: those of A (used by stage 2 only; may be empty without it).
// T_a_b maps B-frame points to A. Sizes of p_a / p_b, descriptors (N x 32 CV_8UC1), levels and, for the
// rotation check, keypoints are checked (InvariantError). Empty frames give no matches.
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
