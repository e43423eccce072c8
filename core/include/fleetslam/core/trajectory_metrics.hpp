#pragma once
// Trajectory metrics: association of an estimate with ground truth, alignment, ATE and RPE.
// Association and ATE follow the TUM RGB-D benchmark tools (associate.py, evaluate_ate.py) exactly, so
// the numbers here match theirs; RPE uses evaluate_rpe.py's error, E_ij = (P_i^-1 P_j) (Q_i^-1 Q_j)^-1 with
// Q ground truth and P the estimate (Sturm et al. 2012 write (Q_i^-1 Q_j)^-1 (P_i^-1 P_j): the same
// rotation angle, a translation that can differ by millimetres; the tool's is the one papers report).
//
// Failure is a field of the result, not an exception: too few pairs or degenerate geometry give a
// status the caller checks (the CLI turns them into errors naming the files).

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "fleetslam/core/time.hpp"
#include "fleetslam/core/trajectory.hpp"

namespace fleetslam::core {

// ---- association ---------------------------------------------------------------------------------

// One ground-truth pose matched with one estimated pose (indices into the two trajectories).
struct PosePair {
  std::size_t gt_index = 0;
  std::size_t est_index = 0;
  friend bool operator==(const PosePair& a, const PosePair& b) {
    return a.gt_index == b.gt_index && a.est_index == b.est_index;
  }
};

struct TimeAssociationConfig {
  TimeNs max_difference_ns = 20'000'000;  // pairs need |t_gt - (t_est + offset)| < max_difference
  TimeNs offset_ns = 0;                   // added to the estimate's stamps
};

// associate.py: every (gt, est) with |t_gt - (t_est + offset)| < max_difference is a candidate; the
// candidates are taken greedily in order of (difference, t_gt, t_est), each pose used at most once;
// the pairs come back sorted by ground-truth time. Differences are exact integer nanoseconds.
std::vector<PosePair> associate_by_time(const Trajectory& gt, const Trajectory& est,
                                        const TimeAssociationConfig& config = {});

// KITTI: pose i with pose i for i < min(gt.size(), est.size()).
std::vector<PosePair> associate_by_index(const Trajectory& gt, const Trajectory& est);

// ---- alignment -----------------------------------------------------------------------------------

enum class AlignmentMode { kNone, kSe3, kSim3 };
std::string to_string(AlignmentMode mode);  // "none", "se3", "sim3"
std::optional<AlignmentMode> alignment_mode_from_string(const std::string& name);

enum class AlignmentStatus {
  kOk,
  kTooFewPairs,  // se3/sim3 with fewer than 3 pairs: the transform is left at identity
  kDegenerate,   // collinear (or coincident) estimate positions: the transform below still minimises the
                 // squared error, but the rotation about the line is arbitrary (and for coincident points
                 // the scale is left at 1)
};
std::string to_string(AlignmentStatus status);

// The similarity that maps the estimate into the ground-truth frame: p_gt ~ scale * R * p_est + t,
// with R = T_gt_est.linear(), t = T_gt_est.translation(). scale is 1 except for kSim3.
struct Alignment {
  AlignmentMode mode = AlignmentMode::kNone;
  AlignmentStatus status = AlignmentStatus::kOk;
  Eigen::Isometry3d T_gt_est = Eigen::Isometry3d::Identity();
  double scale = 1.0;

  bool ok() const { return status == AlignmentStatus::kOk; }
  Eigen::Vector3d apply(const Eigen::Vector3d& p_est) const;
  // Pose of the body in the ground-truth frame: rotation R * R_est, position scale * R * t_est + t.
  Eigen::Isometry3d apply(const Eigen::Isometry3d& T_est_body) const;
};

// Closed-form least squares (Umeyama 1991; Horn 1987 for se3, as evaluate_ate.py) of
// sum |gt_i - (s R est_i + t)|^2. est and gt must have the same size.
Alignment align_positions(const std::vector<Eigen::Vector3d>& est, const std::vector<Eigen::Vector3d>& gt,
                          AlignmentMode mode);

// The estimate moved into the ground-truth frame (every pose, matched or not).
Trajectory apply_alignment(const Alignment& alignment, const Trajectory& est);

// ---- statistics ----------------------------------------------------------------------------------

// Summary of non-negative errors. median as numpy.median (mean of the two middle values for an even
// count), std the population standard deviation (numpy.std). All NaN when count == 0.
struct ErrorStats {
  std::size_t count = 0;
  double rmse = 0.0;
  double mean = 0.0;
  double median = 0.0;
  double std = 0.0;
  double min = 0.0;
  double max = 0.0;
};
ErrorStats compute_stats(const std::vector<double>& values);

// ---- absolute trajectory error -------------------------------------------------------------------

struct AteResult {
  std::vector<PosePair> pairs;
  Alignment alignment;
  std::vector<TimeNs> t_ns;         // ground-truth stamp of each pair (for plots over time)
  std::vector<double> errors_m;     // |gt - aligned est| per pair
  ErrorStats stats;
  bool ok() const { return !pairs.empty() && alignment.ok(); }
  // Whether the errors are the ATE: there are pairs and the alignment was computed. A degenerate one
  // counts: collinear (or coincident) estimate positions leave free only a rotation about their line,
  // which moves none of them, so every error is the same whichever rotation is taken.
  bool measured() const { return !pairs.empty() && alignment.status != AlignmentStatus::kTooFewPairs; }
};

// Aligns the paired positions (mode) and measures the translational error of every pair.
AteResult compute_ate(const Trajectory& gt, const Trajectory& est, const std::vector<PosePair>& pairs,
                      AlignmentMode mode);

// ---- relative pose error -------------------------------------------------------------------------

enum class RpeUnit { kFrames, kMeters, kSeconds };
std::string to_string(RpeUnit unit);  // "frames", "m", "s"
std::optional<RpeUnit> rpe_unit_from_string(const std::string& name);

struct RpeConfig {
  double delta = 1.0;               // frames (a positive integer), metres or seconds; > 0
  RpeUnit unit = RpeUnit::kFrames;
};

// Over the sequence of pairs (in time order), pair k is compared with pair j:
//   frames: the pair of the estimate's pose delta poses after k's (none when that pose is not paired),
//           as evaluate_rpe.py steps through the estimate's poses;
//   m:      the first j > k whose distance travelled along the ground truth (summed over the paired
//           ground-truth positions) from k reaches delta;
//   s:      the first j > k whose ground-truth stamp is at least delta seconds after k's.
// A gap is a step between consecutive pairs' ground-truth stamps longer than twice the median step (a
// drop-out of tracking or ground truth; evaluate_rpe.py's bound). A (k, j) found across one is left out
// and counted in skipped_across_gaps: in seconds, j's stamp more than that step beyond k's + delta (no
// pose near t + delta); in metres, a gap anywhere between them (the distance across it is unknown).
// Each (k, j) gives E = (P_k^-1 P_j) (Q_k^-1 Q_j)^-1 (evaluate_rpe.py's order, above); the translational
// error is |trans(E)| and the rotational error the angle of rot(E). est_scale multiplies the estimate's
// relative translations (the sim3 alignment scale; rigid alignment does not change relative motion).
struct RpeResult {
  RpeConfig config;
  std::vector<std::size_t> from_pair, to_pair;  // indices into the pairs
  std::vector<TimeNs> t_ns;                     // ground-truth stamp of from_pair
  std::vector<double> translation_errors_m;
  std::vector<double> rotation_errors_rad;
  ErrorStats translation_m;
  ErrorStats rotation_rad;
  std::size_t skipped_across_gaps = 0;  // pairs whose partner lies across a gap (left out)
};

// Throws InvariantError on a non-positive delta or a fractional frame delta (callers validate input).
RpeResult compute_rpe(const Trajectory& gt, const Trajectory& est, const std::vector<PosePair>& pairs,
                      const RpeConfig& config, double est_scale = 1.0);

}  // namespace fleetslam::core
