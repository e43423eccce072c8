#pragma once
// Multi-robot deconfliction by priorities. Robots are planned in the order given (first = highest
// priority). Each path is timed as its robot's controller drives it (schedule_path): along its xy length
// at a nominal speed, with its turns at yaw_rate_radps (0: turning takes no time). A heading change of
// more than turn_on_spot_deg, from the robot's start yaw to the first segment or at a corner, is turned on
// the spot; a smaller one is driven through, no faster than the yaw rate allows. Before its start a robot
// stands at its start, after its end at its last pose; a robot without a path stands at its start
// throughout. Robots already following a path they keep (CommittedPath) come first, timed from now
// (facing along it). A later robot's path conflicts with an earlier one when, at some
// time t (sampled every time_step_s), the two are closer than separation_m at times t and t' with
// |t - t'| <= time_margin_s. On a conflict the later robot is replanned with the earlier robot's path
// around the conflict (poses within +-block_window_s of it) blocked by disks of radius separation_m (disks
// that would cover the later robot's own start or goal are left out), up to max_replans times. Conflicts
// left then are reported, never hidden.

#include <vector>

#include <Eigen/Core>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/planners/occupancy_grid.hpp"
#include "fleetslam/planners/planner.hpp"

namespace fleetslam::planners {

struct DeconflictionConfig {
  double speed_m_per_s = 0.5;
  double yaw_rate_radps = 0.0;     // turns' rate (0: not timed)
  double turn_on_spot_deg = 60.0;  // heading changes beyond this are turned on the spot (the controller's
                                   // rotate_in_place_deg)
  double time_step_s = 0.1;
  double time_margin_s = 0.5;
  double separation_m = 0.5;   // at least twice the robot radius
  double block_window_s = 2.0;
  int max_replans = 5;

  template <class V>
  void visit(V& v) {
    v("speed_m_per_s", speed_m_per_s, core::Limits<double>{1e-3, 100.0});
    v("yaw_rate_radps", yaw_rate_radps, core::Limits<double>{0.0, 100.0});
    v("turn_on_spot_deg", turn_on_spot_deg, core::Limits<double>{0.0, 180.0});
    v("time_step_s", time_step_s, core::Limits<double>{1e-3, 10.0});
    v("time_margin_s", time_margin_s, core::Limits<double>{0.0, 100.0});
    v("separation_m", separation_m, core::Limits<double>{0.0, 100.0});
    v("block_window_s", block_window_s, core::Limits<double>{0.0, 1000.0});
    v("max_replans", max_replans, core::Limits<int>{0, 1000});
  }
};

struct RobotQuery {
  int robot_id = 0;
  Pose2d start_world;
  Eigen::Vector2d goal_world = Eigen::Vector2d::Zero();
};

// A path a robot is already following and keeps: the rest of it, from where the robot is now. Robots
// being planned keep clear of it as of a robot of higher priority, timed from now.
struct CommittedPath {
  int robot_id = 0;
  std::vector<Pose2d> path_world;
  Eigen::Vector2d position_world = Eigen::Vector2d::Zero();  // where it is now (and stays without a path)
};

struct Conflict {
  int robot_a = 0;  // higher priority
  int robot_b = 0;  // lower priority
  double time_s = 0.0;
  Eigen::Vector2d position_a_world = Eigen::Vector2d::Zero();
  Eigen::Vector2d position_b_world = Eigen::Vector2d::Zero();
  double distance_m = 0.0;
};

struct DeconflictionResult {
  std::vector<PlanResult> plans;  // one per query, in the queries' order
  std::vector<int> replans;       // replans per robot
  std::vector<Conflict> conflicts;  // left unresolved
  bool conflict_free() const { return conflicts.empty(); }
};

class Deconflicter {
 public:
  using Config = DeconflictionConfig;
  Deconflicter(const Config& config, const PathPlannerConfig& planner_config, core::Logger logger = core::null_logger());

  // Committed paths come before every query in priority; a conflict with one names its robot as robot_a.
  DeconflictionResult plan(const OccupancyGrid& grid, const std::vector<RobotQuery>& queries_by_priority,
                           const std::vector<CommittedPath>& committed = {}) const;

  const Config& config() const { return config_; }

 private:
  Config config_;
  PathPlanner planner_;
  core::Logger logger_;
};

// When a robot following a path is where: it reaches pose i at arrive_s[i] and leaves it at depart_s[i]
// (later after a turn on the spot), from t = 0 at the path's start.
struct PathSchedule {
  std::vector<double> arrive_s;
  std::vector<double> depart_s;
  double end_s() const { return arrive_s.empty() ? 0.0 : arrive_s.back(); }
};

// The schedule of a path driven as the header says, by a robot that starts facing start_yaw_rad: segment i
// takes its length / speed_m_per_s, or |heading change| / yaw_rate_radps when that is longer (the turn is
// driven through), and a heading change beyond turn_on_spot_deg is turned at the segment's start first.
// Segments without length are crossed in no time and change no heading.
PathSchedule schedule_path(const std::vector<Pose2d>& path_world, double start_yaw_rad, const DeconflictionConfig& config);

// Position on a scheduled path at t_s (its start before 0, its end after end_s()); `fallback` when the
// path is empty.
Eigen::Vector2d position_at(const std::vector<Pose2d>& path_world, const PathSchedule& schedule, double t_s,
                            const Eigen::Vector2d& fallback);

}  // namespace fleetslam::planners
