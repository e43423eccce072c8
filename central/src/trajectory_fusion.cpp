#include "fleetslam/central/trajectory_fusion.hpp"

#include <algorithm>
#include <memory>

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include "fleetslam/core/error.hpp"

namespace fleetslam::central {

namespace {

// A node: world pose of a keyframe as quaternion (x, y, z, w: Eigen's storage) and translation.
struct Node {
  Eigen::Quaterniond q;
  Eigen::Vector3d t;
};

// Residual of a measured relative pose T_ab between nodes a and b:
//   e = [2 vec(q_meas^-1 * q_a^-1 q_b); R_meas^T (R_a^T (t_b - t_a) - t_meas)] weighted per axis.
struct RelativePoseCost {
  RelativePoseCost(const Eigen::Isometry3d& T_ab, double sigma_t, double sigma_r)
      : q_ab(T_ab.rotation()), t_ab(T_ab.translation()), w_t(1.0 / sigma_t), w_r(1.0 / sigma_r) {}

  template <typename T>
  bool operator()(const T* qa, const T* ta, const T* qb, const T* tb, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q_a(qa), q_b(qb);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_a(ta), t_b(tb);
    const Eigen::Quaternion<T> q_a_inv = q_a.conjugate();
    const Eigen::Quaternion<T> q_rel = q_a_inv * q_b;
    const Eigen::Matrix<T, 3, 1> t_rel = q_a_inv * (t_b - t_a);
    const Eigen::Quaternion<T> q_meas_inv = q_ab.conjugate().cast<T>();
    const Eigen::Quaternion<T> dq = q_meas_inv * q_rel;
    const Eigen::Matrix<T, 3, 1> dt = q_meas_inv * (t_rel - t_ab.cast<T>());
    for (int i = 0; i < 3; ++i) {
      r[i] = T(w_t) * dt[i];
      r[3 + i] = T(2.0 * w_r) * dq.vec()[i];
    }
    return true;
  }

  Eigen::Quaterniond q_ab;
  Eigen::Vector3d t_ab;
  double w_t, w_r;
};

// Residual of a node against an absolute world pose.
struct AbsolutePoseCost {
  AbsolutePoseCost(const Eigen::Isometry3d& T_world, double sigma_t, double sigma_r)
      : q(T_world.rotation()), t(T_world.translation()), w_t(1.0 / sigma_t), w_r(1.0 / sigma_r) {}

  template <typename T>
  bool operator()(const T* qn, const T* tn, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q_n(qn);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_n(tn);
    const Eigen::Quaternion<T> dq = q.conjugate().cast<T>() * q_n;
    for (int i = 0; i < 3; ++i) {
      r[i] = T(w_t) * (t_n[i] - T(t[i]));
      r[3 + i] = T(2.0 * w_r) * dq.vec()[i];
    }
    return true;
  }

  Eigen::Quaterniond q;
  Eigen::Vector3d t;
  double w_t, w_r;
};

core::Trajectory moved(const core::Trajectory& trajectory, const Eigen::Isometry3d& T) {
  core::Trajectory out = trajectory;
  for (core::StampedPose& p : out) p.T_world_body = T * p.T_world_body;
  return out;
}

}  // namespace

core::Trajectory follow_keyframes(const core::Trajectory& frames_robot, const core::Trajectory& keyframes_robot,
                                  const core::Trajectory& keyframes_world) {
  FLEETSLAM_CHECK(keyframes_robot.size() == keyframes_world.size(), "keyframe trajectories differ in length");
  if (keyframes_robot.empty()) return {};
  core::Trajectory out;
  out.reserve(frames_robot.size());
  for (const core::StampedPose& frame : frames_robot) {
    const auto after = std::upper_bound(keyframes_robot.begin(), keyframes_robot.end(), frame.t_ns,
                                        [](core::TimeNs t, const core::StampedPose& kf) { return t < kf.t_ns; });
    const std::size_t k = after == keyframes_robot.begin() ? 0 : static_cast<std::size_t>(after - keyframes_robot.begin()) - 1;
    const Eigen::Isometry3d T_kf_frame = keyframes_robot[k].T_world_body.inverse() * frame.T_world_body;
    out.push_back(core::StampedPose{frame.t_ns, keyframes_world[k].T_world_body * T_kf_frame});
  }
  return out;
}

TrajectoryFusion::TrajectoryFusion(const TrajectoryFusionConfig& config) : config_(config) {}

FusedTrajectory TrajectoryFusion::fuse(const core::Trajectory& keyframes_robot, const core::Trajectory& frames_robot,
                                       const Eigen::Isometry3d& T_world_robot_prior,
                                       const std::optional<InterRobotConstraint>& constraint) const {
  FusedTrajectory out;
  if (constraint) {
    for (std::size_t a : constraint->anchors) {
      if (a >= keyframes_robot.size()) {
        throw InputError("trajectory fusion", "anchor keyframe " + std::to_string(a) + " out of range (" +
                                                  std::to_string(keyframes_robot.size()) + " keyframes)");
      }
    }
  }
  const Eigen::Isometry3d T_rigid = constraint ? constraint->T_world_robot_refined : T_world_robot_prior;
  out.keyframes_world = moved(keyframes_robot, T_rigid);
  if (!constraint || !config_.pose_graph || keyframes_robot.size() < 2 || constraint->anchors.empty()) {
    out.frames_world = moved(frames_robot, T_rigid);
    return out;
  }

  // Nodes start at the rigid solution; the graph then trades the prior against the anchors.
  std::vector<Node> nodes;
  nodes.reserve(keyframes_robot.size());
  for (const core::StampedPose& kf : out.keyframes_world) {
    nodes.push_back(Node{Eigen::Quaterniond(kf.T_world_body.rotation()), kf.T_world_body.translation()});
  }
  ceres::Problem problem;
  ceres::Manifold* manifold = new ceres::EigenQuaternionManifold;  // owned by the problem
  for (Node& n : nodes) {
    problem.AddParameterBlock(n.q.coeffs().data(), 4, manifold);
    problem.AddParameterBlock(n.t.data(), 3);
  }
  for (std::size_t i = 1; i < nodes.size(); ++i) {
    const Eigen::Isometry3d T_ab = keyframes_robot[i - 1].T_world_body.inverse() * keyframes_robot[i].T_world_body;
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<RelativePoseCost, 6, 4, 3, 4, 3>(new RelativePoseCost(
                                 T_ab, config_.odometry_translation_sigma_m, config_.odometry_rotation_sigma_rad)),
                             nullptr, nodes[i - 1].q.coeffs().data(), nodes[i - 1].t.data(),
                             nodes[i].q.coeffs().data(), nodes[i].t.data());
  }
  const Eigen::Isometry3d prior0 = T_world_robot_prior * keyframes_robot.front().T_world_body;
  problem.AddResidualBlock(new ceres::AutoDiffCostFunction<AbsolutePoseCost, 6, 4, 3>(new AbsolutePoseCost(
                               prior0, config_.prior_translation_sigma_m, config_.prior_rotation_sigma_rad)),
                           nullptr, nodes.front().q.coeffs().data(), nodes.front().t.data());
  std::vector<std::size_t> anchors = constraint->anchors;
  std::sort(anchors.begin(), anchors.end());
  anchors.erase(std::unique(anchors.begin(), anchors.end()), anchors.end());
  for (std::size_t a : anchors) {
    const Eigen::Isometry3d target = constraint->T_world_robot_refined * keyframes_robot[a].T_world_body;
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<AbsolutePoseCost, 6, 4, 3>(new AbsolutePoseCost(
                                 target, config_.anchor_translation_sigma_m, config_.anchor_rotation_sigma_rad)),
                             nullptr, nodes[a].q.coeffs().data(), nodes[a].t.data());
  }
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  options.max_num_iterations = config_.max_iterations;
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  out.pose_graph_solved = summary.IsSolutionUsable();
  out.iterations = static_cast<int>(summary.iterations.size());
  out.initial_cost = summary.initial_cost;
  out.final_cost = summary.final_cost;
  if (!out.pose_graph_solved) {
    out.frames_world = moved(frames_robot, T_rigid);
    return out;
  }
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = nodes[i].q.normalized().toRotationMatrix();
    T.translation() = nodes[i].t;
    out.keyframes_world[i].T_world_body = T;
  }
  out.frames_world = follow_keyframes(frames_robot, keyframes_robot, out.keyframes_world);
  return out;
}

}  // namespace fleetslam::central
