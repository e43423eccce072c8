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
//  - Stage 1 keeps the closest candidate (the lower A index among equally close ones) when its distance
//    <= max_distance and <= nn_ratio * the second closest (another feature); then one-to-one (several B
//    features on one A feature: the closest wins, the first in B order on ties); then the rotation
//    histogram: 30 bins of the keypoint angle difference (bin 0 centred on no rotation), matches outside
//    the three fullest bins dropped (the second and third only count with >= 10 % of the first's matches,
//    as in ORB-SLAM).
//  - Stage 2 keeps the pair when its B feature is among the candidates and none is strictly closer to A's
//    descriptor (a tie cannot tell them apart, so it does not overrule stage 1); no threshold or ratio.
// Deterministic: results depend only on the inputs. Frames must be finalize()d (their grids are used).
// Cost: one grid search per B feature with a 3D point (stage 1) and, with cross-validation, one smaller
// search per stage-1 match whose B feature passes the level and r2 tests itself (stage 2); candidates are
// taken from the grid as they come (FeatureGrid::scan_area in stage 1, visit_area in stage 2), without
// allocating.

#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>

#include "fleetslam/core/config.hpp"
#include "fleetslam/slam/frame.hpp"
#include "fleetslam/slam/vocabulary.hpp"

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

// BoW-guided matching (ORB-SLAM's SearchByBoW idea): only features that share a vocabulary node of the
// direct index (FeatureVector, same levels_up for both) are compared. Each usable feature of A takes its
// closest usable B feature in the node when the distance <= max_distance and <= nn_ratio * the second
// closest; then one-to-one on B (the closest wins, the lower A index on ties); then the rotation
// histogram as match_by_projection. usable_a / usable_b: per feature whether it takes part (empty: all;
// otherwise one entry per feature, checked). Returns matches sorted by A index. Deterministic.
struct BowMatchConfig {
  int max_distance = 50;   // ORB-SLAM's TH_LOW
  double nn_ratio = 0.75;
  bool check_orientation = true;

  template <class V>
  void visit(V& v) {
    v("max_distance", max_distance, core::Limits<int>{0, 256});
    v("nn_ratio", nn_ratio, core::Limits<double>{0.1, 1.0});
    v("check_orientation", check_orientation);
  }
};
std::vector<Match> search_by_bow(const Frame& a, const FeatureVector& words_a, const std::vector<bool>& usable_a,
                                 const Frame& b, const FeatureVector& words_b, const std::vector<bool>& usable_b,
                                 const BowMatchConfig& config);

// Stereo stripe search for rectified pairs (no cross-validation here, PAPER.md), after ORB-SLAM's
// ComputeStereoMatches: for each left feature, the right features of levels within +-1 of its level on
// rows within +-row_band_scales * scale of their level, with u_right in [u - bf / min_depth_m, u]; the best
// Hamming distance below max_distance wins. Sub-pixel refinement on the left feature's level image: the
// (2 window_half_px + 1)^2 window around the left feature is compared by SAD (each window minus its mean,
// which absorbs a brightness offset between the cameras) at the right match's column +-search_half_px;
// a minimum at either end of the search is rejected, a parabola through the minimum and its neighbours
// gives the sub-pixel offset, and a disparity outside (0, bf / min_depth_m) is rejected. Last, matches
// whose SAD exceeds outlier_median_factor * median SAD (ORB-SLAM's 1.5 * 1.4) are dropped.
// Fills depth_m = bf / disparity and u_right of `left` (-1 for features without a match); left.uv and
// left.keypoints must be those of the rectified left image, left.bf > 0 (checked).
struct StereoMatchConfig {
  int max_distance = 75;  // (TH_HIGH + TH_LOW) / 2
  double min_depth_m = 0.05;
  int window_half_px = 5;
  int search_half_px = 5;
  double row_band_scales = 2.0;         // half-height of a right feature's row band, in its level's scale
  double outlier_median_factor = 2.1;   // ORB-SLAM: 1.5 * 1.4 * median SAD

  template <class V>
  void visit(V& v) {
    v("max_distance", max_distance, core::Limits<int>{0, 256});
    v("min_depth_m", min_depth_m, core::Limits<double>{0.001, 100.0});
    v("window_half_px", window_half_px, core::Limits<int>{1, 20});
    v("search_half_px", search_half_px, core::Limits<int>{1, 20});
    v("row_band_scales", row_band_scales, core::Limits<double>{0.0, 20.0});
    v("outlier_median_factor", outlier_median_factor, core::Limits<double>{0.1, 100.0});
  }
};
// left_image/right_image: rectified gray level-0 images (CV_8UC1, checked); their pyramids
// are rebuilt with left.pyramid as OrbExtractor builds them. right_keypoints and right_descriptors: the
// right image's ORB features (level-0 coordinates, octave = level). Returns the number of left
// features given depth.
int match_stereo(Frame& left, const cv::Mat& left_image, const std::vector<cv::KeyPoint>& right_keypoints,
                 const cv::Mat& right_descriptors, const cv::Mat& right_image, const StereoMatchConfig& config);
// The same on pyramids already built (OrbFeatures::levels of both images): no image is resized again.
int match_stereo_levels(Frame& left, const std::vector<cv::Mat>& left_levels,
                        const std::vector<cv::KeyPoint>& right_keypoints, const cv::Mat& right_descriptors,
                        const std::vector<cv::Mat>& right_levels, const StereoMatchConfig& config);

// RGB-D: depth of each feature from the registered depth image (CV_32FC1, metres, 0 = none; checked) at
// its raw keypoint position rounded to the nearest pixel, and the virtual right coordinate
// u_right = uv.x - bf / depth (left -1 when bf <= 0). Readings that are not finite or outside
// [min_depth_m, max_depth_m], and keypoints outside the depth image, give no depth (-1). Returns the
// number of features given depth.
int assign_rgbd_depth(Frame& frame, const cv::Mat& depth_m, double min_depth_m, double max_depth_m);

}  // namespace fleetslam::slam
