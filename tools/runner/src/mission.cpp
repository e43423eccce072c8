// MissionPlanner: goals, grids and deconflicted plans for the ground robots of a run (see mission.hpp).

#include "fleetslam/runner/mission.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <limits>
#include <utility>

#include <spdlog/logger.h>

#include "fleetslam/core/error.hpp"
#include "fleetslam/planners/deconfliction.hpp"
#include "fleetslam/planners/goal_assignment.hpp"

namespace fleetslam::runner {
namespace {

using planners::Pose2d;

std::string format_s(double t_s) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.2f s", t_s);
  return buffer;
}

// At most max_points of a path, evenly spread, ends kept.
std::vector<Eigen::Vector2d> thinned(const std::vector<Pose2d>& path, std::size_t max_points) {
  std::vector<Eigen::Vector2d> out;
  if (path.empty()) return out;
  const std::size_t step = std::max<std::size_t>(1, (path.size() + max_points - 1) / max_points);
  for (std::size_t i = 0; i < path.size(); i += step) out.push_back(path[i].xy());
  if ((path.size() - 1) % step != 0) out.push_back(path.back().xy());
  return out;
}

std::vector<Eigen::Vector2d> xy_of(const std::vector<Pose2d>& path) {
  std::vector<Eigen::Vector2d> out;
  out.reserve(path.size());
  for (const Pose2d& p : path) out.push_back(p.xy());
  return out;
}

// Index of the path pose nearest p.
std::size_t nearest_pose(const std::vector<Pose2d>& path, const Eigen::Vector2d& p) {
  std::size_t best = 0;
  double best_m = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < path.size(); ++i) {
    const double d = (path[i].xy() - p).norm();
    if (d < best_m) {
      best_m = d;
      best = i;
    }
  }
  return best;
}

}  // namespace

MissionPlanner::MissionPlanner(const MissionConfig& mission, const PlanningConfig& planning, std::vector<MissionRobot> robots,
                               core::Logger logger)
    : mission_(mission),
      planning_(planning),
      robots_(std::move(robots)),
      logger_(logger ? std::move(logger) : core::null_logger()),
      grid_(planning.grid),
      planning_grid_(planning.grid),
      state_(robots_.size()),
      reports_(robots_.size()) {
  // Constructing the planners checks their configs before the run starts.
  planners::PathPlanner check_path(planning_.path);
  planners::Deconflicter check_deconfliction(planning_.deconfliction, planning_.path);
  for (std::size_t r = 0; r < robots_.size(); ++r) {
    MissionRobotReport& report = reports_[r];
    if (!robots_[r].ground) {
      report.status = "follows its own trajectory";
    } else if (mission_.kind == MissionKind::kScripted) {
      report.status = "follows its scenario waypoints";
    } else if (mission_.kind == MissionKind::kWaypoints) {
      report.goals_total = static_cast<int>(robots_[r].waypoints_world.size());
    }
  }
}

void MissionPlanner::event(std::size_t robot, double t_s, const std::string& what) {
  reports_[robot].events.push_back(format_s(t_s) + ": " + what);
  logger_->info("mission: {} at {}: {}", robots_[robot].name, format_s(t_s), what);
}

bool MissionPlanner::wants_plan(std::size_t robot) const {
  if (!planned() || robot >= robots_.size() || !robots_[robot].ground) return false;
  const RobotMission& s = state_[robot];
  if (s.goal_world) return true;
  if (mission_.kind == MissionKind::kWaypoints) return s.next_waypoint < robots_[robot].waypoints_world.size();
  return !s.exhausted;
}

void MissionPlanner::rebuild_grid(const core::PointCloud& map_world, const std::vector<RobotObservation>& robots,
                                  const std::vector<planners::SensorView>& views_world) {
  planners::OccupancyGridConfig config = planning_.grid;
  if (config.bounds_xy_m.empty()) {
    // The map's extent, the robots and their goals, padded: a robot can plan out of what it has seen.
    Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector2d hi = -lo;
    auto grow = [&](const Eigen::Vector2d& p) {
      if (!p.allFinite()) return;
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    };
    for (std::size_t i = 0; i < map_world.size(); ++i) grow(map_world.points[i].head<2>().cast<double>());
    for (std::size_t r = 0; r < robots.size(); ++r) {
      // A free rig flies: where it is says nothing about the floor.
      if (robots_[r].ground) {
        for (const Eigen::Vector2d& p : robots[r].footprint_world) grow(p);
        if (robots[r].has_pose) grow(robots[r].pose_world.xy());
      }
      if (mission_.kind == MissionKind::kWaypoints) {
        for (const Eigen::Vector2d& p : robots_[r].waypoints_world) grow(p);
      }
    }
    if (lo.allFinite() && hi.allFinite()) {
      hi = hi.cwiseMax(lo + Eigen::Vector2d::Constant(config.resolution_m));  // one point, no margin: one cell
      config.bounds_xy_m = {lo.x() - config.margin_m, lo.y() - config.margin_m, hi.x() + config.margin_m,
                            hi.y() + config.margin_m};
    }
  }
  planners::OccupancyGrid grid(config);
  if (!config.bounds_xy_m.empty()) {
    try {
      grid.update(map_world, views_world);
    } catch (const InputError& e) {  // bounds needing more than max_cells (a far-off point or placement)
      logger_->warn("mission: planning grid kept from the last update: {}", e.what());
      return;
    }
  }
  grid_ = std::move(grid);
  planning_grid_ = grid_;
  if (config.bounds_xy_m.empty()) return;  // nothing seen and no robot: an empty grid
  std::vector<planners::Disk> driven;  // floor a ground robot drove over (a free rig passes above things)
  for (std::size_t r = 0; r < robots.size(); ++r) {
    if (!robots_[r].ground) continue;
    for (const Eigen::Vector2d& p : robots[r].footprint_world) driven.push_back({p, mission_.footprint_free_radius_m});
  }
  if (mission_.footprint_free_radius_m > 0.0) grid_.mark_free(driven, /*clear_occupied=*/true);
  planning_grid_ = grid_;
  if (mission_.blind_zone_free_radius_m > 0.0) {
    std::vector<planners::Disk> blind;
    for (std::size_t r = 0; r < robots.size(); ++r) {
      if (robots_[r].ground && robots[r].tracking) blind.push_back({robots[r].pose_world.xy(), mission_.blind_zone_free_radius_m});
    }
    planning_grid_.mark_free(blind);
  }
}

void MissionPlanner::give_up_goal(double t_s, std::size_t robot, const std::string& why) {
  RobotMission& s = state_[robot];
  MissionRobotReport& report = reports_[robot];
  ++report.goals_given_up;
  char what[160];
  std::snprintf(what, sizeof(what), "goal (%.2f, %.2f) given up: %s", s.goal_world->x(), s.goal_world->y(), why.c_str());
  event(robot, t_s, what);
  if (mission_.kind == MissionKind::kExplore) abandoned_goals_world_.push_back(*s.goal_world);
  if (mission_.kind == MissionKind::kWaypoints) ++s.next_waypoint;
  s.goal_world.reset();
  s.path_goal_world.reset();
  s.short_since_s = -1.0;
  s.failures_for_goal = 0;
}

void MissionPlanner::update_goals(double t_s, const std::vector<RobotObservation>& robots, std::vector<bool>& needs_plan,
                                  std::vector<PathCommand>& looks) {
  const std::vector<planners::Frontier> frontiers =
      mission_.kind == MissionKind::kExplore ? planning_grid_.frontiers() : std::vector<planners::Frontier>{};
  for (std::size_t r = 0; r < robots_.size(); ++r) {
    if (!robots_[r].ground) continue;
    RobotMission& s = state_[r];
    MissionRobotReport& report = reports_[r];
    const RobotObservation& seen = robots[r];
    if (!seen.tracking) {
      if (!s.stopped_lost) {
        s.stopped_lost = true;
        event(r, t_s, "tracking lost");
      }
      report.status = "tracking lost: waiting to relocalise";
      continue;
    }
    if (s.stopped_lost) {
      s.stopped_lost = false;
      s.has_path = false;
      event(r, t_s, "tracking back: planning again");
    }
    const Eigen::Vector2d position = seen.pose_world.xy();
    const auto near = [&](const std::optional<Eigen::Vector2d>& goal) {
      return goal && (position - *goal).norm() <= mission_.goal_reached_m;
    };
    if (s.goal_world && (near(s.goal_world) || near(s.path_goal_world))) {
      ++report.goals_reached;
      report.reached_at_world.push_back(near(s.goal_world) ? *s.goal_world : *s.path_goal_world);
      char what[128];
      if (near(s.goal_world)) {
        std::snprintf(what, sizeof(what), "goal (%.2f, %.2f) reached", s.goal_world->x(), s.goal_world->y());
      } else {
        std::snprintf(what, sizeof(what), "goal (%.2f, %.2f) reached at the free spot %.2f m from it", s.goal_world->x(),
                      s.goal_world->y(), (*s.path_goal_world - *s.goal_world).norm());
      }
      event(r, t_s, what);
      if (mission_.kind == MissionKind::kWaypoints) ++s.next_waypoint;
      if (mission_.kind == MissionKind::kExplore) reached_goals_world_.push_back(*s.goal_world);
      // With viewpoints on, a robot that arrived facing away from its frontier turns to it: a goal reached
      // is a frontier seen (the revisit rule counts on it).
      if (mission_.kind == MissionKind::kExplore && mission_.explore_view_search_m > 0.0) {
        look_towards(t_s, r, seen.pose_world, s.frontier_centroid_world, looks);
      }
      s.goal_world.reset();
      s.path_goal_world.reset();
      s.short_since_s = -1.0;
      s.failures_for_goal = 0;
      s.has_path = false;
    }
    // A solved path driven to its end with the estimate not there (the controller follows the path on the
    // robot's true pose; the estimate is off by more than goal_reached_m): sent again, as the merge may
    // correct the robot's placement, for short_of_goal_patience_s, or it would be sent for ever.
    if (s.goal_world && s.has_path && s.path_goal_world && seen.path_done) {
      if (s.short_since_s < 0.0) s.short_since_s = t_s;
      char what[128];
      std::snprintf(what, sizeof(what), "path done %.2f m short of its goal (%.2f, %.2f)",
                    (position - *s.path_goal_world).norm(), s.goal_world->x(), s.goal_world->y());
      event(r, t_s, what);
      s.has_path = false;
      s.path_goal_world.reset();
      if (t_s - s.short_since_s >= mission_.short_of_goal_patience_s) give_up_goal(t_s, r, "its paths end short of it");
    }
    if (s.goal_world && mission_.kind == MissionKind::kExplore) {
      // The frontier it was sent to has been seen (by it or another robot): a new one.
      bool frontier_left = false;
      for (const planners::Frontier& f : frontiers) {
        for (const planners::CellIndex& c : f.cells) {
          if ((planning_grid_.center_of(c) - s.frontier_world).norm() <= mission_.explore_goal_valid_m) {
            frontier_left = true;
            break;
          }
        }
        if (frontier_left) break;
      }
      if (!frontier_left) {
        ++report.goals_reached;
        event(r, t_s, "its frontier has been explored");
        s.goal_world.reset();
        s.path_goal_world.reset();
        s.short_since_s = -1.0;
        s.failures_for_goal = 0;
        s.has_path = false;
      }
    }
    if (!s.goal_world && mission_.kind == MissionKind::kWaypoints && s.next_waypoint < robots_[r].waypoints_world.size()) {
      s.goal_world = robots_[r].waypoints_world[s.next_waypoint];
      s.path_goal_world.reset();
      s.short_since_s = -1.0;
      s.has_path = false;
    }
    if (s.goal_world && (!s.has_path || seen.path_done || path_blocked(r, seen))) needs_plan[r] = true;
  }
}

void MissionPlanner::look_around(double t_s, std::size_t robot, const RobotObservation& seen, std::vector<PathCommand>& commands) {
  // A quarter turn further each time (left, back, right, ahead), a short step onto floor it may stand on.
  RobotMission& s = state_[robot];
  if (mission_.look_around_step_m <= 0.0 || s.look_arounds >= mission_.max_look_arounds) return;
  for (int k = 0; k < 4; ++k) {
    const double yaw = seen.pose_world.yaw_rad + 0.5 * M_PI * static_cast<double>((s.look_arounds + k) % 4 + 1);
    const Eigen::Vector2d target = seen.pose_world.xy() + mission_.look_around_step_m * Eigen::Vector2d(std::cos(yaw), std::sin(yaw));
    if (!planning_grid_.traversable(target, planning_.path.unknown_cells)) continue;
    s.look_arounds += k + 1;
    commands.push_back({robot, {target}});
    event(robot, t_s, "turns to look around");
    return;
  }
}

void MissionPlanner::assign_frontiers(double t_s, const std::vector<RobotObservation>& robots, std::vector<bool>& needs_plan,
                                      std::vector<PathCommand>& looks) {
  std::vector<std::size_t> idle;
  std::vector<Eigen::Vector2d> idle_positions;
  std::vector<Eigen::Vector2d> taken;
  for (std::size_t r = 0; r < robots_.size(); ++r) {
    if (!robots_[r].ground) continue;
    // Still turning to look at a frontier (or told to at this update, after the robot's path was done).
    if (state_[r].looking && (!robots[r].path_done || state_[r].look_t_s == t_s)) continue;
    state_[r].looking = false;
    if (state_[r].goal_world) {
      taken.push_back(*state_[r].goal_world);
    } else if (robots[r].tracking) {
      idle.push_back(r);
      // Where its plan would start (a robot brushing an inflated obstacle starts from the nearest free cell).
      const std::optional<Eigen::Vector2d> start = planners::nearest_traversable(
          planning_grid_, robots[r].pose_world.xy(), mission_.start_snap_radius_m, planning_.assignment.unknown_cells);
      idle_positions.push_back(start ? *start : robots[r].pose_world.xy());
    }
  }
  if (idle.empty()) return;
  std::vector<Eigen::Vector2d> goals, goal_frontiers, goal_centroids;
  std::vector<double> gains_m2;
  const std::vector<planners::Frontier> frontiers = planning_grid_.frontiers();
  // Each frontier's goal: the cell nearest its centroid that a robot can stand on, with unknown cells
  // as the assignment counts them (the grid's own goals count them occupied).
  std::vector<Eigen::Vector2d> frontier_goals, frontier_of_goal, centroid_of_goal;
  std::vector<double> frontier_gain_m2;
  const bool gains = planning_.assignment.gain_weight_m_per_m2 > 0.0;
  const auto gain_of = [&](const planners::Frontier& f) {
    return gains ? planners::unknown_area_in_sight_m2(planning_grid_, f.centroid_world, mission_.explore_gain_radius_m) : 0.0;
  };
  const planners::UnknownCells unknown = planning_.assignment.unknown_cells;
  // With viewpoints on, a goal is also one an idle robot can reach: a frontier whose nearby cells no robot
  // reaches (floor beyond a doorway, seen only as strips) gets a reachable cell farther off, or a viewpoint.
  std::vector<std::vector<double>> reach_m;
  if (mission_.explore_view_search_m > 0.0) {
    for (const Eigen::Vector2d& p : idle_positions) reach_m.push_back(planning_grid_.geodesic_distances_m(p, unknown));
  }
  const auto good_goal = [&](const Eigen::Vector2d& p) {
    const std::optional<planners::CellIndex> cell = planning_grid_.cell_of(p);
    if (!cell || !planning_grid_.traversable(*cell, unknown) ||
        planning_grid_.clearance_m(*cell, planners::UnknownCells::kFree) < mission_.explore_goal_clearance_m) {
      return false;
    }
    bool reached = reach_m.empty();
    for (const std::vector<double>& d : reach_m) reached = reached || std::isfinite(d[planning_grid_.index(*cell)]);
    return reached;
  };
  for (const planners::Frontier& f : frontiers) {
    const std::optional<Eigen::Vector2d> g =
        good_goal(f.centroid_world)
            ? std::optional<Eigen::Vector2d>(f.centroid_world)
            : planners::nearest_cell_centre(planning_grid_, f.centroid_world, planning_grid_.config().frontier_goal_search_m, good_goal);
    if (g) {
      frontier_goals.push_back(*g);
      frontier_of_goal.push_back(*g);
      centroid_of_goal.push_back(f.centroid_world);
      frontier_gain_m2.push_back(gain_of(f));
      continue;
    }
    if (mission_.explore_view_search_m <= 0.0) continue;
    const std::optional<Eigen::Vector2d> view = planners::nearest_cell_centre(
        planning_grid_, f.centroid_world, mission_.explore_view_search_m, [&](const Eigen::Vector2d& p) {
          return good_goal(p) && planners::line_of_sight(planning_grid_, p, f.centroid_world);
        });
    if (view) {
      frontier_goals.push_back(*view);
      frontier_of_goal.push_back(f.centroid_world);
      centroid_of_goal.push_back(f.centroid_world);
      frontier_gain_m2.push_back(gain_of(f));
    }
  }
  if (mission_.explore_view_search_m > 0.0) look_at_frontiers(t_s, robots, frontier_goals, centroid_of_goal, idle, idle_positions, looks);
  if (idle.empty()) return;
  for (std::size_t i = 0; i < frontier_goals.size(); ++i) {
    const Eigen::Vector2d& g = frontier_goals[i];
    bool free_goal = true;
    for (const Eigen::Vector2d& t : taken) free_goal = free_goal && (g - t).norm() > planning_.assignment.separation_m;
    for (const Eigen::Vector2d& a : abandoned_goals_world_) free_goal = free_goal && (g - a).norm() > mission_.goal_reached_m;
    for (const Eigen::Vector2d& v : reached_goals_world_) {
      free_goal = free_goal && (g - v).norm() >= mission_.explore_revisit_radius_m;
    }
    // The rim of the floor a robot stands on (its own footprint next to the unseen floor below its
    // camera) is a frontier too, but not a place to go.
    for (std::size_t r = 0; r < robots_.size(); ++r) {
      if (robots_[r].ground && robots[r].has_pose) {
        free_goal = free_goal && (g - robots[r].pose_world.xy()).norm() >= mission_.explore_min_goal_distance_m;
      }
    }
    if (free_goal) {
      goals.push_back(g);
      goal_frontiers.push_back(frontier_of_goal[i]);
      goal_centroids.push_back(centroid_of_goal[i]);
      gains_m2.push_back(frontier_gain_m2[i]);
    }
  }
  const planners::GoalAssignment assignment = planners::GoalAssigner(planning_.assignment).assign(idle_positions, goals, &planning_grid_, gains_m2);
  logger_->info("mission: {:.2f} s: {} frontier(s), {} with a goal, {} worth a trip, for {} idle robot(s)", t_s,
                frontiers.size(), frontier_goals.size(), goals.size(), idle.size());
  for (std::size_t i = 0; i < idle.size(); ++i) {
    const std::size_t r = idle[i];
    RobotMission& s = state_[r];
    const int g = assignment.goal_of_robot[i];
    if (g < 0) {
      if (!s.exhausted) event(r, t_s, "no reachable frontier left");
      s.exhausted = true;
      reports_[r].status = "no reachable frontier left";
      look_around(t_s, r, robots[r], looks);
      continue;
    }
    s.exhausted = false;
    s.look_arounds = 0;
    s.goal_world = goals[static_cast<std::size_t>(g)];
    s.path_goal_world.reset();
    s.short_since_s = -1.0;
    s.frontier_world = goal_frontiers[static_cast<std::size_t>(g)];
    s.frontier_centroid_world = goal_centroids[static_cast<std::size_t>(g)];
    s.failures_for_goal = 0;
    s.has_path = false;
    ++reports_[r].goals_total;
    char what[128];
    if (s.frontier_world == *s.goal_world) {
      std::snprintf(what, sizeof(what), "frontier (%.2f, %.2f) assigned", s.goal_world->x(), s.goal_world->y());
    } else {
      std::snprintf(what, sizeof(what), "viewpoint (%.2f, %.2f) on the frontier at (%.2f, %.2f) assigned",
                    s.goal_world->x(), s.goal_world->y(), s.frontier_world.x(), s.frontier_world.y());
    }
    event(r, t_s, what);
    needs_plan[r] = true;
  }
}

bool MissionPlanner::look_towards(double t_s, std::size_t robot, const planners::Pose2d& pose, const Eigen::Vector2d& frontier_world,
                                  std::vector<PathCommand>& looks) {
  constexpr double kFacingRad = M_PI / 4.0;
  constexpr double kStepM = 0.25;
  const Eigen::Vector2d to_frontier = frontier_world - pose.xy();
  if (to_frontier.norm() < kStepM) return false;
  const double off = std::abs(std::remainder(std::atan2(to_frontier.y(), to_frontier.x()) - pose.yaw_rad, 2.0 * M_PI));
  if (off <= kFacingRad || !planners::line_of_sight(planning_grid_, pose.xy(), frontier_world)) return false;
  const Eigen::Vector2d target = pose.xy() + kStepM * to_frontier.normalized();
  if (!planning_grid_.traversable(target, planning_.path.unknown_cells)) return false;
  looked_at_world_.push_back(frontier_world);
  state_[robot].looking = true;
  state_[robot].look_t_s = t_s;
  looks.push_back({robot, {target}});
  char what[96];
  std::snprintf(what, sizeof(what), "turns to look at the frontier at (%.2f, %.2f)", frontier_world.x(), frontier_world.y());
  event(robot, t_s, what);
  return true;
}

void MissionPlanner::look_at_frontiers(double t_s, const std::vector<RobotObservation>& robots,
                                       const std::vector<Eigen::Vector2d>& frontier_goals,
                                       const std::vector<Eigen::Vector2d>& centroid_of_goal, std::vector<std::size_t>& idle,
                                       std::vector<Eigen::Vector2d>& idle_positions, std::vector<PathCommand>& looks) {
  // An idle robot that already stands at a frontier's goal or viewpoint (nearer than
  // explore_min_goal_distance_m, so no trip is made to it) but faces away from the frontier turns towards
  // it (look_towards), once per frontier; it takes no goal until the turn is done.
  for (std::size_t k = 0; k < idle.size();) {
    const std::size_t r = idle[k];
    const planners::Pose2d& pose = robots[r].pose_world;
    bool turned = false;
    for (std::size_t i = 0; i < frontier_goals.size() && !turned; ++i) {
      const Eigen::Vector2d& frontier = centroid_of_goal[i];
      if ((frontier_goals[i] - pose.xy()).norm() >= mission_.explore_min_goal_distance_m) continue;
      if ((frontier - pose.xy()).norm() < mission_.explore_min_goal_distance_m) continue;  // its own rim
      bool looked = false;
      for (const Eigen::Vector2d& l : looked_at_world_) looked = looked || (l - frontier).norm() < mission_.explore_goal_valid_m;
      if (!looked) turned = look_towards(t_s, r, pose, frontier, looks);
    }
    if (!turned) {
      ++k;
      continue;
    }
    idle.erase(idle.begin() + static_cast<std::ptrdiff_t>(k));
    idle_positions.erase(idle_positions.begin() + static_cast<std::ptrdiff_t>(k));
  }
}

bool MissionPlanner::path_blocked(std::size_t robot, const RobotObservation& observation) const {
  const RobotMission& s = state_[robot];
  if (!s.has_path || s.path_world.empty()) return false;
  // The rest of the path, beyond the stretch next to the robot (a robot brushing past an inflated wall
  // is not a blocked path).
  std::size_t from = nearest_pose(s.path_world, observation.pose_world.xy());
  while (from < s.path_world.size() &&
         (s.path_world[from].xy() - observation.pose_world.xy()).norm() < mission_.start_snap_radius_m) {
    ++from;
  }
  if (from >= s.path_world.size()) return false;
  const std::vector<Pose2d> rest(s.path_world.begin() + static_cast<std::ptrdiff_t>(from), s.path_world.end());
  return planners::first_blocked_pose(planning_grid_, rest, planning_.path.unknown_cells) >= 0;
}

void MissionPlanner::plan(double t_s, const std::vector<RobotObservation>& robots, const std::vector<bool>& needs_plan,
                          std::vector<PathCommand>& commands) {
  // The robots that need a path are deconflicted among themselves (by priority); the others (standing,
  // or keeping a path that is still good, which a new plan would only make them turn away from) are
  // obstacles where they are, and those keeping a path are also deconflicted against along the rest of
  // it (committed, of higher priority), so that a new path does not cross theirs in time. A robot boxed
  // in, or whose conflict stays unresolved, stops and stands (held): the others are planned again around
  // it, those keeping a path that passes it too. Each pass takes at least one robot out of the planning
  // or one committed path into it, so the passes end.
  enum class Role { kNone, kStanding, kCommitted, kQuery, kHeld };
  std::vector<Role> role(robots_.size(), Role::kNone);
  for (std::size_t r = 0; r < robots_.size(); ++r) {
    if (needs_plan[r]) {
      role[r] = Role::kQuery;
    } else if (robots_[r].ground && robots[r].has_pose) {  // a free rig blocks no floor; nor does one nowhere yet
      role[r] = state_[r].has_path && !state_[r].path_world.empty() ? Role::kCommitted : Role::kStanding;
    }
  }
  const auto rest_of_path = [&](std::size_t r) {
    const Eigen::Vector2d position = robots[r].pose_world.xy();
    const std::vector<Pose2d>& path = state_[r].path_world;
    std::vector<Pose2d> rest{robots[r].pose_world};
    rest.insert(rest.end(), path.begin() + static_cast<std::ptrdiff_t>(nearest_pose(path, position)), path.end());
    return rest;
  };
  const auto hold = [&](std::size_t r, const std::string& why) {
    RobotMission& s = state_[r];
    role[r] = Role::kHeld;
    s.has_path = false;
    s.path_goal_world.reset();
    commands.push_back({r, {}});
    reports_[r].status = why;
    // A path kept by another robot that passes where this one now stands is planned again.
    const double separation = planning_.deconfliction.separation_m;
    for (std::size_t c = 0; c < robots_.size(); ++c) {
      if (role[c] != Role::kCommitted || !state_[c].goal_world) continue;
      for (const Pose2d& pose : rest_of_path(c)) {
        if ((pose.xy() - robots[r].pose_world.xy()).norm() >= separation) continue;
        role[c] = Role::kQuery;
        event(c, t_s, "its path passes " + robots_[r].name + ", who stopped: planning again");
        break;
      }
    }
  };
  for (;;) {
    // Marked occupied, each disk is then inflated by the robot radius: centres stay separation_m apart.
    const double radius = std::max(0.0, planning_.deconfliction.separation_m - planning_grid_.config().robot_radius_m);
    planners::OccupancyGrid grid = planning_grid_;
    std::vector<planners::Disk> standing;
    std::vector<planners::CommittedPath> committed;
    for (std::size_t r = 0; r < robots_.size(); ++r) {
      if (role[r] == Role::kNone || role[r] == Role::kQuery || !robots[r].has_pose) continue;
      standing.push_back({robots[r].pose_world.xy(), radius});
      if (role[r] == Role::kCommitted) committed.push_back({static_cast<int>(r), rest_of_path(r), robots[r].pose_world.xy()});
    }
    if (!standing.empty()) grid.block(standing);
    std::vector<planners::RobotQuery> queries;
    std::vector<std::size_t> queried;
    bool boxed_in = false;
    for (std::size_t r = 0; r < robots_.size(); ++r) {
      if (role[r] != Role::kQuery) continue;
      RobotMission& s = state_[r];
      const std::optional<Eigen::Vector2d> start =
          planners::nearest_traversable(grid, robots[r].pose_world.xy(), mission_.start_snap_radius_m, planning_.path.unknown_cells);
      if (!start) {
        ++reports_[r].plan_failures;
        if (s.goal_world) reports_[r].plan_log.push_back({t_s, "start_invalid", *s.goal_world, {}});
        hold(r, "boxed in: no free cell near it");
        if (s.goal_world && ++s.failures_for_goal >= mission_.max_plan_failures) give_up_goal(t_s, r, "the robot is boxed in");
        boxed_in = true;
        continue;
      }
      Pose2d pose = robots[r].pose_world;
      pose.x_m = start->x();
      pose.y_m = start->y();
      queries.push_back({static_cast<int>(r), pose, *s.goal_world});
      queried.push_back(r);
    }
    if (boxed_in) continue;  // it stands now: the others around it
    if (queries.empty()) return;
    const planners::Deconflicter deconflicter(planning_.deconfliction, planning_.path, logger_);
    const planners::DeconflictionResult result = deconflicter.plan(grid, queries, committed);
    if (!result.conflicts.empty()) {
      for (const planners::Conflict& c : result.conflicts) {
        const auto b = static_cast<std::size_t>(c.robot_b);
        const std::string& other = robots_[static_cast<std::size_t>(c.robot_a)].name;
        event(b, t_s, "path conflict with " + other + " left unresolved: held where it is");
        hold(b, "held: its path conflicted with " + other + "'s");
      }
      continue;
    }
    apply_plans(t_s, queried, result, commands);
    return;
  }
}

void MissionPlanner::apply_plans(double t_s, const std::vector<std::size_t>& queried,
                                 const planners::DeconflictionResult& result, std::vector<PathCommand>& commands) {
  for (std::size_t q = 0; q < queried.size(); ++q) {
    const std::size_t r = queried[q];
    RobotMission& s = state_[r];
    MissionRobotReport& report = reports_[r];
    const planners::PlanResult& plan = result.plans[q];
    report.plan_log.push_back({t_s, planners::to_string(plan.status), *s.goal_world, thinned(plan.path_world, 60)});
    const bool usable = plan.status == planners::PlanStatus::kSolved ||
                        (plan.status == planners::PlanStatus::kApproximate && !plan.path_world.empty());
    s.path_goal_world.reset();
    if (usable) {
      ++report.plans;
      if (!plan.solved()) ++report.plan_failures;
      if (!plan.solved() && ++s.failures_for_goal >= mission_.max_plan_failures) {
        give_up_goal(t_s, r, "only approximate paths");
        commands.push_back({r, {}});
        s.has_path = false;
        continue;
      }
      s.path_world = plan.path_world;
      s.has_path = true;
      if (plan.solved()) s.path_goal_world = plan.goal_world;
      commands.push_back({r, xy_of(plan.path_world)});
      char status[96];
      std::snprintf(status, sizeof(status), "to (%.2f, %.2f), %.1f m path", s.goal_world->x(), s.goal_world->y(), plan.length_m);
      report.status = status;
      continue;
    }
    ++report.plan_failures;
    report.status = std::string("no path to its goal (") + planners::to_string(plan.status) + ")";
    s.has_path = false;
    commands.push_back({r, {}});
    if (++s.failures_for_goal >= mission_.max_plan_failures) {
      give_up_goal(t_s, r, std::string("no path (") + planners::to_string(plan.status) + ")");
    }
  }
}

std::vector<PathCommand> MissionPlanner::update(double t_s, const core::PointCloud& map_world,
                                                const std::vector<RobotObservation>& robots,
                                                const std::vector<planners::SensorView>& views_world) {
  FLEETSLAM_CHECK(robots.size() == robots_.size(), "one observation per robot");
  rebuild_grid(map_world, robots, views_world);
  std::vector<PathCommand> commands;
  if (!planned()) return commands;
  std::vector<bool> needs_plan(robots_.size(), false);
  update_goals(t_s, robots, needs_plan, commands);
  if (mission_.kind == MissionKind::kExplore) assign_frontiers(t_s, robots, needs_plan, commands);
  for (std::size_t r = 0; r < robots_.size(); ++r) {
    if (!robots_[r].ground) continue;
    const RobotMission& s = state_[r];
    if (!robots[r].tracking && !s.backtracked) {
      // Lost: drive back to where it tracked a little earlier (the controller turns it round on the
      // spot), so that its camera sees mapped places again and its agent can relocalise; then it waits.
      state_[r].backtracked = true;
      state_[r].has_path = false;
      std::vector<Eigen::Vector2d> back;
      const std::vector<Eigen::Vector2d>& trail = robots[r].footprint_world;
      for (auto it = trail.rbegin(); it != trail.rend() && mission_.lost_backtrack_m > 0.0; ++it) {
        if ((*it - robots[r].pose_world.xy()).norm() >= mission_.lost_backtrack_m) {
          back.push_back(*it);
          break;
        }
      }
      commands.push_back({r, back});
      if (!back.empty()) event(r, t_s, "tracking lost: driving back to where it last tracked");
    }
    if (robots[r].tracking) state_[r].backtracked = false;
    if (!s.goal_world && robots[r].tracking && mission_.kind == MissionKind::kWaypoints &&
        s.next_waypoint >= robots_[r].waypoints_world.size()) {
      reports_[r].status = reports_[r].goals_given_up > 0 ? "mission over, some goals given up" : "all goals reached";
    }
  }
  if (std::find(needs_plan.begin(), needs_plan.end(), true) != needs_plan.end()) plan(t_s, robots, needs_plan, commands);
  return commands;
}

}  // namespace fleetslam::runner
