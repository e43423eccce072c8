// Association, alignment, ATE and RPE (see trajectory_metrics.hpp for the definitions followed).

#include "fleetslam/core/trajectory_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <tuple>

#include <Eigen/SVD>

#include "fleetslam/core/error.hpp"

namespace fleetslam::core {
namespace {

// ---- association ----

struct Candidate {
  TimeNs difference_ns;
  std::size_t gt_index;
  std::size_t est_index;
};

// Every (gt, est) closer than max_difference; gt stamps increase, so a binary search bounds the window.
std::vector<Candidate> candidate_pairs(const Trajectory& gt, const Trajectory& est,
                                       const TimeAssociationConfig& config) {
  std::vector<Candidate> candidates;
  auto stamp_less = [](const StampedPose& pose, TimeNs t_ns) { return pose.t_ns < t_ns; };
  for (std::size_t e = 0; e < est.size(); ++e) {
    const TimeNs t_ns = saturating_add(est[e].t_ns, config.offset_ns);
    auto it = std::lower_bound(gt.begin(), gt.end(), saturating_add(t_ns, 1 - config.max_difference_ns), stamp_less);
    for (; it != gt.end() && it->t_ns < saturating_add(t_ns, config.max_difference_ns); ++it) {
      const TimeNs difference_ns = it->t_ns > t_ns ? it->t_ns - t_ns : t_ns - it->t_ns;
      candidates.push_back({difference_ns, static_cast<std::size_t>(it - gt.begin()), e});
    }
  }
  return candidates;
}

// ---- alignment ----

Eigen::Vector3d mean_of(const std::vector<Eigen::Vector3d>& points) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& p : points) sum += p;
  return sum / static_cast<double>(points.size());
}

// Below this ratio of the second to the first singular value of the cross-covariance, the points are
// taken as collinear: the rotation about their line is then not determined.
constexpr double kCollinearRatio = 1e-10;

// ---- statistics / RPE helpers ----

double rotation_angle(const Eigen::Matrix3d& R) {
  // atan2 of sin and cos stays accurate near 0 and pi, where acos((trace - 1) / 2) does not.
  const Eigen::Vector3d axis(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0), R(1, 0) - R(0, 1));
  return std::atan2(0.5 * axis.norm(), 0.5 * (R.trace() - 1.0));
}

Eigen::Isometry3d relative(const Eigen::Isometry3d& T_a, const Eigen::Isometry3d& T_b) {
  return T_a.inverse() * T_b;
}

// The index into `values` (non-decreasing) of the first j > k with values[j] - values[k] >= delta.
template <typename T>
std::size_t first_reaching(const std::vector<T>& values, std::size_t k, T delta) {
  const auto begin = values.begin() + static_cast<std::ptrdiff_t>(k) + 1;
  return static_cast<std::size_t>(std::lower_bound(begin, values.end(), values[k] + delta) - values.begin());
}

// For each pair k, the pair it is compared with (pairs.size() when none), and how many pairs found a
// partner only across a gap (left without one). A gap is a step between consecutive pairs' ground-truth
// stamps longer than twice the median step (evaluate_rpe.py's bound on ground-truth time differences):
// a drop-out of tracking or of the ground truth. In seconds, the partner must lie within that step of
// k's stamp + delta (no pose near it otherwise); in metres, no gap may lie between them (the distance
// travelled across a drop-out is unknown); in frames, the estimate's own pose delta later must be paired.
std::vector<std::size_t> rpe_partners(const Trajectory& gt, const std::vector<PosePair>& pairs,
                                      const RpeConfig& config, std::size_t& across_gaps) {
  const std::size_t n = pairs.size();
  std::vector<std::size_t> partner(n, n);
  across_gaps = 0;
  if (n < 2) return partner;
  std::vector<TimeNs> stamps(n);
  for (std::size_t k = 0; k < n; ++k) stamps[k] = gt[pairs[k].gt_index].t_ns;
  std::vector<TimeNs> steps(n - 1);
  for (std::size_t k = 0; k + 1 < n; ++k) steps[k] = stamps[k + 1] - stamps[k];
  std::vector<TimeNs> sorted = steps;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
  const TimeNs max_step = 2 * sorted[sorted.size() / 2];
  std::vector<std::size_t> gaps_before(n, 0);  // steps longer than max_step among the first k
  for (std::size_t k = 1; k < n; ++k) gaps_before[k] = gaps_before[k - 1] + (steps[k - 1] > max_step ? 1 : 0);
  const TimeNs delta_ns = config.unit == RpeUnit::kSeconds ? seconds_to_ns(config.delta) : 0;

  if (config.unit == RpeUnit::kFrames) {
    // The estimate's own frame delta later, when it is paired too (evaluate_rpe.py steps through the
    // estimate's frames): a frame that is not paired is never replaced by a later one.
    const auto step = static_cast<std::size_t>(config.delta);
    std::vector<std::size_t> pair_of_est;  // est index -> pair (n: none)
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t e = pairs[k].est_index;
      if (pair_of_est.size() <= e) pair_of_est.resize(e + 1, n);
      pair_of_est[e] = k;
    }
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t e = pairs[k].est_index + step;
      if (e < pair_of_est.size()) partner[k] = pair_of_est[e];
    }
  } else if (config.unit == RpeUnit::kSeconds) {
    for (std::size_t k = 0; k < n; ++k) partner[k] = first_reaching(stamps, k, delta_ns);
  } else {
    std::vector<double> travelled(n, 0.0);
    for (std::size_t k = 1; k < n; ++k) {
      travelled[k] = travelled[k - 1] + (gt[pairs[k].gt_index].T_world_body.translation() -
                                         gt[pairs[k - 1].gt_index].T_world_body.translation())
                                            .norm();
    }
    for (std::size_t k = 0; k < n; ++k) partner[k] = first_reaching(travelled, k, config.delta);
  }
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t j = partner[k];
    if (j >= n || j <= k) continue;
    const bool across =
        config.unit == RpeUnit::kSeconds ? stamps[j] - stamps[k] - delta_ns > max_step
        : config.unit == RpeUnit::kMeters ? gaps_before[j] != gaps_before[k]
                                          : false;
    if (across) {
      partner[k] = n;
      ++across_gaps;
    }
  }
  return partner;
}

}  // namespace

// ---- association ---------------------------------------------------------------------------------

std::vector<PosePair> associate_by_time(const Trajectory& gt, const Trajectory& est,
                                        const TimeAssociationConfig& config) {
  std::vector<Candidate> candidates = candidate_pairs(gt, est, config);
  // Stamps increase with the index, so (difference, gt index, est index) orders as associate.py's
  // (difference, t_gt, t_est) tuples do.
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    return std::tie(a.difference_ns, a.gt_index, a.est_index) < std::tie(b.difference_ns, b.gt_index, b.est_index);
  });
  std::vector<bool> gt_used(gt.size(), false);
  std::vector<bool> est_used(est.size(), false);
  std::vector<PosePair> pairs;
  for (const Candidate& c : candidates) {
    if (gt_used[c.gt_index] || est_used[c.est_index]) continue;
    gt_used[c.gt_index] = est_used[c.est_index] = true;
    pairs.push_back({c.gt_index, c.est_index});
  }
  std::sort(pairs.begin(), pairs.end(), [](const PosePair& a, const PosePair& b) { return a.gt_index < b.gt_index; });
  return pairs;
}

std::vector<PosePair> associate_by_index(const Trajectory& gt, const Trajectory& est) {
  std::vector<PosePair> pairs(std::min(gt.size(), est.size()));
  for (std::size_t i = 0; i < pairs.size(); ++i) pairs[i] = {i, i};
  return pairs;
}

// ---- alignment -----------------------------------------------------------------------------------

std::string to_string(AlignmentMode mode) {
  switch (mode) {
    case AlignmentMode::kNone: return "none";
    case AlignmentMode::kSe3: return "se3";
    case AlignmentMode::kSim3: return "sim3";
  }
  return "unknown";
}

std::optional<AlignmentMode> alignment_mode_from_string(const std::string& name) {
  for (auto mode : {AlignmentMode::kNone, AlignmentMode::kSe3, AlignmentMode::kSim3}) {
    if (name == to_string(mode)) return mode;
  }
  return std::nullopt;
}

std::string to_string(AlignmentStatus status) {
  switch (status) {
    case AlignmentStatus::kOk: return "ok";
    case AlignmentStatus::kTooFewPairs: return "too few pairs (alignment needs at least 3)";
    case AlignmentStatus::kDegenerate: return "degenerate (estimate or ground-truth positions are collinear)";
  }
  return "unknown";
}

Eigen::Vector3d Alignment::apply(const Eigen::Vector3d& p_est) const {
  return scale * (T_gt_est.linear() * p_est) + T_gt_est.translation();
}

Eigen::Isometry3d Alignment::apply(const Eigen::Isometry3d& T_est_body) const {
  Eigen::Isometry3d T_gt_body = Eigen::Isometry3d::Identity();
  T_gt_body.linear() = T_gt_est.linear() * T_est_body.linear();
  T_gt_body.translation() = apply(Eigen::Vector3d(T_est_body.translation()));
  return T_gt_body;
}

Alignment align_positions(const std::vector<Eigen::Vector3d>& est, const std::vector<Eigen::Vector3d>& gt,
                          AlignmentMode mode) {
  FLEETSLAM_CHECK(est.size() == gt.size(), "align_positions needs as many estimate as ground-truth points");
  Alignment result;
  result.mode = mode;
  if (mode == AlignmentMode::kNone) return result;
  if (est.size() < 3) {
    result.status = AlignmentStatus::kTooFewPairs;
    return result;
  }
  // Umeyama (1991), eqs. 38-42: SVD of the cross-covariance of the centred point sets.
  const Eigen::Vector3d mu_est = mean_of(est);
  const Eigen::Vector3d mu_gt = mean_of(gt);
  Eigen::Matrix3d sigma = Eigen::Matrix3d::Zero();
  double variance_est = 0.0;
  for (std::size_t i = 0; i < est.size(); ++i) {
    sigma += (gt[i] - mu_gt) * (est[i] - mu_est).transpose();
    variance_est += (est[i] - mu_est).squaredNorm();
  }
  const auto n = static_cast<double>(est.size());
  sigma /= n;
  variance_est /= n;
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(sigma, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Vector3d s = Eigen::Vector3d::Ones();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0) s(2) = -1.0;  // no reflection
  const Eigen::Matrix3d R = svd.matrixU() * s.asDiagonal() * svd.matrixV().transpose();
  const Eigen::Vector3d d = svd.singularValues();
  if (!(d(1) > kCollinearRatio * d(0))) result.status = AlignmentStatus::kDegenerate;
  if (mode == AlignmentMode::kSim3 && variance_est > 0.0) result.scale = d.dot(s) / variance_est;
  result.T_gt_est.linear() = R;
  result.T_gt_est.translation() = mu_gt - result.scale * R * mu_est;
  return result;
}

Trajectory apply_alignment(const Alignment& alignment, const Trajectory& est) {
  Trajectory aligned = est;
  for (StampedPose& pose : aligned) pose.T_world_body = alignment.apply(pose.T_world_body);
  return aligned;
}

// ---- statistics ----------------------------------------------------------------------------------

ErrorStats compute_stats(const std::vector<double>& values) {
  ErrorStats stats;
  stats.count = values.size();
  if (values.empty()) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    stats.rmse = stats.mean = stats.median = stats.std = stats.min = stats.max = nan;
    return stats;
  }
  const auto n = static_cast<double>(values.size());
  double sum = 0.0;
  double sum_squares = 0.0;
  for (double v : values) {
    sum += v;
    sum_squares += v * v;
  }
  stats.rmse = std::sqrt(sum_squares / n);
  stats.mean = sum / n;
  double deviation = 0.0;  // two passes, as numpy.std
  for (double v : values) deviation += (v - stats.mean) * (v - stats.mean);
  stats.std = std::sqrt(deviation / n);
  std::vector<double> sorted = values;
  std::sort(sorted.begin(), sorted.end());
  const std::size_t mid = sorted.size() / 2;
  stats.median = sorted.size() % 2 == 1 ? sorted[mid] : 0.5 * (sorted[mid - 1] + sorted[mid]);
  stats.min = sorted.front();
  stats.max = sorted.back();
  return stats;
}

// ---- absolute trajectory error -------------------------------------------------------------------

AteResult compute_ate(const Trajectory& gt, const Trajectory& est, const std::vector<PosePair>& pairs,
                      AlignmentMode mode) {
  AteResult result;
  result.pairs = pairs;
  std::vector<Eigen::Vector3d> p_est;
  std::vector<Eigen::Vector3d> p_gt;
  for (const PosePair& pair : pairs) {
    FLEETSLAM_CHECK(pair.gt_index < gt.size() && pair.est_index < est.size(), "pair index out of range");
    p_est.push_back(est[pair.est_index].T_world_body.translation());
    p_gt.push_back(gt[pair.gt_index].T_world_body.translation());
    result.t_ns.push_back(gt[pair.gt_index].t_ns);
  }
  result.alignment = align_positions(p_est, p_gt, mode);
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    result.errors_m.push_back((p_gt[i] - result.alignment.apply(p_est[i])).norm());
  }
  result.stats = compute_stats(result.errors_m);
  return result;
}

// ---- relative pose error -------------------------------------------------------------------------

std::string to_string(RpeUnit unit) {
  switch (unit) {
    case RpeUnit::kFrames: return "frames";
    case RpeUnit::kMeters: return "m";
    case RpeUnit::kSeconds: return "s";
  }
  return "unknown";
}

std::optional<RpeUnit> rpe_unit_from_string(const std::string& name) {
  for (auto unit : {RpeUnit::kFrames, RpeUnit::kMeters, RpeUnit::kSeconds}) {
    if (name == to_string(unit)) return unit;
  }
  return std::nullopt;
}

RpeResult compute_rpe(const Trajectory& gt, const Trajectory& est, const std::vector<PosePair>& pairs,
                      const RpeConfig& config, double est_scale) {
  FLEETSLAM_CHECK(config.delta > 0.0 && std::isfinite(config.delta), "RPE delta must be positive");
  FLEETSLAM_CHECK(config.unit != RpeUnit::kFrames || std::floor(config.delta) == config.delta,
                  "an RPE frame delta must be an integer");
  RpeResult result;
  result.config = config;
  const std::vector<std::size_t> partner = rpe_partners(gt, pairs, config, result.skipped_across_gaps);
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const std::size_t j = partner[k];
    if (j >= pairs.size()) continue;
    const Eigen::Isometry3d Q = relative(gt[pairs[k].gt_index].T_world_body, gt[pairs[j].gt_index].T_world_body);
    Eigen::Isometry3d P = relative(est[pairs[k].est_index].T_world_body, est[pairs[j].est_index].T_world_body);
    P.translation() *= est_scale;
    // evaluate_rpe.py's order, ominus(ominus(P_j, P_i), ominus(Q_j, Q_i)) = P Q^-1 (same angle as Sturm et
    // al.'s Q^-1 P, translation up to a rotation of the gt step: the tool's numbers are the ones compared).
    const Eigen::Isometry3d E = P * Q.inverse();
    result.from_pair.push_back(k);
    result.to_pair.push_back(j);
    result.t_ns.push_back(gt[pairs[k].gt_index].t_ns);
    result.translation_errors_m.push_back(E.translation().norm());
    result.rotation_errors_rad.push_back(rotation_angle(E.linear()));
  }
  result.translation_m = compute_stats(result.translation_errors_m);
  result.rotation_rad = compute_stats(result.rotation_errors_rad);
  return result;
}

}  // namespace fleetslam::core
