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
  double start_s = 0.0;  // when it starts along the path (after its start turn)

  Eigen::Vector2d at(double speed_m_per_s, double t_s) const {
    return position_at(path, speed_m_per_s, t_s - start_s, rest_world);
  }
  double end_s(double speed_m_per_s) const { return start_s + path_duration_s(path, speed_m_per_s); }
};

std::optional<Conflict> first_conflict(const TimedPath& a, const TimedPath& b, const DeconflictionConfig& c) {
  const double end = std::max(a.end_s(c.speed_m_per_s), b.end_s(c.speed_m_per_s)) + c.time_margin_s + c.time_step_s;
  const int margin_steps = static_cast<int>(std::ceil(c.time_margin_s / c.time_step_s));
  for (int k = 0; k * c.time_step_s <= end; ++k) {
    const double t = k * c.time_step_s;
    const Eigen::Vector2d pb = b.at(c.speed_m_per_s, t);
    for (int m = -margin_steps; m <= margin_steps; ++m) {
      const double ta = std::max(0.0, t + m * c.time_step_s);
      const Eigen::Vector2d pa = a.at(c.speed_m_per_s, ta);
      const double d = (pa - pb).norm();
      if (d < c.separation_m) return Conflict{a.robot_id, b.robot_id, t, pa, pb, d};
    }
  }
  return std::nullopt;
}

}  // namespace

double path_duration_s(const std::vector<Pose2d>& path_world, double speed_m_per_s) {
  double length = 0.0;
  for (std::size_t i = 1; i < path_world.size(); ++i) length += (path_world[i].xy() - path_world[i - 1].xy()).norm();
  return length / speed_m_per_s;
}

double start_turn_s(double start_yaw_rad, const std::vector<Pose2d>& path_world, double yaw_rate_radps) {
  if (!(yaw_rate_radps > 0.0)) return 0.0;
  for (std::size_t i = 1; i < path_world.size(); ++i) {
    const Eigen::Vector2d d = path_world[i].xy() - path_world[i - 1].xy();
    if (!(d.norm() > 1e-9)) continue;
    constexpr double kTwoPi = 6.283185307179586;
    const double turn = std::remainder(std::atan2(d.y(), d.x()) - start_yaw_rad, kTwoPi);
    return std::isfinite(turn) ? std::abs(turn) / yaw_rate_radps : 0.0;
  }
  return 0.0;
}

Eigen::Vector2d position_at(const std::vector<Pose2d>& path_world, double speed_m_per_s, double t_s,
                            const Eigen::Vector2d& fallback) {
  if (path_world.empty()) return fallback;
  double remaining = std::max(0.0, t_s) * speed_m_per_s;
  for (std::size_t i = 1; i < path_world.size(); ++i) {
    const Eigen::Vector2d a = path_world[i - 1].xy();
    const Eigen::Vector2d b = path_world[i].xy();
    const double length = (b - a).norm();
    if (remaining <= length) return length > 0.0 ? Eigen::Vector2d(a + (b - a) * (remaining / length)) : a;
    remaining -= length;
  }
  return path_world.back().xy();
}

Deconflicter::Deconflicter(const Config& config, const PathPlannerConfig& planner_config, core::Logger logger)
    : config_(config), planner_(planner_config, logger), logger_(logger ? std::move(logger) : core::null_logger()) {
  // The YAML limits guard configs read from files; one built in code is checked here (a zero speed or time
  // step never ended the conflict scan).
  const auto in = [](double value, double lo, double hi) { return value >= lo && value <= hi; };
  if (!in(config_.speed_m_per_s, 1e-3, 100.0)) throw InputError("deconfliction.speed_m_per_s", "must be in [0.001, 100]");
  if (!in(config_.yaw_rate_radps, 0.0, 100.0)) throw InputError("deconfliction.yaw_rate_radps", "must be in [0, 100]");
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
  for (const CommittedPath& c : committed) timed.push_back(TimedPath{c.robot_id, c.path_world, c.position_world});
  // A query's plan as timed: after the turn from the robot's start yaw to the path.
  const auto timed_plan = [&](const RobotQuery& q, const PlanResult& plan) {
    return TimedPath{q.robot_id, plan.path_world, q.start_world.xy(),
                     start_turn_s(q.start_world.yaw_rad, plan.path_world, config_.yaw_rate_radps)};
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
        const Eigen::Vector2d p = other.at(config_.speed_m_per_s, t);
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
