#pragma once
// The scenario file of `fleetslam run`: the simulated world (sim::ScenarioConfig's keys at the top level:
// scene, duration_s, seed, robots) plus the sections that make it a closed-loop test:
//
//   agent:    slam::AgentConfig for every robot's agent
//   central:  central::ServerConfig (map merging, trajectory fusion)
//   planner:  {grid: OccupancyGridConfig, path: PathPlannerConfig, deconfliction: ..., assignment: ...}
//   mission:  what the robots do (scripted waypoints, planned waypoints, or frontier exploration)
//   criteria: pass criteria; the run fails (exit 1) when one does not hold
//
// Read with core::ConfigReader: unknown keys and bad values are errors naming file:key.

#include <cstdint>
#include <filesystem>
#include <optional>

#include "fleetslam/central/server.hpp"
#include "fleetslam/core/config.hpp"
#include "fleetslam/planners/deconfliction.hpp"
#include "fleetslam/planners/goal_assignment.hpp"
#include "fleetslam/planners/occupancy_grid.hpp"
#include "fleetslam/planners/planner.hpp"
#include "fleetslam/sim/scenario.hpp"
#include "fleetslam/slam/agent.hpp"

namespace fleetslam::runner {

// scripted:  ground robots follow their scenario waypoints directly (no planning; the maps are still
//            judged, and coverage is reported).
// waypoints: the central unit plans each ground robot's path to its next scenario waypoint on the fused
//            map (OMPL), with deconfliction, and replans when the map changes or the path is blocked.
// explore:   the central unit assigns frontiers of the fused map to the ground robots and plans to them
//            until no frontier is left or the scenario time is over.
// Free rigs always follow their timed knots.
enum class MissionKind { kScripted, kWaypoints, kExplore };

struct MissionConfig {
  MissionKind kind = MissionKind::kScripted;
  double first_plan_s = 0.5;        // simulated time of the first plan (ground robots stand until then)
  double replan_period_s = 2.0;     // the fused map is rebuilt and paths are checked this often
  double min_replan_interval_s = 0.5;  // a robot that finished its path triggers a plan no sooner than this
  double goal_reached_m = 0.25;     // the estimated position this close to a goal: reached
  int max_plan_failures = 3;        // failed plans for one goal before it is given up (reported)
  // A robot whose solved paths keep ending with its estimate more than goal_reached_m from the goal (its
  // estimate is off: the controller drives on the true pose) is sent again until this long after the
  // first such end, as the merge may correct its placement meanwhile, then the goal is given up.
  double short_of_goal_patience_s = 15.0;
  // Disks around the robots' past positions are free floor, even where the map has obstacles: a robot's
  // body was there (so it is no wall), and what stood there may have been a robot seen by another.
  // At most the robots' radius.
  double footprint_free_radius_m = 0.18;
  // For planning only (never for coverage): unknown floor this close to a ground robot is taken as free.
  // A forward camera never sees the floor right in front of it (here up to about 0.7 m), so without this
  // a robot that plans conservatively (unknown cells occupied) could not leave its start. 0: off.
  double blind_zone_free_radius_m = 0.0;
  double start_snap_radius_m = 0.5;  // a start inside the inflated obstacles moves to the nearest free cell
  double lost_backtrack_m = 0.6;    // a robot that lost tracking drives back this far along its trail (0: stops)
  double explore_goal_valid_m = 1.0;  // an exploration goal stays while a frontier cell is this close
  double explore_min_goal_distance_m = 1.0;  // frontier goals nearer a ground robot are not worth a trip
  // Explore: frontier goals this close to one a robot has reached are not worth another trip (0, the
  // default: off). With free-space carving (OccupancyGridConfig::carve_rays), a frontier still there when
  // a robot stands at it cannot be seen from the floor: the top of a bed taller than the camera borders
  // free floor all round, and a robot sent back to it again and again spent 60 of the apartment's 120 s
  // beside it. Without carving, a robot that arrived facing away may still see it from another heading.
  double explore_revisit_radius_m = 0.0;
  // Explore: a frontier's goal is the cell nearest it this far from obstacles (seen ones: a frontier
  // borders unknown floor by definition) (0: any cell the robot fits in). A robot that stops, and turns towards its next goal, with its camera a hand's breadth from
  // a wall sees nothing an agent can track (depth below its range, a patch of bare texture).
  double explore_goal_clearance_m = 0.0;
  // Explore: a frontier with no goal within the grid's frontier_goal_search_m gets a viewpoint instead, the
  // goal cell nearest its centroid within this distance that sees the centroid (no occupied cell between):
  // beyond a doorway, the floor seen through it from afar is strips between the camera's rays, too narrow
  // for a robot and too close to the jambs for a goal, and only a robot in front of the doorway sees it
  // whole. The robot's goal stays while frontier cells remain near the centroid. With viewpoints on, every
  // frontier goal must also be one an idle robot can reach, and a robot that stands at a frontier's goal
  // or viewpoint facing away turns towards the frontier once. 0 (default): off.
  double explore_view_search_m = 0.0;
  // Explore: a frontier's gain (planner.assignment.gain_weight_m_per_m2) is the unknown floor within this
  // distance of its centroid that the centroid has in sight.
  double explore_gain_radius_m = 1.5;
  // Explore: a robot with no reachable frontier turns a quarter further (a short step that way) to see
  // more, up to max_look_arounds times until it gets a frontier again. 0 (default): it waits. Turning on
  // the spot in front of a bare wall can cost an agent its tracking.
  double look_around_step_m = 0.0;
  int max_look_arounds = 8;

  template <class V>
  void visit(V& v) {
    v.choice("kind", kind,
             {{"scripted", MissionKind::kScripted}, {"waypoints", MissionKind::kWaypoints}, {"explore", MissionKind::kExplore}});
    v("first_plan_s", first_plan_s, core::Limits<double>{0.0, 1e6});
    v("replan_period_s", replan_period_s, core::Limits<double>{0.05, 1e6});
    v("min_replan_interval_s", min_replan_interval_s, core::Limits<double>{0.0, 1e6});
    v("goal_reached_m", goal_reached_m, core::Limits<double>{0.01, 100.0});
    v("max_plan_failures", max_plan_failures, core::Limits<int>{1, 1000});
    v("short_of_goal_patience_s", short_of_goal_patience_s, core::Limits<double>{0.0, 1e6});
    v("footprint_free_radius_m", footprint_free_radius_m, core::Limits<double>{0.0, 10.0});
    v("blind_zone_free_radius_m", blind_zone_free_radius_m, core::Limits<double>{0.0, 10.0});
    v("start_snap_radius_m", start_snap_radius_m, core::Limits<double>{0.0, 10.0});
    v("lost_backtrack_m", lost_backtrack_m, core::Limits<double>{0.0, 100.0});
    v("explore_goal_valid_m", explore_goal_valid_m, core::Limits<double>{0.0, 100.0});
    v("explore_min_goal_distance_m", explore_min_goal_distance_m, core::Limits<double>{0.0, 100.0});
    v("explore_revisit_radius_m", explore_revisit_radius_m, core::Limits<double>{0.0, 100.0});
    v("explore_goal_clearance_m", explore_goal_clearance_m, core::Limits<double>{0.0, 10.0});
    v("explore_view_search_m", explore_view_search_m, core::Limits<double>{0.0, 100.0});
    v("explore_gain_radius_m", explore_gain_radius_m, core::Limits<double>{0.01, 100.0});
    v("look_around_step_m", look_around_step_m, core::Limits<double>{0.0, 10.0});
    v("max_look_arounds", max_look_arounds, core::Limits<int>{0, 1000});
  }
};

struct PlanningConfig {
  planners::OccupancyGridConfig grid;
  planners::PathPlannerConfig path;
  planners::DeconflictionConfig deconfliction;
  planners::GoalAssignmentConfig assignment;

  template <class V>
  void visit(V& v) {
    v("grid", grid);
    v("path", path);
    v("deconfliction", deconfliction);
    v("assignment", assignment);
  }
};

// Pass criteria. A negative limit (the default) switches a numeric criterion off.
struct CriteriaConfig {
  double max_ate_m = -1.0;               // every robot: RMSE of its fused world trajectory against truth
  double max_map_accuracy_mean_m = -1.0;  // merged map: mean distance to the true surfaces
  double max_map_accuracy_p95_m = -1.0;
  double min_map_completeness = -1.0;     // share of the true surfaces within 5 cm of the merged map
  double min_coverage = -1.0;             // share of the reachable free floor seen free in the fused map
  double min_real_time_factor = -1.0;
  double max_lost_share = -1.0;           // every robot: share of its frames without a pose
  bool no_collisions = false;             // no robot touches the scene or another robot
  bool goals_reached = false;             // planned missions: every goal of every ground robot reached
  // Planned missions: for every goal the mission counted reached from the robot's estimate (near the goal,
  // or near the free spot the planner moved it to), how far the true body was from that spot at that
  // moment; the largest, per robot, at most this. An explored frontier counts as reached without a spot.
  double max_goal_true_distance_m = -1.0;

  template <class V>
  void visit(V& v) {
    const core::Limits<double> any{-1.0, 1e9};
    v("max_ate_m", max_ate_m, any);
    v("max_map_accuracy_mean_m", max_map_accuracy_mean_m, any);
    v("max_map_accuracy_p95_m", max_map_accuracy_p95_m, any);
    v("min_map_completeness", min_map_completeness, any);
    v("min_coverage", min_coverage, any);
    v("min_real_time_factor", min_real_time_factor, any);
    v("max_lost_share", max_lost_share, any);
    v("no_collisions", no_collisions);
    v("goals_reached", goals_reached);
    v("max_goal_true_distance_m", max_goal_true_distance_m, any);
  }
};

struct RunScenarioConfig {
  sim::ScenarioConfig world;
  slam::AgentConfig agent;
  central::ServerConfig central;
  PlanningConfig planner;
  MissionConfig mission;
  CriteriaConfig criteria;

  template <class V>
  void visit(V& v) {
    world.visit(v);
    v("agent", agent);
    v("central", central);
    v("planner", planner);
    v("mission", mission);
    v("criteria", criteria);
  }
};

// Reads a run scenario and checks its world part like sim::load_scenario. Throws InputError naming file:key.
// seed (>= 0) replaces the file's world seed before the robots without a seed of their own derive theirs
// from it (sim::validate_scenario), so that it reaches the simulation.
RunScenarioConfig load_run_scenario(const std::filesystem::path& file, std::optional<std::int64_t> seed = std::nullopt);

}  // namespace fleetslam::runner
