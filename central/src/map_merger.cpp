#include "fleetslam/central/map_merger.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <set>
#include <string>

#include <spdlog/fmt/fmt.h>
#include <spdlog/logger.h>

#include "fleetslam/central/kdtree.hpp"
#include "fleetslam/core/error.hpp"
#include "normal_test.hpp"
#include "voxel_hash.hpp"

namespace fleetslam::central {
namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

bool is_rigid(const Eigen::Isometry3d& T) {
  if (!T.matrix().allFinite()) return false;
  const Eigen::Matrix3d R = T.linear();
  return (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-6 && R.determinant() > 0.0;
}

}  // namespace

namespace detail {

// Which robot each point of the merged cloud came from: robot i owns [begin, end).
struct MergedOwner {
  std::size_t robot;  // position in the input
  std::size_t begin;
  std::size_t end;
};

// Merging state: the merged cloud and who owns which part.
struct MergedCloud {
  core::PointCloud cloud;
  std::vector<MergedOwner> owners;

  void add(std::size_t robot, const core::PointCloud& cloud_world) {
    owners.push_back(MergedOwner{robot, cloud.size(), cloud.size() + cloud_world.size()});
    cloud.append(cloud_world);
  }
};

}  // namespace detail

namespace {

using detail::MergedCloud;
using detail::MergedOwner;

// Mutual pairs per robot already merged (the A side of the overlap is the merged cloud).
std::vector<std::pair<int, std::size_t>> pairs_per_robot(const Overlap& overlap, const MergedCloud& merged,
                                                         const std::vector<RobotCloud>& robots) {
  std::vector<std::pair<int, std::size_t>> counts;
  for (const MergedOwner& owner : merged.owners) {
    const auto first = std::lower_bound(overlap.indices_a.begin(), overlap.indices_a.end(), owner.begin);
    const auto last = std::lower_bound(overlap.indices_a.begin(), overlap.indices_a.end(), owner.end);
    counts.emplace_back(robots[owner.robot].robot_id, static_cast<std::size_t>(last - first));
  }
  return counts;
}

constexpr double kDegreesPerRadian = 57.29577951308232;

double rotation_deg(const Eigen::Isometry3d& T) { return Eigen::AngleAxisd(T.linear()).angle() * kDegreesPerRadian; }

std::string describe(double shift_m, double angle_deg) { return fmt::format("{:.1f} mm, {:.3f} deg", shift_m * 1e3, angle_deg); }

std::string describe(const Eigen::Isometry3d& T) { return describe(T.translation().norm(), rotation_deg(T)); }

// Why a robot was placed by its prior or left out without matching: what its last overlap was.
std::string without_overlap(const RobotMergeReport& report) {
  const std::string pairs = std::to_string(report.overlap_points) + " pairs";
  if (report.overlap_points == 0) return "no overlap";
  return report.no_common_surface ? "no common surface on " + pairs : "overlap too small (" + pairs + ")";
}

}  // namespace

MapMerger::MapMerger(const Config& config, core::Logger logger)
    : config_((core::check_config(config, "merge"), config)),
      overlap_(config.coarse),
      registration_(config.registration),
      local_registration_(config.local_registration),
      sampler_(config.sampling),
      filter_(config.filter),
      logger_(logger ? std::move(logger) : core::null_logger()) {}

namespace detail {

// One hypothesis of fine matching (see the header), from the cloud at its prior placement.
struct Refinement {
  Eigen::Isometry3d correction = Eigen::Isometry3d::Identity();  // world frame, on the prior placement
  RegistrationResult registration;  // the last applied round's, or the failed first round's
  int rounds = 0;                   // rounds applied; 0: the first failed
  std::size_t refined_overlap_points = 0;
  std::string failure;              // why the first round failed
  double consistency = -1.0;
};

// One GICP round of a hypothesis: on the coarse overlap sets or on the overlap regions about the pose so far.
struct Round {
  const GicpRegistration* registration = nullptr;
  bool on_regions = false;
};

}  // namespace detail

namespace {

// How well `correction` fits the robot's cloud to the merged one: the share of `source` points
// (at most kMaxConsistencyPoints, evenly spread over the set) within distance_m of a target point whose
// normal agrees within the angle, taken per surface orientation (the world axis the point's normal is
// nearest to; points without a normal count with the vertical ones) and averaged over the orientations
// that hold at least kMinOrientationShare of the points. The floor is most of an indoor overlap and stays
// consistent under a wrong yaw or a shift along it: alone it would decide.
constexpr std::size_t kMaxConsistencyPoints = 10000;
constexpr double kMinOrientationShare = 0.05;

double consistency(const core::PointCloud& source, const core::PointCloud& target, const KdTree& target_tree,
                   const Eigen::Isometry3d& correction, double distance_m, double max_normal_angle_deg) {
  if (source.empty() || target.empty()) return 0.0;
  const float min_cos = detail::min_normal_cos(max_normal_angle_deg);
  const bool use_normals = source.has_normals() && target.has_normals();
  const Eigen::Matrix3f R = correction.linear().cast<float>();
  const Eigen::Vector3f t = correction.translation().cast<float>();
  const std::size_t stride = (source.size() + kMaxConsistencyPoints - 1) / kMaxConsistencyPoints;
  std::array<std::size_t, 3> tested{};
  std::array<std::size_t, 3> consistent{};
  for (std::size_t i = 0; i < source.size(); i += stride) {
    const Eigen::Vector3f normal = use_normals ? Eigen::Vector3f(R * source.normals[i]) : Eigen::Vector3f::Zero();
    int axis = 2;
    if (!normal.isZero()) normal.cwiseAbs().maxCoeff(&axis);
    ++tested[static_cast<std::size_t>(axis)];
    const Neighbour n = target_tree.nearest(R * source.points[i] + t, static_cast<float>(distance_m));
    if (!n.found()) continue;
    if (use_normals && !detail::normals_agree(normal, target.normals[n.index], min_cos)) continue;
    ++consistent[static_cast<std::size_t>(axis)];
  }
  const std::size_t total = tested[0] + tested[1] + tested[2];
  double sum = 0.0;
  int orientations = 0;
  for (std::size_t axis = 0; axis < 3; ++axis) {
    if (tested[axis] == 0 || static_cast<double>(tested[axis]) < kMinOrientationShare * static_cast<double>(total)) continue;
    sum += static_cast<double>(consistent[axis]) / static_cast<double>(tested[axis]);
    ++orientations;
  }
  return orientations > 0 ? sum / orientations : 0.0;
}

}  // namespace

// The rounds of one hypothesis, each GICP from the correction so far: on the coarse overlap sets, or (
// on_regions) on the overlap regions chosen again about the refined pose. A round that fails ends the
// hypothesis with the last good correction; when the first fails, the hypothesis has none.
detail::Refinement MapMerger::refine(const std::vector<detail::Round>& rounds, const char* hypothesis, int robot_id,
                                     const Overlap& coarse, const core::PointCloud& merged,
                                     const core::PointCloud& cloud_world, const Eigen::Vector3d& centroid_prior,
                                     MergeTimings& timings) const {
  detail::Refinement out;
  core::PointCloud moved;  // the cloud by the correction so far (from the second round on)
  for (int round = 1; round <= static_cast<int>(rounds.size()); ++round) {
    const detail::Round& step = rounds[static_cast<std::size_t>(round - 1)];
    const GicpRegistration& registration = *step.registration;
    const core::PointCloud& current = round == 1 ? cloud_world : moved;
    OverlapRegions sets{coarse.indices_a, coarse.indices_b};
    if (step.on_regions) {
      const Clock::time_point stage = Clock::now();
      sets = overlap_regions(merged, current, config_.refine_radius_m);
      timings.coarse_ms += ms_since(stage);
      const std::size_t smaller = std::min(sets.indices_a.size(), sets.indices_b.size());
      if (smaller < static_cast<std::size_t>(config_.min_overlap_points)) break;
    }
    const Clock::time_point stage = Clock::now();
    const RegistrationResult r =
        registration.align(select_points(current, sets.indices_b), select_points(merged, sets.indices_a));
    timings.registration_ms += ms_since(stage);
    // How far the result would move the cloud from where its prior put it: its centroid, and the rotation.
    const Eigen::Isometry3d from_prior = r.T_target_source * out.correction;
    const double shift_m = (from_prior * centroid_prior - centroid_prior).norm();
    const double correction_deg = rotation_deg(from_prior);
    const bool within = shift_m <= config_.max_correction_m && correction_deg <= config_.max_correction_deg;
    const bool usable =
        (r.converged || r.status == "max iterations") && r.inlier_ratio >= config_.min_inlier_ratio && within;
    logger_->info("merge: robot {}: {} round {}: GICP {} after {} iterations on {}/{} points (overlap sets {}/{}), "
                  "fitness {:.3g} m^2, inliers {:.2f}, correction {}",
                  robot_id, hypothesis, round, r.status, r.iterations, r.source_points, r.target_points,
                  sets.indices_b.size(), sets.indices_a.size(), r.fitness_m2, r.inlier_ratio, describe(r.T_target_source));
    if (!usable) {
      const std::string why = within ? r.status + ", inlier ratio " + std::to_string(r.inlier_ratio)
                                     : describe(shift_m, correction_deg) + " from the prior, beyond the limits";
      if (round == 1) {
        out.registration = r;
        out.failure = why;
      } else {
        logger_->warn("merge: robot {}: {} round {} discarded ({})", robot_id, hypothesis, round, why);
      }
      break;
    }
    out.correction = from_prior;
    out.registration = r;
    out.rounds = round;
    out.refined_overlap_points = sets.indices_b.size();
    if (round < static_cast<int>(rounds.size())) moved = core::transformed(cloud_world, out.correction);
  }
  return out;
}

// Fine matching (see the header): the wide and the local hypothesis, the more consistent one applied unless
// the prior is about as consistent. When neither has a usable first round, the prior stands. False (no
// common surface) when neither the prior nor a hypothesis fits min_consistency of the cloud.
bool MapMerger::fine_match(RobotMergeReport& report, const Overlap& coarse, const core::PointCloud& merged,
                           core::PointCloud& cloud_world, MergeTimings& timings) const {
  // The cloud's centroid where the prior puts it (fine matching starts from the prior).
  Eigen::Vector3d centroid_prior = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3f& p : cloud_world.points) centroid_prior += p.cast<double>();
  if (!cloud_world.empty()) centroid_prior /= static_cast<double>(cloud_world.size());

  // Wide: the paper's GICP on the coarse sets, then refinement_rounds - 1 rounds on the overlap regions.
  // Local: one round of the local registration on the coarse sets.
  std::vector<detail::Round> wide_rounds{{&registration_, false}};
  for (int round = 2; round <= config_.refinement_rounds; ++round) wide_rounds.push_back({&registration_, true});
  detail::Refinement wide = refine(wide_rounds, "wide", report.robot_id, coarse, merged, cloud_world, centroid_prior, timings);
  if (!config_.local_hypothesis) {  // the paper's fine matching, unweighed
    apply(wide, "wide", /*move=*/true, report, cloud_world);
    return true;
  }
  detail::Refinement local = refine({{&local_registration_, false}}, "local", report.robot_id, coarse, merged,
                                    cloud_world, centroid_prior, timings);
  // Both scored on the robot's whole cloud against the whole merged cloud: the coarse sets were chosen
  // under the prior, and scored on them the prior looks better than the truth (seen with the office's
  // 10 cm + 5 degree prior error: 0.49 at the prior, 0.35 at the wide result 9 mm from the truth).
  const Clock::time_point stage = Clock::now();
  const KdTree merged_tree(merged.points);
  const auto score = [&](const Eigen::Isometry3d& correction) {
    return consistency(cloud_world, merged, merged_tree, correction, config_.consistency_distance_m,
                       config_.local_registration.max_normal_angle_deg);
  };
  for (detail::Refinement* h : {&wide, &local}) {
    if (h->rounds > 0) h->consistency = score(h->correction);
  }
  const double at_prior = score(Eigen::Isometry3d::Identity());
  timings.registration_ms += ms_since(stage);
  report.consistency_wide = wide.consistency;
  report.consistency_local = local.consistency;
  // Ties go to the local hypothesis: the prior, polished.
  const bool use_local = local.rounds > 0 && local.consistency >= wide.consistency;
  const detail::Refinement& chosen = use_local ? local : wide;
  report.no_common_surface = chosen.rounds > 0 && std::max(chosen.consistency, at_prior) < config_.min_consistency;
  if (report.no_common_surface) {
    report.registration = chosen.registration;
    logger_->warn("merge: robot {}: {} coarse pairs but no common surface (consistency prior {:.4f}, wide {:.4f}, "
                  "local {:.4f}, below {:.4f}): as without overlap",
                  report.robot_id, coarse.size(), at_prior, wide.consistency, local.consistency, config_.min_consistency);
    return false;
  }
  // A correction that does not fit the cloud clearly better than the prior leaves the prior (the overlap
  // confirmed it), as does one that fits almost none of it (the overlap was no common surface).
  const bool keep_prior = !(chosen.consistency >= config_.min_consistency &&
                            chosen.consistency > at_prior * (1.0 + config_.min_consistency_gain));
  const char* applied = keep_prior ? "prior" : use_local ? "local" : "wide";
  if (chosen.rounds > 0) {
    logger_->info("merge: robot {}: {} hypothesis applied (consistency within {:.0f} mm: prior {:.4f}, wide {:.4f}, "
                  "local {:.4f}), correction {}",
                  report.robot_id, applied, config_.consistency_distance_m * 1e3, at_prior, wide.consistency,
                  local.consistency, keep_prior ? describe(Eigen::Isometry3d::Identity()) : describe(chosen.correction));
  }
  apply(chosen, applied, !keep_prior, report, cloud_world);  // with no usable round, chosen is wide
  return true;
}

// The outcome of fine matching: a hypothesis without a usable first round leaves the prior (status
// "registration discarded"); otherwise the robot is fine matched, and with `move` its cloud and placement
// take the hypothesis's correction (without, the prior is confirmed and stays).
void MapMerger::apply(const detail::Refinement& chosen, const char* hypothesis, bool move, RobotMergeReport& report,
                      core::PointCloud& cloud_world) const {
  report.registration = chosen.registration;
  if (chosen.rounds == 0) {
    report.status = "registration discarded (" + chosen.failure + "): prior kept";
    logger_->warn("merge: robot {}: {}", report.robot_id, report.status);
    return;
  }
  report.hypothesis = hypothesis;
  report.fine_matched = true;
  report.status = "fine matched";
  if (!move) return;
  core::transform_in_place(cloud_world, chosen.correction);
  report.T_world_robot = chosen.correction * report.T_world_robot;
  report.refinement_rounds = chosen.rounds;
  report.refined_overlap_points = chosen.refined_overlap_points;
}

double MapMerger::voxel_reach_m() const {
  double smallest_m = std::min({config_.coarse.coarse_radius_m, config_.refine_radius_m, config_.sampling.voxel_size_m,
                                config_.filter.radius_m});
  for (const RegistrationConfig* r : {&config_.registration, &config_.local_registration}) {
    if (r->voxel_size_m > 0.0) smallest_m = std::min(smallest_m, r->voxel_size_m);
  }
  return (detail::kMaxVoxelCoordinate - 1) * smallest_m;  // a voxel of margin for the +-1 neighbours
}

// Each robot's finite points in the world by its prior; the robots that can be merged, in input order.
std::vector<std::size_t> MapMerger::place_by_priors(const std::vector<RobotCloud>& robots, MergeResult& result,
                                                    std::vector<core::PointCloud>& clouds_world) const {
  std::vector<std::size_t> usable;
  for (std::size_t i = 0; i < robots.size(); ++i) {
    RobotMergeReport& report = result.robots[i];
    report.robot_id = robots[i].robot_id;
    report.T_world_robot_prior = robots[i].T_world_robot_prior;
    report.T_world_robot = robots[i].T_world_robot_prior;
    const bool bad_after = robots[i].T_after_robot.has_value() && !is_rigid(*robots[i].T_after_robot);
    if (!is_rigid(robots[i].T_world_robot_prior) || bad_after) {
      report.status = std::string("bad prior (") + (bad_after ? "T_after_robot" : "T_world_robot_prior") +
                      " not a finite rigid transform): left out";
      logger_->error("merge: robot {}: {}", report.robot_id, report.status);
      continue;
    }
    clouds_world[i] = core::transformed(robots[i].cloud_robot, robots[i].T_world_robot_prior);
    report.non_finite_removed = core::remove_non_finite(clouds_world[i]);
    report.points = clouds_world[i].size();
    // The voxel grids (overlap, sampling, filtering) index +-2^20 voxels around the world origin: a cloud
    // reaching beyond would be folded into the border voxels without a word.
    float farthest_m = 0.0f;
    for (const Eigen::Vector3f& p : clouds_world[i].points) farthest_m = std::max(farthest_m, p.cwiseAbs().maxCoeff());
    if (static_cast<double>(farthest_m) > voxel_reach_m()) {
      report.status = fmt::format("too far from the world origin ({:.0f} m on an axis; the voxel grids reach {:.0f} m "
                                  "with these voxel sizes: use a world frame near the robots): left out",
                                  farthest_m, voxel_reach_m());
      logger_->error("merge: robot {}: {}", report.robot_id, report.status);
      clouds_world[i] = core::PointCloud();
      continue;
    }
    if (report.non_finite_removed > 0) {
      logger_->warn("merge: robot {}: {} non-finite points removed", report.robot_id, report.non_finite_removed);
    }
    if (clouds_world[i].empty()) {
      report.status = "empty cloud: nothing to merge";
      logger_->warn("merge: robot {}: {}", report.robot_id, report.status);
    }
    usable.push_back(i);
  }
  return usable;
}

// Coarse matching of robot i against the merged cloud, then fine matching when the overlap is large
// enough. False when the robot has to wait for the merged cloud to grow.
bool MapMerger::match(std::size_t i, const std::vector<RobotCloud>& robots, const MergedCloud& merged,
                      core::PointCloud& cloud_world, MergeResult& result) const {
  RobotMergeReport& report = result.robots[i];
  const Clock::time_point stage = Clock::now();
  const Overlap overlap = overlap_.find(merged.cloud, cloud_world);
  result.timings.coarse_ms += ms_since(stage);
  report.overlap_points = overlap.size();
  report.no_common_surface = false;  // until fine matching finds so
  report.overlap_mean_distance_m = overlap.mean_distance_m;
  report.overlap_normal_rejected = overlap.normal_rejected;
  report.overlap_with = pairs_per_robot(overlap, merged, robots);
  logger_->info("merge: robot {}: coarse overlap {} pairs (mean distance {:.3f} m, {} left out for opposite normals) "
                "with {} merged points",
                report.robot_id, overlap.size(), overlap.mean_distance_m, overlap.normal_rejected, merged.cloud.size());
  if (overlap.size() < static_cast<std::size_t>(config_.min_overlap_points)) return false;
  if (config_.registration.enabled) {
    if (!fine_match(report, overlap, merged.cloud, cloud_world, result.timings)) return false;
  } else {
    report.status = "coarse only (registration disabled)";
  }
  return true;
}

MergeResult MapMerger::merge(const std::vector<RobotCloud>& robots) const {
  const Clock::time_point start = Clock::now();
  std::set<int> ids;
  for (const RobotCloud& robot : robots) {
    if (!ids.insert(robot.robot_id).second) {
      throw InputError("merge", "robot id " + std::to_string(robot.robot_id) + " appears twice");
    }
  }
  MergeResult result;
  result.robots.resize(robots.size());
  std::vector<core::PointCloud> clouds_world(robots.size());
  std::vector<std::size_t> pending = place_by_priors(robots, result, clouds_world);

  MergedCloud merged;
  std::vector<std::size_t> tried_at(robots.size(), static_cast<std::size_t>(-1));  // merged size at last try
  // A waiting cloud that continues robot i (after_id, T_after_robot) starts from i's placement.
  const auto carry_over = [&](std::size_t i) {
    const RobotMergeReport& placed = result.robots[i];
    for (const std::size_t k : pending) {
      if (k == i || robots[k].after_id != placed.robot_id || !robots[k].T_after_robot) continue;
      RobotMergeReport& report = result.robots[k];
      const Eigen::Isometry3d prior = placed.T_world_robot * *robots[k].T_after_robot;
      core::transform_in_place(clouds_world[k], prior * report.T_world_robot.inverse());
      report.T_world_robot_prior = prior;
      report.T_world_robot = prior;
      tried_at[k] = static_cast<std::size_t>(-1);
      logger_->info("merge: robot {}: prior follows robot {}'s placement", report.robot_id, placed.robot_id);
    }
  };
  const auto place = [&](std::size_t i, const std::string& status) {
    RobotMergeReport& report = result.robots[i];
    report.placed = true;
    if (report.status.empty()) report.status = status;
    merged.add(i, clouds_world[i]);
    logger_->info("merge: robot {}: {} ({} points)", report.robot_id, report.status, report.points);
    carry_over(i);
  };
  // The reference: robots[0], or the first usable robot when robots[0]'s prior is not.
  if (!pending.empty()) {
    place(pending.front(), "reference");
    pending.erase(pending.begin());
  }
  // Coarse-to-fine matching against the merged cloud so far; see the header for the order.
  bool in_order = true;  // later components wait for the input they continue
  const auto waits = [&](std::size_t i) {
    return in_order && robots[i].after_id >= 0 && std::any_of(pending.begin(), pending.end(), [&](std::size_t j) {
             return robots[j].robot_id == robots[i].after_id;
           });
  };
  while (!pending.empty()) {
    bool placed_any = false;
    for (auto it = pending.begin(); it != pending.end();) {
      const std::size_t i = *it;
      if (waits(i)) {
        ++it;
        continue;
      }
      // An empty cloud has nothing to match: placed so that its report is final. A robot already tried
      // against this merged cloud waits.
      const bool untried = !clouds_world[i].empty() && tried_at[i] != merged.cloud.size();
      if (untried) tried_at[i] = merged.cloud.size();
      if (clouds_world[i].empty() || (untried && match(i, robots, merged, clouds_world[i], result))) {
        place(i, "matched");  // match() and place_by_priors() set the precise status
        it = pending.erase(it);
        placed_any = true;
      } else {
        ++it;
      }
    }
    if (!placed_any && !pending.empty()) {  // nobody overlaps: the first pending robot keeps its prior
      // ... one that waits for nobody: a later component keeps waiting for the input it continues.
      const auto first = std::find_if(pending.begin(), pending.end(), [&](std::size_t i) {
        return robots[i].keep_prior_without_overlap && !waits(i);
      });
      if (first == pending.end()) {
        const bool any_waiting = std::any_of(pending.begin(), pending.end(), waits);
        if (in_order && any_waiting) {  // what they wait for will never be placed: try them anyway
          in_order = false;
          continue;
        }
        break;  // the rest are left out (below)
      }
      RobotMergeReport& report = result.robots[*first];
      report.status = without_overlap(report) + ": prior kept";
      logger_->warn("merge: robot {}: {}", report.robot_id, report.status);
      place(*first, report.status);
      pending.erase(first);
    }
  }
  for (std::size_t i : pending) {
    RobotMergeReport& report = result.robots[i];
    report.status = without_overlap(report) + ": left out";
    logger_->info("merge: robot {}: {}", report.robot_id, report.status);
  }
  finish(std::move(merged.cloud), result);
  result.timings.total_ms = ms_since(start);
  return result;
}

// Uniform sampling and Gaussian filtering of the merged cloud, with counts and timings.
void MapMerger::finish(core::PointCloud merged, MergeResult& result) const {
  result.points_before_sampling = merged.size();
  Clock::time_point stage = Clock::now();
  SamplingResult sampled = sampler_.sample(merged);
  result.timings.sampling_ms = ms_since(stage);
  result.points_after_sampling = sampled.points_after;
  stage = Clock::now();
  FilterResult filtered = filter_.filter(sampled.cloud);
  result.timings.filter_ms = ms_since(stage);
  result.points_after_filter = filtered.points;
  result.cloud_world = std::move(filtered.cloud);
  const double reduction = result.points_before_sampling == 0
                               ? 0.0
                               : 100.0 * (1.0 - static_cast<double>(result.points_after_sampling) /
                                                    static_cast<double>(result.points_before_sampling));
  logger_->info("merge: {} points merged, {} after uniform sampling ({:.2f} % fewer), {} after Gaussian filtering "
                "(mean shift {:.4f} m); coarse {:.1f} ms, fine {:.1f} ms, sampling {:.1f} ms, filter {:.1f} ms",
                result.points_before_sampling, result.points_after_sampling, reduction, result.points_after_filter,
                filtered.mean_shift_m, result.timings.coarse_ms, result.timings.registration_ms,
                result.timings.sampling_ms, result.timings.filter_ms);
}

}  // namespace fleetslam::central
