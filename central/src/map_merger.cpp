#include "fleetslam/central/map_merger.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <set>
#include <string>

#include <spdlog/fmt/fmt.h>
#include <spdlog/logger.h>

#include "fleetslam/core/error.hpp"

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

}  // namespace

MapMerger::MapMerger(const Config& config, core::Logger logger)
    : config_(config),
      overlap_(config.coarse),
      registration_(config.registration),
      sampler_(config.sampling),
      filter_(config.filter),
      logger_(logger ? std::move(logger) : core::null_logger()) {
  if (config_.min_overlap_points < 1) throw InputError("min_overlap_points", "must be at least 1");
  if (config_.refinement_rounds < 1) throw InputError("refinement_rounds", "must be at least 1");
  if (!(config_.refine_radius_m > 0.0) || !std::isfinite(config_.refine_radius_m)) {
    throw InputError("refine_radius_m", "must be positive");
  }
  if (!(config_.min_inlier_ratio >= 0.0 && config_.min_inlier_ratio <= 1.0)) {
    throw InputError("min_inlier_ratio", "must be in [0, 1]");
  }
}

// Fine matching (see the header): GICP on the overlap sets, then, for each further refinement round, the
// overlap sets chosen again with the refined pose (radius refine_radius_m) and GICP again. A round that
// fails ends the refinement with the last good pose; when the first fails, the prior stands.
void MapMerger::fine_match(RobotMergeReport& report, const Overlap& coarse, const core::PointCloud& merged,
                           core::PointCloud& cloud_world, MergeTimings& timings) const {
  OverlapRegions sets{coarse.indices_a, coarse.indices_b};
  // The cloud's centroid where the prior puts it (fine matching starts from the prior).
  Eigen::Vector3d centroid_prior = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3f& p : cloud_world.points) centroid_prior += p.cast<double>();
  if (!cloud_world.empty()) centroid_prior /= static_cast<double>(cloud_world.size());
  for (int round = 1; round <= config_.refinement_rounds; ++round) {
    if (round > 1) {
      const Clock::time_point stage = Clock::now();
      sets = overlap_regions(merged, cloud_world, config_.refine_radius_m);
      timings.coarse_ms += ms_since(stage);
      const std::size_t smaller = std::min(sets.indices_a.size(), sets.indices_b.size());
      if (smaller < static_cast<std::size_t>(config_.min_overlap_points)) break;
    }
    const Clock::time_point stage = Clock::now();
    const RegistrationResult r = registration_.align(select_points(cloud_world, sets.indices_b),
                                                     select_points(merged, sets.indices_a));
    timings.registration_ms += ms_since(stage);
    // How far the result would move the cloud from where its prior put it: its centroid, and the rotation.
    const Eigen::Isometry3d from_prior = r.T_target_source * report.T_world_robot * report.T_world_robot_prior.inverse();
    const double shift_m = (from_prior * centroid_prior - centroid_prior).norm();
    const double correction_deg = rotation_deg(from_prior);
    const bool within = shift_m <= config_.max_correction_m && correction_deg <= config_.max_correction_deg;
    const bool usable =
        (r.converged || r.status == "max iterations") && r.inlier_ratio >= config_.min_inlier_ratio && within;
    logger_->info("merge: robot {}: round {}: GICP {} after {} iterations on {}/{} points (overlap sets {}/{}), "
                  "fitness {:.3g} m^2, inliers {:.2f}, correction {}",
                  report.robot_id, round, r.status, r.iterations, r.source_points, r.target_points,
                  sets.indices_b.size(), sets.indices_a.size(),
                  r.fitness_m2, r.inlier_ratio, describe(r.T_target_source));
    if (!usable) {
      const std::string why = within ? r.status + ", inlier ratio " + std::to_string(r.inlier_ratio)
                                     : describe(shift_m, correction_deg) + " from the prior, beyond the limits";
      if (round == 1) {
        report.registration = r;
        report.status = "registration discarded (" + why + "): prior kept";
        logger_->warn("merge: robot {}: {}", report.robot_id, report.status);
      } else {
        logger_->warn("merge: robot {}: round {} discarded ({})", report.robot_id, round, why);
      }
      return;
    }
    core::transform_in_place(cloud_world, r.T_target_source);
    report.T_world_robot = r.T_target_source * report.T_world_robot;
    report.registration = r;
    report.refinement_rounds = round;
    report.refined_overlap_points = sets.indices_b.size();
    report.fine_matched = true;
    report.status = "fine matched";
  }
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
    if (!is_rigid(robots[i].T_world_robot_prior)) {
      report.status = "bad prior (not a finite rigid transform): left out";
      logger_->error("merge: robot {}: {}", report.robot_id, report.status);
      continue;
    }
    clouds_world[i] = core::transformed(robots[i].cloud_robot, robots[i].T_world_robot_prior);
    report.non_finite_removed = core::remove_non_finite(clouds_world[i]);
    report.points = clouds_world[i].size();
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
  report.overlap_mean_distance_m = overlap.mean_distance_m;
  report.overlap_normal_rejected = overlap.normal_rejected;
  report.overlap_with = pairs_per_robot(overlap, merged, robots);
  logger_->info("merge: robot {}: coarse overlap {} pairs (mean distance {:.3f} m, {} left out for opposite normals) "
                "with {} merged points",
                report.robot_id, overlap.size(), overlap.mean_distance_m, overlap.normal_rejected, merged.cloud.size());
  if (overlap.size() < static_cast<std::size_t>(config_.min_overlap_points)) return false;
  if (config_.registration.enabled) {
    fine_match(report, overlap, merged.cloud, cloud_world, result.timings);
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
  const auto place = [&](std::size_t i, const std::string& status) {
    RobotMergeReport& report = result.robots[i];
    report.placed = true;
    if (report.status.empty()) report.status = status;
    merged.add(i, clouds_world[i]);
    logger_->info("merge: robot {}: {} ({} points)", report.robot_id, report.status, report.points);
  };
  // The reference: robots[0], or the first usable robot when robots[0]'s prior is not.
  if (!pending.empty()) {
    place(pending.front(), "reference");
    pending.erase(pending.begin());
  }
  // Coarse-to-fine matching against the merged cloud so far; see the header for the order.
  std::vector<std::size_t> tried_at(robots.size(), static_cast<std::size_t>(-1));  // merged size at last try
  while (!pending.empty()) {
    bool placed_any = false;
    for (auto it = pending.begin(); it != pending.end();) {
      const std::size_t i = *it;
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
    if (!placed_any && !pending.empty()) {  // nobody overlaps: the first waiting robot keeps its prior
      const auto first = std::find_if(pending.begin(), pending.end(),
                                      [&](std::size_t i) { return robots[i].keep_prior_without_overlap; });
      if (first == pending.end()) break;  // the rest are left out (below)
      RobotMergeReport& report = result.robots[*first];
      report.status = report.overlap_points == 0
                          ? "no overlap: prior kept"
                          : "overlap too small (" + std::to_string(report.overlap_points) + " pairs): prior kept";
      logger_->warn("merge: robot {}: {}", report.robot_id, report.status);
      place(*first, report.status);
      pending.erase(first);
    }
  }
  for (std::size_t i : pending) {
    RobotMergeReport& report = result.robots[i];
    report.status = report.overlap_points == 0
                        ? "no overlap: left out"
                        : "overlap too small (" + std::to_string(report.overlap_points) + " pairs): left out";
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
