#include "fleetslam/planners/deconfliction.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <utility>

#include <spdlog/spdlog.h>

#include "fleetslam/core/error.hpp"

namespace fleetslam::planners {
namespace {

struct TimedPath {
  int robot_id = 0;
  std::vector<Pose2d> path;
  Eigen::Vector2d rest_world = Eigen::Vector2d::Zero();  // where it stands without a path
  PathSchedule schedule;

  Eigen::Vector2d at(double t_s) const { return position_at(path, schedule, t_s, rest_world); }
  double end_s() const { return schedule.end_s(); }
};

std::optional<Conflict> first_conflict(const TimedPath& a, const TimedPath& b, const DeconflictionConfig& c) {
  const double end = std::max(a.end_s(), b.end_s()) + c.time_margin_s + c.time_step_s;
  const int margin_steps = static_cast<int>(std::ceil(c.time_margin_s / c.time_step_s));
  for (int k = 0; k * c.time_step_s <= end; ++k) {
    const double t = k * c.time_step_s;
    const Eigen::Vector2d pb = b.at(t);
    for (int m = -margin_steps; m <= margin_steps; ++m) {
      const double ta = std::max(0.0, t + m * c.time_step_s);
      const Eigen::Vector2d pa = a.at(ta);
      const double d = (pa - pb).norm();
      if (d < c.separation_m) return Conflict{a.robot_id, b.robot_id, t, pa, pb, d};
    }
  }
  return std::nullopt;
}

// The heading of a path's first segment that has a length (0 without one).
double first_heading(const std::vector<Pose2d>& path_world) {
  for (std::size_t i = 1; i < path_world.size(); ++i) {
    const Eigen::Vector2d d = path_world[i].xy() - path_world[i - 1].xy();
    if (d.norm() > 1e-9) return std::atan2(d.y(), d.x());
  }
  return 0.0;
}

}  // namespace

PathSchedule schedule_path(const std::vector<Pose2d>& path_world, double start_yaw_rad, const DeconflictionConfig& config) {
  constexpr double kTwoPi = 6.283185307179586;
  const double on_spot_rad = config.turn_on_spot_deg * kTwoPi / 360.0;
  PathSchedule schedule;
  schedule.arrive_s.resize(path_world.size());
  schedule.depart_s.resize(path_world.size());
  double t = 0.0;
  double heading = start_yaw_rad;
  for (std::size_t i = 0; i < path_world.size(); ++i) {
    schedule.arrive_s[i] = t;
    double drive_s = 0.0;
    if (i + 1 < path_world.size()) {
      const Eigen::Vector2d d = path_world[i + 1].xy() - path_world[i].xy();
      const double length = d.norm();
      drive_s = length / config.speed_m_per_s;
      if (length > 1e-9 && config.yaw_rate_radps > 0.0) {
        const double next = std::atan2(d.y(), d.x());
        double turn = std::abs(std::remainder(next - heading, kTwoPi));
        if (!std::isfinite(turn)) turn = 0.0;  // a start yaw that is no angle: nothing to time
        heading = next;
        const double turn_s = turn / config.yaw_rate_radps;
        if (turn > on_spot_rad) {
          t += turn_s;
        } else {
          drive_s = std::max(drive_s, turn_s);
        }
      }
    }
    schedule.depart_s[i] = t;
    t += drive_s;
  }
  return schedule;
}

Eigen::Vector2d position_at(const std::vector<Pose2d>& path_world, const PathSchedule& schedule, double t_s,
                            const Eigen::Vector2d& fallback) {
  if (path_world.empty()) return fallback;
  FLEETSLAM_CHECK(schedule.arrive_s.size() == path_world.size() && schedule.depart_s.size() == path_world.size(),
                  "position_at: the schedule is of another path");
  // The last pose reached by t_s (arrival times never decrease).
  const auto reached = std::upper_bound(schedule.arrive_s.begin(), schedule.arrive_s.end(), t_s);
  if (reached == schedule.arrive_s.begin()) return path_world.front().xy();
  const auto i = static_cast<std::size_t>(reached - schedule.arrive_s.begin()) - 1;
  if (i + 1 == path_world.size() || !(t_s > schedule.depart_s[i])) return path_world[i].xy();
  const double span = schedule.arrive_s[i + 1] - schedule.depart_s[i];
  const double along = span > 0.0 ? (t_s - schedule.depart_s[i]) / span : 1.0;
  return path_world[i].xy() + (path_world[i + 1].xy() - path_world[i].xy()) * std::clamp(along, 0.0, 1.0);
}

Deconflicter::Deconflicter(const Config& config, const PathPlannerConfig& planner_config, core::Logger logger)
    : config_(config), planner_(planner_config, logger), logger_(logger ? std::move(logger) : core::null_logger()) {
  // The YAML limits guard configs read from files; one built in code is checked here (a zero speed or time
  // step never ended the conflict scan).
  const auto in = [](double value, double lo, double hi) { return value >= lo && value <= hi; };
  if (!in(config_.speed_m_per_s, 1e-3, 100.0)) throw InputError("deconfliction.speed_m_per_s", "must be in [0.001, 100]");
  if (!in(config_.yaw_rate_radps, 0.0, 100.0)) throw InputError("deconfliction.yaw_rate_radps", "must be in [0, 100]");
  if (!in(config_.turn_on_spot_deg, 0.0, 180.0)) throw InputError("deconfliction.turn_on_spot_deg", "must be in [0, 180]");
  if (!in(config_.time_step_s, 1e-3, 10.0)) throw InputError("deconfliction.time_step_s", "must be in [0.001, 10]");
  if (!in(config_.time_margin_s, 0.0, 100.0)) throw InputError("deconfliction.time_margin_s", "must be in [0, 100]");
  if (!in(config_.separation_m, 0.0, 100.0)) throw InputError("deconfliction.separation_m", "must be in [0, 100]");
  if (!in(config_.block_window_s, 0.0, 1000.0)) throw InputError("deconfliction.block_window_s", "must be in [0, 1000]");
  if (config_.max_replans < 0 || config_.max_replans > 1000) {
    throw InputError("deconfliction.max_replans", "must be in [0, 1000]");
  }
}

DeconflictionResult Deconflicter::plan(const OccupancyGrid& grid, const std::vector<RobotQuery>& queries,
                                       const std::vector<CommittedPath>& committed) const {
  DeconflictionResult result;
  std::vector<TimedPath> timed;
  // A committed robot is under way along its path: it faces along it, with no turn at its start.
  for (const CommittedPath& c : committed) {
    timed.push_back(TimedPath{c.robot_id, c.path_world, c.position_world,
                              schedule_path(c.path_world, first_heading(c.path_world), config_)});
  }
  const auto timed_plan = [&](const RobotQuery& q, const PlanResult& plan) {
    return TimedPath{q.robot_id, plan.path_world, q.start_world.xy(),
                     schedule_path(plan.path_world, q.start_world.yaw_rad, config_)};
  };
  for (const RobotQuery& q : queries) {
    std::vector<Disk> blocked;
    PlanResult plan = planner_.plan(grid, q.start_world, q.goal_world, blocked);
    int replans = 0;
    std::optional<Conflict> conflict;
    for (;;) {
      const TimedPath mine = timed_plan(q, plan);
      conflict.reset();
      for (const TimedPath& other : timed) {
        conflict = first_conflict(other, mine, config_);
        if (conflict) break;
      }
      if (!conflict || replans >= config_.max_replans) break;
      // Block the higher-priority robot's poses around the conflict time.
      const TimedPath& other = *std::find_if(timed.begin(), timed.end(),
                                             [&](const TimedPath& t) { return t.robot_id == conflict->robot_a; });
      const double step_s = 0.5 * grid.resolution_m() / config_.speed_m_per_s;
      for (double t = conflict->time_s - config_.block_window_s; t <= conflict->time_s + config_.block_window_s;
           t += step_s) {
        const Eigen::Vector2d p = other.at(t);
        if ((p - q.start_world.xy()).norm() < config_.separation_m || (p - q.goal_world).norm() < config_.separation_m) {
          continue;
        }
        blocked.push_back(Disk{p, config_.separation_m});
      }
      ++replans;
      PlanResult replanned = planner_.plan(grid, q.start_world, q.goal_world, blocked);
      logger_->debug("deconfliction: robot {} conflicts with robot {} at t = {:.1f} s; replan {}: {}", q.robot_id,
                     conflict->robot_a, conflict->time_s, replans, to_string(replanned.status));
      if (!replanned.solved()) break;  // keep the last path found; the conflict is reported
      plan = std::move(replanned);
    }
    if (conflict) result.conflicts.push_back(*conflict);
    timed.push_back(timed_plan(q, plan));
    result.plans.push_back(std::move(plan));
    result.replans.push_back(replans);
  }
  return result;
}

}  // namespace fleetslam::planners
