// Pose-only optimisation and local bundle adjustment with Ceres, following ORB-SLAM's scheme (robust
// rounds, chi-square classification, a last round without the robust kernel), written from its
// description. A pose is two Ceres parameter blocks: an Eigen-ordered unit quaternion (x, y, z, w) on
// EigenQuaternionManifold and a translation; p_cam = R(q) p_world + t. Residuals are analytic.

#include "fleetslam/slam/optimizer.hpp"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include "fleetslam/core/error.hpp"

namespace fleetslam::slam {
namespace {

using Vector3 = Eigen::Vector3d;

// Ceres hands Jacobians as row-major arrays.
template <int kRows, int kCols>
Eigen::Map<Eigen::Matrix<double, kRows, kCols, Eigen::RowMajor>> jacobian_block(double* data) {
  return Eigen::Map<Eigen::Matrix<double, kRows, kCols, Eigen::RowMajor>>(data);
}

// Undistorted intrinsics and the stereo baseline times fx.
struct Intrinsics {
  double fx = 1.0, fy = 1.0, cx = 0.0, cy = 0.0, bf = 0.0;
};

Intrinsics intrinsics_of(const core::PinholeCamera& camera, double bf) {
  return {camera.fx(), camera.fy(), camera.cx(), camera.cy(), bf};
}

bool is_stereo(const Observation& obs) { return obs.u_right.has_value(); }

// Weighted residual r = sqrt(inv_sigma2) (z - h(p_cam)) of a mono (kDim 2) or stereo (kDim 3) observation,
// so that r.r is the chi-square statistic ORB-SLAM thresholds. dr_dp (optional) is d r / d p_cam.
// False when the point is not in front of the camera (the projection is undefined there).
template <int kDim>
bool weighted_residual(const Intrinsics& k, const Observation& obs, const Vector3& p_cam, double* r,
                       Eigen::Matrix<double, kDim, 3>* dr_dp) {
  if (!(p_cam.z() > core::PinholeCamera::min_depth)) return false;
  const double w = std::sqrt(obs.inv_sigma2);
  const double inv_z = 1.0 / p_cam.z();
  const double u = k.fx * p_cam.x() * inv_z + k.cx;
  r[0] = w * (obs.uv.x() - u);
  r[1] = w * (obs.uv.y() - (k.fy * p_cam.y() * inv_z + k.cy));
  if constexpr (kDim == 3) r[2] = w * (*obs.u_right - (u - k.bf * inv_z));
  if (dr_dp != nullptr) {
    const double inv_z2 = inv_z * inv_z;
    Eigen::Matrix<double, kDim, 3>& J = *dr_dp;
    J.row(0) << -w * k.fx * inv_z, 0.0, w * k.fx * p_cam.x() * inv_z2;
    J.row(1) << 0.0, -w * k.fy * inv_z, w * k.fy * p_cam.y() * inv_z2;
    if constexpr (kDim == 3) J.row(2) << J(0, 0), 0.0, J(0, 2) - w * k.bf * inv_z2;
  }
  return true;
}

// d (R(q) p) / d q for a unit quaternion in Eigen's (x, y, z, w) order, from
// R(q) p = p + 2 w (v x p) + 2 v x (v x p) with v = (x, y, z). Ceres chains it with the manifold's
// plus-Jacobian, so only its tangent directions matter.
Eigen::Matrix<double, 3, 4> rotated_point_jacobian(const Eigen::Quaterniond& q, const Vector3& p) {
  const Vector3 v = q.vec();
  const double w = q.w();
  Eigen::Matrix3d skew_p;
  skew_p << 0.0, -p.z(), p.y(), p.z(), 0.0, -p.x(), -p.y(), p.x(), 0.0;
  Eigen::Matrix<double, 3, 4> J;
  J.leftCols<3>() =
      -2.0 * w * skew_p + 2.0 * (v.dot(p) * Eigen::Matrix3d::Identity() + v * p.transpose() - 2.0 * p * v.transpose());
  J.col(3) = 2.0 * v.cross(p);
  return J;
}

// Residual of one observation and the Jacobians Ceres asks for (row-major; null when not wanted).
template <int kDim>
bool evaluate_observation(const Intrinsics& k, const Observation& obs, const double* q_xyzw, const double* t,
                          const double* p_world, double* residual, double* J_q, double* J_t, double* J_p) {
  const Eigen::Map<const Eigen::Quaterniond> q(q_xyzw);
  const Eigen::Map<const Vector3> p(p_world);
  const Eigen::Matrix3d R = q.toRotationMatrix();
  const Vector3 p_cam = R * p + Eigen::Map<const Vector3>(t);
  const bool want_jacobian = J_q != nullptr || J_t != nullptr || J_p != nullptr;
  Eigen::Matrix<double, kDim, 3> dr_dp;
  if (!weighted_residual<kDim>(k, obs, p_cam, residual, want_jacobian ? &dr_dp : nullptr)) return false;
  if (J_q != nullptr) jacobian_block<kDim, 4>(J_q) = dr_dp * rotated_point_jacobian(q, p);
  if (J_t != nullptr) jacobian_block<kDim, 3>(J_t) = dr_dp;
  if (J_p != nullptr) jacobian_block<kDim, 3>(J_p) = dr_dp * R;
  return true;
}

// Huber's rho(s) = s for s <= delta^2, 2 delta sqrt(s) - delta^2 beyond (Ceres' HuberLoss; the cost is
// rho / 2), applied inside a residual: r' = g r with g = sqrt(rho(s) / s), so |r'|^2 = rho(s), and
// J' = a J + c r r^T J with a = sqrt(rho'(s)) (Ceres' own correction of a Huber residual's Jacobian) and
// c = (rho' / g - a) / s, which makes J'^T r' = rho' J^T r, Huber's exact gradient. The cost and
// gradient are Huber's; only the Gauss-Newton curvature along r itself is rho' / 2 instead of Ceres'
// rho' for residuals far beyond delta (the true curvature there is 0): the same minimum.
template <int kDim>
void apply_huber(double delta, double* r, double* J, int cols) {
  double s = 0.0;
  for (int i = 0; i < kDim; ++i) s += r[i] * r[i];
  if (!(s > delta * delta)) return;
  const double sqrt_s = std::sqrt(s);
  const double rho = 2.0 * delta * sqrt_s - delta * delta;
  const double rho1 = delta / sqrt_s;
  const double g = std::sqrt(rho / s);
  const double a = std::sqrt(rho1);
  const double c = (rho1 / g - a) / s;
  if (J != nullptr) {
    for (int col = 0; col < cols; ++col) {
      double rtj = 0.0;
      for (int i = 0; i < kDim; ++i) rtj += r[i] * J[i * cols + col];
      for (int i = 0; i < kDim; ++i) J[i * cols + col] = a * J[i * cols + col] + c * r[i] * rtj;
    }
  }
  for (int i = 0; i < kDim; ++i) r[i] *= g;
}

// Tracking: every observation of a round in one residual block (the map points are fixed; parameters
// are the pose's quaternion and translation), mono observations 2 rows, stereo 3, in the order given.
// One block instead of one per observation: Ceres' per-block work (evaluation bookkeeping, validity
// checks, loss correction, Jacobian scatter) cost several times the residuals themselves. Huber, when
// robust, per observation (apply_huber).
class PoseBatchCost final : public ceres::CostFunction {
 public:
  PoseBatchCost(const Intrinsics& k, const std::vector<PoseObservation>& observations, std::vector<std::size_t> used,
                const OptimizerConfig& config, bool robust)
      : k_(k), observations_(observations), used_(std::move(used)), robust_(robust),
        delta_mono_(std::sqrt(config.chi2_mono)), delta_stereo_(std::sqrt(config.chi2_stereo)) {
    int rows = 0;
    for (std::size_t i : used_) rows += is_stereo(observations_[i].obs) ? 3 : 2;
    set_num_residuals(rows);
    mutable_parameter_block_sizes()->assign({4, 3});
  }

  bool Evaluate(double const* const* x, double* residuals, double** jacobians) const override {
    double* J_q = jacobians != nullptr ? jacobians[0] : nullptr;
    double* J_t = jacobians != nullptr ? jacobians[1] : nullptr;
    const Eigen::Map<const Eigen::Quaterniond> q(x[0]);
    const Eigen::Matrix3d R = q.toRotationMatrix();
    const Eigen::Map<const Vector3> t(x[1]);
    const bool want_jacobian = J_q != nullptr || J_t != nullptr;
    std::size_t row = 0;
    for (std::size_t i : used_) {
      const PoseObservation& o = observations_[i];
      const Vector3 p_cam = R * o.p_world + t;
      const bool ok = is_stereo(o.obs) ? evaluate<3>(o, q, p_cam, want_jacobian, residuals + row, J_q, J_t, row)
                                       : evaluate<2>(o, q, p_cam, want_jacobian, residuals + row, J_q, J_t, row);
      if (!ok) return false;
      row += is_stereo(o.obs) ? 3 : 2;
    }
    return true;
  }

 private:
  template <int kDim>
  bool evaluate(const PoseObservation& o, const Eigen::Quaterniond& q, const Vector3& p_cam, bool want_jacobian,
                double* r, double* J_q, double* J_t, std::size_t row) const {
    Eigen::Matrix<double, kDim, 3> dr_dp;
    if (!weighted_residual<kDim>(k_, o.obs, p_cam, r, want_jacobian ? &dr_dp : nullptr)) return false;
    // Both Jacobians of this observation side by side (4 + 3 columns) for the kernel, then scattered.
    Eigen::Matrix<double, kDim, 7, Eigen::RowMajor> J;
    if (want_jacobian) {
      J.template leftCols<4>() = dr_dp * rotated_point_jacobian(q, o.p_world);
      J.template rightCols<3>() = dr_dp;
    }
    if (robust_) apply_huber<kDim>(kDim == 3 ? delta_stereo_ : delta_mono_, r, want_jacobian ? J.data() : nullptr, 7);
    if (J_q != nullptr) jacobian_block<kDim, 4>(J_q + row * 4) = J.template leftCols<4>();
    if (J_t != nullptr) jacobian_block<kDim, 3>(J_t + row * 3) = J.template rightCols<3>();
    return true;
  }

  Intrinsics k_;
  const std::vector<PoseObservation>& observations_;
  std::vector<std::size_t> used_;
  bool robust_;
  double delta_mono_;
  double delta_stereo_;
};

// Bundle adjustment: quaternion, translation and point are all parameters (Ceres skips the Jacobians of
// blocks held constant, which is how fixed keyframes enter).
template <int kDim>
class BaCost final : public ceres::SizedCostFunction<kDim, 4, 3, 3> {
 public:
  BaCost(const Intrinsics& k, const Observation& obs) : k_(k), obs_(obs) {}
  bool Evaluate(double const* const* x, double* residuals, double** jacobians) const override {
    const auto jacobian = [jacobians](int i) { return jacobians != nullptr ? jacobians[i] : nullptr; };
    return evaluate_observation<kDim>(k_, obs_, x[0], x[1], x[2], residuals, jacobian(0), jacobian(1), jacobian(2));
  }

 private:
  Intrinsics k_;
  Observation obs_;
};

// A pose as Ceres parameter blocks.
struct PoseBlocks {
  double q[4] = {0.0, 0.0, 0.0, 1.0};  // x, y, z, w
  double t[3] = {0.0, 0.0, 0.0};

  explicit PoseBlocks(const Eigen::Isometry3d& T) {
    Eigen::Map<Eigen::Quaterniond> q_map(q);
    q_map = Eigen::Quaterniond(T.rotation()).normalized();
    Eigen::Map<Vector3> t_map(t);
    t_map = T.translation();
  }
  Eigen::Isometry3d isometry() const {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::Map<const Eigen::Quaterniond>(q).normalized().toRotationMatrix();
    T.translation() = Eigen::Map<const Vector3>(t);
    return T;
  }
};

// Chi-square statistic of one observation at a pose; -1 when the point is not in front of the camera.
double chi2_of(const Intrinsics& k, const Observation& obs, const PoseBlocks& pose, const Vector3& p_world) {
  double r[3] = {0.0, 0.0, 0.0};
  const bool ok = is_stereo(obs)
                      ? evaluate_observation<3>(k, obs, pose.q, pose.t, p_world.data(), r, nullptr, nullptr, nullptr)
                      : evaluate_observation<2>(k, obs, pose.q, pose.t, p_world.data(), r, nullptr, nullptr, nullptr);
  return ok ? r[0] * r[0] + r[1] * r[1] + r[2] * r[2] : -1.0;
}

// Outlier when behind the camera or beyond the chi-square threshold of its dimension.
bool is_outlier(const OptimizerConfig& config, const Observation& obs, double chi2) {
  return chi2 < 0.0 || chi2 > (is_stereo(obs) ? config.chi2_stereo : config.chi2_mono);
}

// Huber with delta = sqrt(chi2 threshold): quadratic for inliers, linear beyond, as ORB-SLAM.
struct RobustKernels {
  ceres::HuberLoss mono;
  ceres::HuberLoss stereo;
  explicit RobustKernels(const OptimizerConfig& config)
      : mono(std::sqrt(config.chi2_mono)), stereo(std::sqrt(config.chi2_stereo)) {}
  ceres::LossFunction* pick(const Observation& obs, bool robust) {
    if (!robust) return nullptr;
    return is_stereo(obs) ? static_cast<ceres::LossFunction*>(&stereo) : &mono;
  }
};

// The problem borrows manifolds and losses (owned by the caller's frame), and owns the cost functions.
ceres::Problem::Options borrowing_problem_options() {
  ceres::Problem::Options options;
  options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  return options;
}

ceres::Solver::Options solver_options(const OptimizerConfig& config, ceres::LinearSolverType linear_solver) {
  ceres::Solver::Options options;
  options.linear_solver_type = linear_solver;
  options.max_num_iterations = config.iterations_per_round;
  options.num_threads = config.num_threads;
  options.logging_type = ceres::SILENT;
  options.minimizer_progress_to_stdout = false;
  // Tight enough that a noise-free problem converges to ~1e-9 and a noisy one to well below its noise;
  // the iteration cap bounds the time either way.
  options.function_tolerance = 1e-10;
  options.gradient_tolerance = 1e-14;
  options.parameter_tolerance = 1e-12;
  return options;
}

bool solve(const ceres::Solver::Options& options, ceres::Problem& problem) {
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  return summary.termination_type != ceres::FAILURE && summary.IsSolutionUsable();
}

int count_false(const std::vector<bool>& flags) {
  return static_cast<int>(std::count(flags.begin(), flags.end(), false));
}

// ---- pose-only ----------------------------------------------------------------------------------------

// One round: least squares over the current inliers, robust or not. False when the solve failed.
bool solve_pose_round(const Intrinsics& k, const std::vector<PoseObservation>& observations,
                      const std::vector<bool>& outlier, bool robust, const OptimizerConfig& config, PoseBlocks& pose) {
  std::vector<std::size_t> used;
  used.reserve(observations.size());
  for (std::size_t i = 0; i < observations.size(); ++i) {
    if (!outlier[i]) used.push_back(i);
  }
  ceres::EigenQuaternionManifold quaternion_manifold;
  ceres::Problem problem(borrowing_problem_options());
  problem.AddParameterBlock(pose.q, 4, &quaternion_manifold);
  problem.AddParameterBlock(pose.t, 3);
  problem.AddResidualBlock(new PoseBatchCost(k, observations, std::move(used), config, robust), nullptr, pose.q,
                           pose.t);
  // Six unknowns in a dense, tiny system: normal equations are cheapest and well conditioned enough.
  ceres::Solver::Options options = solver_options(config, ceres::DENSE_NORMAL_CHOLESKY);
  if (robust) options.max_num_iterations = config.pose_robust_iterations;
  return solve(options, problem);
}

// Classifies every observation (inliers of the last round and earlier outliers alike) at the pose.
void classify_pose_observations(const Intrinsics& k, const std::vector<PoseObservation>& observations,
                                const OptimizerConfig& config, const PoseBlocks& pose, std::vector<bool>& outlier) {
  for (std::size_t i = 0; i < observations.size(); ++i) {
    const PoseObservation& o = observations[i];
    outlier[i] = is_outlier(config, o.obs, chi2_of(k, o.obs, pose, o.p_world));
  }
}

// Points behind the initial pose cannot be projected: they sit out until a round brings them in front.
void exclude_points_behind(const Intrinsics& k, const std::vector<PoseObservation>& observations,
                           const PoseBlocks& pose, std::vector<bool>& outlier) {
  for (std::size_t i = 0; i < observations.size(); ++i) {
    outlier[i] = chi2_of(k, observations[i].obs, pose, observations[i].p_world) < 0.0;
  }
}

// ---- local bundle adjustment --------------------------------------------------------------------------

struct BaState {
  std::vector<PoseBlocks> poses;
  std::vector<Vector3> points;

  explicit BaState(const BaProblem& problem) : points(problem.points_world) {
    poses.reserve(problem.keyframes.size());
    for (const BaKeyframe& kf : problem.keyframes) poses.emplace_back(kf.T_cam_world);
  }
  double chi2(const Intrinsics& k, const BaObservation& o) const {
    return chi2_of(k, o.obs, poses[static_cast<std::size_t>(o.keyframe)], points[static_cast<std::size_t>(o.point)]);
  }
};

void check_ba_indices(const BaProblem& problem) {
  const int keyframes = static_cast<int>(problem.keyframes.size());
  const int points = static_cast<int>(problem.points_world.size());
  for (const BaObservation& o : problem.observations) {
    FLEETSLAM_CHECK(o.keyframe >= 0 && o.keyframe < keyframes, "BA observation names no keyframe");
    FLEETSLAM_CHECK(o.point >= 0 && o.point < points, "BA observation names no point");
  }
}

// Points first, then poses: SPARSE_SCHUR eliminates the points, leaving the small reduced camera system.
std::shared_ptr<ceres::ParameterBlockOrdering> schur_ordering(const ceres::Problem& problem, BaState& state) {
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  for (Vector3& p : state.points) {
    if (problem.HasParameterBlock(p.data())) ordering->AddElementToGroup(p.data(), 0);
  }
  for (PoseBlocks& pose : state.poses) {
    if (!problem.HasParameterBlock(pose.q)) continue;
    ordering->AddElementToGroup(pose.q, 1);
    ordering->AddElementToGroup(pose.t, 1);
  }
  return ordering;
}

ceres::Solver::Options ba_solver_options(const OptimizerConfig& config) {
  const bool sparse = ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE);
  ceres::Solver::Options options = solver_options(config, sparse ? ceres::SPARSE_SCHUR : ceres::DENSE_SCHUR);
  if (sparse) options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  return options;
}

// Adds one observation's residual; its keyframe's blocks get the quaternion manifold and are held
// constant for fixed keyframes.
void add_ba_residual(const Intrinsics& k, const BaProblem& input, const BaObservation& o, ceres::LossFunction* loss,
                     ceres::Manifold* quaternion_manifold, ceres::Problem& problem, BaState& state) {
  PoseBlocks& pose = state.poses[static_cast<std::size_t>(o.keyframe)];
  double* point = state.points[static_cast<std::size_t>(o.point)].data();
  ceres::CostFunction* cost =
      is_stereo(o.obs) ? static_cast<ceres::CostFunction*>(new BaCost<3>(k, o.obs)) : new BaCost<2>(k, o.obs);
  problem.AddParameterBlock(pose.q, 4, quaternion_manifold);
  problem.AddResidualBlock(cost, loss, pose.q, pose.t, point);
  if (input.keyframes[static_cast<std::size_t>(o.keyframe)].fixed) {
    problem.SetParameterBlockConstant(pose.q);
    problem.SetParameterBlockConstant(pose.t);
  }
}

bool solve_ba_pass(const Intrinsics& k, const BaProblem& input, const std::vector<bool>& outlier, bool robust,
                   const OptimizerConfig& config, BaState& state) {
  ceres::EigenQuaternionManifold quaternion_manifold;
  RobustKernels kernels(config);
  ceres::Problem problem(borrowing_problem_options());
  for (std::size_t i = 0; i < input.observations.size(); ++i) {
    if (outlier[i]) continue;
    const BaObservation& o = input.observations[i];
    add_ba_residual(k, input, o, kernels.pick(o.obs, robust), &quaternion_manifold, problem, state);
  }
  if (problem.NumResidualBlocks() == 0) return true;
  ceres::Solver::Options options = ba_solver_options(config);
  options.linear_solver_ordering = schur_ordering(problem, state);
  return solve(options, problem);
}

void classify_ba_observations(const Intrinsics& k, const BaProblem& input, const OptimizerConfig& config,
                              const BaState& state, std::vector<bool>& outlier) {
  for (std::size_t i = 0; i < input.observations.size(); ++i) {
    const BaObservation& o = input.observations[i];
    outlier[i] = is_outlier(config, o.obs, state.chi2(k, o));
  }
}

// Pixel RMS of |uv - projection| (left image) over the observations not flagged, at a state.
double reprojection_rms_px(const Intrinsics& k, const BaProblem& input, const std::vector<bool>& outlier,
                           const BaState& state) {
  double sum = 0.0;
  int count = 0;
  for (std::size_t i = 0; i < input.observations.size(); ++i) {
    if (outlier[i]) continue;
    const BaObservation& o = input.observations[i];
    Observation unweighted = o.obs;
    unweighted.inv_sigma2 = 1.0;
    unweighted.u_right.reset();
    const double squared = chi2_of(k, unweighted, state.poses[static_cast<std::size_t>(o.keyframe)],
                                   state.points[static_cast<std::size_t>(o.point)]);
    if (squared < 0.0) continue;  // behind the camera at this state: no pixel error to speak of
    sum += squared;
    ++count;
  }
  return count > 0 ? std::sqrt(sum / count) : 0.0;
}

bool has_fixed_keyframe(const BaProblem& problem) {
  return std::any_of(problem.keyframes.begin(), problem.keyframes.end(), [](const BaKeyframe& kf) { return kf.fixed; });
}

}  // namespace

PoseResult optimize_pose(const core::PinholeCamera& camera, double bf, const std::vector<PoseObservation>& observations,
                         const Eigen::Isometry3d& T_cam_world_initial, const OptimizerConfig& config) {
  PoseResult result;
  result.T_cam_world = T_cam_world_initial;
  result.outlier.assign(observations.size(), false);
  if (observations.size() < 3) return result;

  const Intrinsics k = intrinsics_of(camera, bf);
  PoseBlocks pose(T_cam_world_initial);
  std::vector<bool> outlier(observations.size(), false);
  exclude_points_behind(k, observations, pose, outlier);
  bool solved = true;
  for (int round = 0; round < config.rounds && solved; ++round) {
    if (count_false(outlier) < 3) break;  // too few left to fix six degrees of freedom
    // The last round is plain least squares on the inliers (with a single round, keep the kernel).
    const bool robust = round + 1 < config.rounds || config.rounds == 1;
    solved = solve_pose_round(k, observations, outlier, robust, config, pose);
    classify_pose_observations(k, observations, config, pose, outlier);
  }
  result.T_cam_world = pose.isometry();
  result.outlier = outlier;
  result.inliers = count_false(outlier);
  result.ok = solved && result.inliers >= 3;
  return result;
}

BaResult bundle_adjust(const core::PinholeCamera& camera, double bf, const BaProblem& problem,
                       const OptimizerConfig& config) {
  check_ba_indices(problem);
  BaResult result;
  for (const BaKeyframe& kf : problem.keyframes) result.T_cam_world.push_back(kf.T_cam_world);
  result.points_world = problem.points_world;
  result.outlier.assign(problem.observations.size(), false);
  if (!has_fixed_keyframe(problem) || problem.observations.empty()) return result;

  const Intrinsics k = intrinsics_of(camera, bf);
  const BaState initial(problem);
  BaState state(problem);
  std::vector<bool> outlier(problem.observations.size(), false);
  // Observations behind their camera at the start cannot be evaluated; leave them out of pass one.
  for (std::size_t i = 0; i < outlier.size(); ++i) outlier[i] = state.chi2(k, problem.observations[i]) < 0.0;
  bool solved = solve_ba_pass(k, problem, outlier, true, config, state);
  classify_ba_observations(k, problem, config, state, outlier);
  // Second pass without the kernel: outliers are gone, and plain least squares is the efficient estimate.
  if (solved) solved = solve_ba_pass(k, problem, outlier, false, config, state);
  classify_ba_observations(k, problem, config, state, outlier);

  for (std::size_t i = 0; i < state.poses.size(); ++i) {
    if (!problem.keyframes[i].fixed) result.T_cam_world[i] = state.poses[i].isometry();
  }
  result.points_world = state.points;
  result.outlier = outlier;
  result.initial_rms_px = reprojection_rms_px(k, problem, outlier, initial);
  result.final_rms_px = reprojection_rms_px(k, problem, outlier, state);
  result.ok = solved;
  return result;
}

std::vector<int> reprojection_inliers(const core::PinholeCamera& camera, const std::vector<PoseObservation>& observations,
                                      const Eigen::Isometry3d& T_cam_world, double chi2) {
  std::vector<int> inliers;
  for (std::size_t k = 0; k < observations.size(); ++k) {
    const std::optional<Eigen::Vector2d> uv = camera.project(T_cam_world * observations[k].p_world);
    if (uv && (*uv - observations[k].obs.uv).squaredNorm() * observations[k].obs.inv_sigma2 <= chi2) {
      inliers.push_back(static_cast<int>(k));
    }
  }
  return inliers;
}

}  // namespace fleetslam::slam
