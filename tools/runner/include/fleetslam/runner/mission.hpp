#pragma once
// The central unit's planning side of a run: from the fused dense map, an occupancy grid; for each ground
// robot a goal (its next scenario waypoint, or a frontier assigned so that robots explore different
// places: the frontier's goal, or a viewpoint that sees it, and a robot standing at a viewpoint facing
// away turns towards its frontier) and a deconflicted OMPL path to it, handed back to the robot's
// path-following controller.
//
// update() runs every MissionConfig::replan_period_s of simulated time (and early when a robot finished
// its path): it rebuilds the grid from the fused map (the cells a robot has driven over count as free),
// judges goals reached from the robots' *estimated* positions (the mission never sees ground truth),
// and plans again when a robot needs a new path, its path is blocked in the new map, or it finished
// short of its goal. The robots that need a path are planned together by priority (their order) so that
// their paths do not conflict; the other robots (standing, or keeping a path that is still clear) are
// obstacles where they are. A robot whose conflict deconfliction leaves unresolved is held where it is
// (stopped; an obstacle the others are planned around, as is a boxed-in robot) and planned again at the
// next update. A goal that fails to plan max_plan_failures times, or whose paths keep ending with the
// robot's estimate short of it for MissionConfig::short_of_goal_patience_s, is given up and reported; a robot that lost tracking drives back along its
// trail (lost_backtrack_m) and waits there until its agent relocalises. Nothing here throws for a bad map
// or an unreachable goal: it is all in the reports (a map whose extent needs more than the grid's
// max_cells keeps the last grid, with a warning).

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "fleetslam/core/log.hpp"
#include "fleetslam/core/point_cloud.hpp"
#include "fleetslam/planners/deconfliction.hpp"
#include "fleetslam/planners/occupancy_grid.hpp"
#include "fleetslam/planners/planner.hpp"
#include "fleetslam/runner/run_config.hpp"

namespace fleetslam::runner {

struct MissionRobot {
  std::string name;
  bool ground = true;  // diff-drive robots are planned; free rigs follow their own trajectory
  std::vector<Eigen::Vector2d> waypoints_world;  // the goals of a waypoints mission, in order
};

// A robot as the central unit knows it at an update.
struct RobotObservation {
  bool tracking = false;            // its agent has a pose for the latest frame (implies has_pose)
  bool has_pose = false;            // pose_world holds an estimate: without (its map has not started) the
                                    // robot is nowhere on the grid, not at the origin
  planners::Pose2d pose_world;      // estimated body pose (fused world frame)
  bool path_done = true;            // its controller reached the end of its path (or has none)
  std::vector<Eigen::Vector2d> footprint_world;  // estimated positions it has driven over
};

struct PlanRecord {
  double t_s = 0.0;
  std::string status;  // planners::to_string(PlanStatus), or why no plan was made
  Eigen::Vector2d goal_world = Eigen::Vector2d::Zero();
  std::vector<Eigen::Vector2d> path_world;  // thinned for reports
};

struct MissionRobotReport {
  std::string status = "waiting";  // one line: what the robot is doing or why it stopped
  int goals_total = 0;      // waypoints: the scenario's; explore: frontiers assigned
  int goals_reached = 0;
  // The spot each goal reached by proximity was accepted at: the goal, or the free spot the planner moved
  // it to (an explored frontier counts as reached without one).
  std::vector<Eigen::Vector2d> reached_at_world;
  int goals_given_up = 0;
  int plans = 0;            // plans made (solved or approximate)
  int plan_failures = 0;
  std::vector<PlanRecord> plan_log;
  std::vector<std::string> events;  // "12.0 s: goal 2 reached", ...
};

// A new path for a robot's controller (empty: stop where it is).
struct PathCommand {
  std::size_t robot = 0;
  std::vector<Eigen::Vector2d> path_world;
};

class MissionPlanner {
 public:
  MissionPlanner(const MissionConfig& mission, const PlanningConfig& planning, std::vector<MissionRobot> robots,
                 core::Logger logger = core::null_logger());

  // robots: one observation per robot, in the constructor's order; views: where the robots' sensors saw
  // the map from (free-space carving, OccupancyGridConfig::carve_rays). Returns the controllers' new paths.
  std::vector<PathCommand> update(double t_s, const core::PointCloud& map_world, const std::vector<RobotObservation>& robots,
                                  const std::vector<planners::SensorView>& views_world = {});

  // A ground robot that finished its path has work left (a goal, a waypoint, or frontiers to look for).
  bool wants_plan(std::size_t robot) const;
  bool planned() const { return mission_.kind != MissionKind::kScripted; }
  // The goal a ground robot is heading for (none: idle, stopped, or not planned). A runner that sees the
  // robot's estimate within goal_reached_m of it updates early, so that the next plan starts before the
  // robot stops.
  std::optional<Eigen::Vector2d> goal_of(std::size_t robot) const {
    return robot < state_.size() ? state_[robot].goal_world : std::nullopt;
  }

  // The grid of the last update (empty before the first).
  const planners::OccupancyGrid& grid() const { return grid_; }
  const std::vector<MissionRobotReport>& reports() const { return reports_; }
  const MissionConfig& mission() const { return mission_; }

 private:
  struct RobotMission {
    std::optional<Eigen::Vector2d> goal_world;
    // Where its solved path ends: the goal, or the free spot the planner moved a goal in an obstacle's
    // margin to (PathPlannerConfig::goal_snap_radius_m); reaching either reaches the goal.
    std::optional<Eigen::Vector2d> path_goal_world;
    double short_since_s = -1.0;  // when a path to this goal first ended short of it (-1: none did)
    // Explore: where the frontier of its goal is (the goal itself, or the centroid a viewpoint looks at).
    Eigen::Vector2d frontier_world = Eigen::Vector2d::Zero();
    Eigen::Vector2d frontier_centroid_world = Eigen::Vector2d::Zero();  // explore: its frontier's centroid
    std::size_t next_waypoint = 0;
    int failures_for_goal = 0;
    bool has_path = false;
    bool stopped_lost = false;
    bool backtracked = false;  // lost: the drive back has been commanded
    bool exhausted = false;  // explore: no frontier was left for it at the last assignment
    bool looking = false;    // explore: turning to look at a frontier (busy until its path is done)
    double look_t_s = -1.0;  // ... since this update
    int look_arounds = 0;    // quarter turns since its last frontier
    std::vector<planners::Pose2d> path_world;
  };

  void rebuild_grid(const core::PointCloud& map_world, const std::vector<RobotObservation>& robots,
                    const std::vector<planners::SensorView>& views_world);
  void update_goals(double t_s, const std::vector<RobotObservation>& robots, std::vector<bool>& needs_plan,
                    std::vector<PathCommand>& looks);
  // Turns the robot towards frontier_world with a short step that way (a one-point path), when it faces
  // more than 45 degrees away, sees it and may step there; the robot is busy until the turn is done.
  bool look_towards(double t_s, std::size_t robot, const planners::Pose2d& pose, const Eigen::Vector2d& frontier_world,
                    std::vector<PathCommand>& looks);
  void assign_frontiers(double t_s, const std::vector<RobotObservation>& robots, std::vector<bool>& needs_plan,
                        std::vector<PathCommand>& looks);
  void look_at_frontiers(double t_s, const std::vector<RobotObservation>& robots, const std::vector<Eigen::Vector2d>& frontier_goals,
                         const std::vector<Eigen::Vector2d>& centroid_of_goal, std::vector<std::size_t>& idle,
                         std::vector<Eigen::Vector2d>& idle_positions, std::vector<PathCommand>& looks);
  void look_around(double t_s, std::size_t robot, const RobotObservation& seen, std::vector<PathCommand>& commands);
  bool path_blocked(std::size_t robot, const RobotObservation& observation) const;
  void plan(double t_s, const std::vector<RobotObservation>& robots, const std::vector<bool>& needs_plan,
            std::vector<PathCommand>& commands);
  // The deconflicted plans of the `queried` robots (result.plans in their order) become their paths.
  void apply_plans(double t_s, const std::vector<std::size_t>& queried, const planners::DeconflictionResult& result,
                   std::vector<PathCommand>& commands);
  void give_up_goal(double t_s, std::size_t robot, const std::string& why);
  void event(std::size_t robot, double t_s, const std::string& what);

  MissionConfig mission_;
  PlanningConfig planning_;
  std::vector<MissionRobot> robots_;
  core::Logger logger_;
  planners::OccupancyGrid grid_;           // what the robots saw and drove over (coverage, reports)
  planners::OccupancyGrid planning_grid_;  // grid_ with the blind zones around the robots free (planning)
  std::vector<RobotMission> state_;
  std::vector<MissionRobotReport> reports_;
  std::vector<Eigen::Vector2d> abandoned_goals_world_;  // explore: frontier goals given up
  std::vector<Eigen::Vector2d> reached_goals_world_;    // explore: frontier goals a robot reached
  std::vector<Eigen::Vector2d> looked_at_world_;        // explore: frontiers a robot turned to look at
};

}  // namespace fleetslam::runner
