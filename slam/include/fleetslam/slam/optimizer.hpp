#pragma once
// Ceres optimisation of poses and points with a robust (Huber) kernel and chi-square outlier rejection,
// as ORB-SLAM does it: pose-only optimisation for tracking, local bundle adjustment for local mapping.
// Residuals are in pixels weighted by the keypoint's level (inv_sigma2); stereo/RGB-D observations
// carry a third residual on the (virtual) right u coordinate, u_R = u - bf / z. The chi-square statistic
// is the weighted squared residual, inv_sigma2 * |e|^2; Huber's delta is sqrt(chi2 threshold).
// A pose is a unit quaternion on Ceres' EigenQuaternionManifold plus a translation; Jacobians are
// analytic. Pose-only optimisation puts a round's observations in one residual block with Huber applied
// per observation inside it (exact Huber cost and gradient, see optimizer.cpp): about half the time of
// one block per observation, where Ceres' per-block bookkeeping cost more than the residuals. Bundle
// adjustment has one block per observation with Ceres' HuberLoss. Single-threaded by default and free
// of randomness: the same input gives the same bits.

#include <optional>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "fleetslam/core/camera.hpp"
#include "fleetslam/core/config.hpp"

namespace fleetslam::slam {

struct Observation {
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();  // undistorted pixel
  // Right-image u (stereo, or virtual for RGB-D; may be negative): three residuals. None: monocular, two.
  std::optional<double> u_right;
  double inv_sigma2 = 1.0;                       // 1 / sigma^2 of the keypoint's level
};

struct OptimizerConfig {
  // Pose-only optimisation (optimize_pose): optimise, classify outliers, repeat (outliers left out).
  // bundle_adjust always runs two passes (robust, then plain) and does not read it.
  int rounds = 4;
  int iterations_per_round = 10;
  // Pose-only rounds with the robust kernel: with many residuals far beyond Huber's delta (a poor
  // initial pose) the batched kernel (see above) needs more iterations than Ceres' per-block
  // correction; a round stops when it converges.
  int pose_robust_iterations = 20;
  double chi2_mono = 5.991;       // 95 % with 2 dof
  double chi2_stereo = 7.815;     // 95 % with 3 dof
  int num_threads = 1;            // deterministic by default

  template <class V>
  void visit(V& v) {
    v("rounds", rounds, core::Limits<int>{1, 20});
    v("iterations_per_round", iterations_per_round, core::Limits<int>{1, 200});
    v("pose_robust_iterations", pose_robust_iterations, core::Limits<int>{1, 200});
    v("chi2_mono", chi2_mono, core::Limits<double>{0.1, 1000.0});
    v("chi2_stereo", chi2_stereo, core::Limits<double>{0.1, 1000.0});
    v("num_threads", num_threads, core::Limits<int>{1, 64});
  }
};

// ---- pose-only -------------------------------------------------------------------------------------------

struct PoseObservation {
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();  // the map point (held fixed)
  Observation obs;
};

struct PoseResult {
  Eigen::Isometry3d T_cam_world = Eigen::Isometry3d::Identity();
  std::vector<bool> outlier;  // per observation, classified at the final pose
  int inliers = 0;
  bool ok = false;            // false with fewer than 3 observations, fewer than 3 inliers left, or a failed solve
};

// camera: undistorted intrinsics; bf: baseline * fx (used by stereo observations).
// config.rounds rounds of config.iterations_per_round iterations (pose_robust_iterations with the
// kernel): each optimises over the current inliers
// (Huber, except in the last round, which is plain least squares), then classifies every observation by
// chi2 at the new pose (earlier outliers may come back). Points not in front of the camera are outliers.
// The pose carries over from round to round. With fewer than 3 observations the initial pose is returned.
PoseResult optimize_pose(const core::PinholeCamera& camera, double bf, const std::vector<PoseObservation>& observations,
                         const Eigen::Isometry3d& T_cam_world_initial, const OptimizerConfig& config);

// Indices of the observations whose image point (obs.uv; u_right is not used) lies within the chi-square
// gate chi2 (2 dof) of its projection at T_cam_world, in its level's sigma (obs.inv_sigma2): ORB-SLAM's
// PnP inlier test. Points not in front of the camera fail.
std::vector<int> reprojection_inliers(const core::PinholeCamera& camera, const std::vector<PoseObservation>& observations,
                                      const Eigen::Isometry3d& T_cam_world, double chi2);

// ---- local bundle adjustment -------------------------------------------------------------------------

struct BaKeyframe {
  Eigen::Isometry3d T_cam_world = Eigen::Isometry3d::Identity();
  bool fixed = false;  // outer keyframes that observe local points but are not optimised
};

struct BaObservation {
  int keyframe = -1;  // index into BaProblem::keyframes
  int point = -1;     // index into BaProblem::points
  Observation obs;
};

struct BaProblem {
  std::vector<BaKeyframe> keyframes;
  std::vector<Eigen::Vector3d> points_world;
  std::vector<BaObservation> observations;
};

struct BaResult {
  std::vector<Eigen::Isometry3d> T_cam_world;  // per keyframe (fixed ones unchanged)
  std::vector<Eigen::Vector3d> points_world;
  std::vector<bool> outlier;                   // per observation, after the final round
  // Reprojection RMS, sqrt(mean |uv - projection|^2) in pixels (left image, unweighted), over the
  // observations that are inliers after the final round, at the input state and at the result.
  double initial_rms_px = 0.0;
  double final_rms_px = 0.0;
  bool ok = false;
};

// Local BA with Ceres (SPARSE_SCHUR with SuiteSparse when available, points eliminated first), two
// passes of config.iterations_per_round iterations: optimise with Huber, drop chi-square outliers and
// points behind their camera, optimise again without the kernel (as ORB-SLAM2), classify once more.
// At least one keyframe must be fixed (gauge): otherwise ok is false and the input is returned.
// Observations naming a keyframe or point out of range are a broken invariant (FLEETSLAM_CHECK).
BaResult bundle_adjust(const core::PinholeCamera& camera, double bf, const BaProblem& problem,
                       const OptimizerConfig& config);

}  // namespace fleetslam::slam
