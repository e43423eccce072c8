#pragma once
// The matchers paper Table 1 compares, behind one call, and the ground-truth check of their matches
// (PAPER.md section 2). Shared by `fleetslam experiment matching` and tests/bench/bench_matching.cpp.
//   brute_force          fleetslam's reference (slam::match_brute_force)
//   brute_force_opencv   cv::BFMatcher, NORM_HAMMING, two nearest neighbours + Lowe's ratio
//   flann_lsh            cv::FlannBasedMatcher with an LSH index over A (built in every match, as between
//                        two new frames), two nearest neighbours + Lowe's ratio
//   grid                 projection on A's feature grid with the predicted T_A_B (ORB-SLAM, single stage)
//   cross_validation     the paper's two-stage projection matching
// OpenCV matchers take B's descriptors as queries against A's. FLANN's LSH tables draw from the C
// library's generator: run_matcher seeds it (MatchSettings::lsh_seed) before every index build, so the
// same input gives the same matches.

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "fleetslam/slam/frame.hpp"
#include "fleetslam/slam/matcher.hpp"

namespace fleetslam::experiments {

enum class MatcherKind { kBruteForce, kBruteForceOpenCv, kFlannLsh, kGrid, kCrossValidation };

// "brute_force", "brute_force_opencv", "flann_lsh", "grid", "cross_validation".
std::string to_string(MatcherKind kind);
std::vector<MatcherKind> all_matchers();
// The kind named as to_string names it; nullopt for any other name.
std::optional<MatcherKind> matcher_from_string(const std::string& name);

// Two frames to match, A the earlier one, with their features' 3D points and the transforms.
struct MatchPair {
  slam::Frame a;
  slam::Frame b;
  slam::FeaturePoints p_a;
  slam::FeaturePoints p_b;
  Eigen::Isometry3d T_a_b_true = Eigen::Isometry3d::Identity();       // ground truth
  Eigen::Isometry3d T_a_b_predicted = Eigen::Isometry3d::Identity();  // what the projection matchers get
};

struct MatchSettings {
  slam::MatcherConfig projection;  // grid and cross_validation (cross_validation is set per matcher)
  float lowe_ratio = 0.8F;         // OpenCV matchers
  int lsh_tables = 12;             // FLANN LSH index
  int lsh_key_bits = 20;
  int lsh_multi_probe = 2;
  unsigned lsh_seed = 1;
};

// One match of B against A by `kind`.
std::vector<slam::Match> run_matcher(MatcherKind kind, const MatchPair& pair, const MatchSettings& settings);

// How the matches fare against the true relative pose and depth. A match is checked with B's depth
// point moved into A by T_a_b_true (else A's depth point moved into B), and is correct when it projects
// within correct_px of its partner; without depth on either side it is unverifiable. A B feature with depth
// "has a true partner" when some feature of A lies within correct_px of its true projection.
struct MatchQuality {
  int matches = 0;
  int verifiable = 0;
  int correct = 0;
  int with_partner = 0;          // B features that have a true partner
  int correct_with_partner = 0;  // correct matches of such features (checked with B's depth)

  double precision() const;  // correct / verifiable (NaN without verifiable matches)
  double recall() const;     // correct_with_partner / with_partner (NaN without partners)
  MatchQuality& operator+=(const MatchQuality& o);
};

MatchQuality evaluate_matches(const MatchPair& pair, const std::vector<slam::Match>& matches, double correct_px);

}  // namespace fleetslam::experiments
