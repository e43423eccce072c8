#include "fleetslam/planners/planner.hpp"

#include <atomic>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <queue>
#include <string>
#include <utility>

#include <ompl/base/ProblemDefinition.h>
#include <ompl/base/SpaceInformation.h>
#include <ompl/base/goals/GoalSampleableRegion.h>
#include <ompl/base/objectives/PathLengthOptimizationObjective.h>
#include <ompl/base/spaces/SE2StateSpace.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/PathSimplifier.h>
#include <ompl/geometric/planners/prm/PRMstar.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>
#include <ompl/geometric/planners/rrt/RRTstar.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>
#include <spdlog/spdlog.h>

#include "curve_state_spaces.hpp"
#include "fleetslam/core/error.hpp"

namespace fleetslam::planners {
namespace ob = ompl::base;
namespace og = ompl::geometric;

namespace {

constexpr double kPi = 3.14159265358979323846;

// OMPL's seed generator and console handler are process-wide; every plan holds this lock.
std::mutex& ompl_global_mutex() {
  static std::mutex mutex;
  return mutex;
}

// Sends OMPL's console messages to the planner's logger while installed (restores the previous handler).
class LoggerOutputHandler : public ompl::msg::OutputHandler {
 public:
  explicit LoggerOutputHandler(core::Logger logger) : logger_(std::move(logger)), previous_(ompl::msg::getOutputHandler()) {
    ompl::msg::useOutputHandler(this);
  }
  ~LoggerOutputHandler() override { ompl::msg::useOutputHandler(previous_); }
  LoggerOutputHandler(const LoggerOutputHandler&) = delete;
  LoggerOutputHandler& operator=(const LoggerOutputHandler&) = delete;

  void log(const std::string& text, ompl::msg::LogLevel level, const char*, int) override {
    if (!logger_) return;
    if (level >= ompl::msg::LOG_WARN) {
      logger_->debug("ompl warning: {}", text);
    } else {
      logger_->trace("ompl: {}", text);
    }
  }

 private:
  core::Logger logger_;
  ompl::msg::OutputHandler* previous_;
};

// Validity of a robot-centre position: traversable in the grid and outside every blocked disk.
struct PositionCheck {
  const OccupancyGrid* grid;
  UnknownCells unknown;
  const std::vector<Disk>* blocked;

  bool operator()(const Eigen::Vector2d& p) const {
    if (!grid->traversable(p, unknown)) return false;
    for (const Disk& d : *blocked) {
      if ((p - d.center_world).squaredNorm() < d.radius_m * d.radius_m) return false;
    }
    return true;
  }
};

// Goal: a disc in xy with any heading; sampled headings come from the goal's own seeded generator.
class XyGoal : public ob::GoalSampleableRegion {
 public:
  XyGoal(const ob::SpaceInformationPtr& si, Eigen::Vector2d goal_world, double tolerance_m)
      : ob::GoalSampleableRegion(si), goal_world_(std::move(goal_world)) {
    setThreshold(tolerance_m);
  }
  double distanceGoal(const ob::State* st) const override {
    const auto* s = st->as<ob::SE2StateSpace::StateType>();
    return std::hypot(s->getX() - goal_world_.x(), s->getY() - goal_world_.y());
  }
  void sampleGoal(ob::State* st) const override {
    auto* s = st->as<ob::SE2StateSpace::StateType>();
    s->setXY(goal_world_.x(), goal_world_.y());
    s->setYaw(rng_.uniformReal(-kPi, kPi));
  }
  unsigned int maxSampleCount() const override { return std::numeric_limits<unsigned int>::max(); }

 private:
  Eigen::Vector2d goal_world_;
  mutable ompl::RNG rng_;
};

ob::StateSpacePtr make_space(const PathPlannerConfig& config, const OccupancyGrid& grid) {
  ob::StateSpacePtr space;
  switch (config.state_space) {
    case StateSpaceKind::kSe2: space = std::make_shared<ob::SE2StateSpace>(); break;
    case StateSpaceKind::kDubins: space = std::make_shared<CurveCheckedDubins>(config.turning_radius_m); break;
    case StateSpaceKind::kReedsShepp: space = std::make_shared<CurveCheckedReedsShepp>(config.turning_radius_m); break;
  }
  ob::RealVectorBounds bounds(2);
  const Eigen::Vector2d lo = grid.origin_world();
  const Eigen::Vector2d hi = lo + grid.resolution_m() * Eigen::Vector2d(grid.width(), grid.height());
  bounds.setLow(0, lo.x());
  bounds.setLow(1, lo.y());
  bounds.setHigh(0, hi.x());
  bounds.setHigh(1, hi.y());
  space->as<ob::SE2StateSpace>()->setBounds(bounds);
  return space;
}

ob::PlannerPtr make_planner(const PathPlannerConfig& config, const ob::SpaceInformationPtr& si) {
  switch (config.planner) {
    case PlannerAlgorithm::kRrtStar: return std::make_shared<og::RRTstar>(si);
    case PlannerAlgorithm::kPrmStar: return std::make_shared<og::PRMstar>(si);
    case PlannerAlgorithm::kRrtConnect: return std::make_shared<og::RRTConnect>(si);
  }
  return nullptr;
}

// 8-connected flood fill over valid cell centres from start's cell; true when goal's cell is reached.
bool reachable(const OccupancyGrid& grid, const PositionCheck& valid, const Eigen::Vector2d& start,
               const Eigen::Vector2d& goal) {
  const std::optional<CellIndex> s = grid.cell_of(start);
  const std::optional<CellIndex> g = grid.cell_of(goal);
  if (!s || !g) return false;
  std::vector<std::uint8_t> seen(static_cast<std::size_t>(grid.width()) * static_cast<std::size_t>(grid.height()), 0);
  std::queue<CellIndex> open;
  open.push(*s);
  seen[grid.index(*s)] = 1;
  while (!open.empty()) {
    const CellIndex c = open.front();
    open.pop();
    if (c == *g) return true;
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const CellIndex n{c.x + dx, c.y + dy};
        if (!grid.contains(n) || seen[grid.index(n)] != 0) continue;
        seen[grid.index(n)] = 1;
        if (n == *g || valid(grid.center_of(n))) open.push(n);
      }
    }
  }
  return false;
}

// The valid cell centre nearest `goal` within radius_m (first in scan order on ties).
std::optional<Eigen::Vector2d> snap_goal(const OccupancyGrid& grid, const PositionCheck& valid,
                                         const Eigen::Vector2d& goal, double radius_m) {
  return nearest_cell_centre(grid, goal, radius_m, [&valid](const Eigen::Vector2d& c) { return valid(c); });
}

double xy_length(const std::vector<Pose2d>& path) {
  double length = 0.0;
  for (std::size_t i = 1; i < path.size(); ++i) length += (path[i].xy() - path[i - 1].xy()).norm();
  return length;
}

// SE(2): the vertices' polyline resampled every step_m, heading = direction of travel (start keeps its yaw).
std::vector<Pose2d> resample_polyline(const std::vector<Eigen::Vector2d>& vertices, const Pose2d& start,
                                      double step_m) {
  std::vector<Pose2d> out{start};
  for (std::size_t i = 1; i < vertices.size(); ++i) {
    const Eigen::Vector2d a = vertices[i - 1];
    const Eigen::Vector2d b = vertices[i];
    const double length = (b - a).norm();
    if (length <= 0.0) continue;
    const double yaw = std::atan2(b.y() - a.y(), b.x() - a.x());
    const int steps = std::max(1, static_cast<int>(std::ceil(length / step_m)));
    for (int k = 1; k <= steps; ++k) {
      const Eigen::Vector2d p = a + (b - a) * (static_cast<double>(k) / steps);
      out.push_back({p.x(), p.y(), yaw});
    }
  }
  return out;
}

std::vector<Pose2d> to_poses(og::PathGeometric path, const PathPlannerConfig& config, const Pose2d& start) {
  const auto xy_of = [](const ob::State* st) {
    const auto* s = st->as<ob::SE2StateSpace::StateType>();
    return Eigen::Vector2d(s->getX(), s->getY());
  };
  if (config.state_space == StateSpaceKind::kSe2) {
    std::vector<Eigen::Vector2d> vertices;
    for (std::size_t i = 0; i < path.getStateCount(); ++i) vertices.push_back(xy_of(path.getState(i)));
    return resample_polyline(vertices, start, config.path_step_m);
  }
  // Curves: OMPL interpolates along them (states a fifth of a step apart), then every step_m is kept.
  path.interpolate(static_cast<unsigned int>(std::ceil(path.length() / (0.2 * config.path_step_m))) + 2);
  std::vector<Pose2d> dense;
  for (std::size_t i = 0; i < path.getStateCount(); ++i) {
    const auto* s = path.getState(i)->as<ob::SE2StateSpace::StateType>();
    dense.push_back({s->getX(), s->getY(), s->getYaw()});
  }
  std::vector<Pose2d> out{dense.front()};
  double since_last = 0.0;
  for (std::size_t i = 1; i < dense.size(); ++i) {
    since_last += (dense[i].xy() - dense[i - 1].xy()).norm();
    if (since_last >= config.path_step_m || i + 1 == dense.size()) {
      out.push_back(dense[i]);
      since_last = 0.0;
    }
  }
  return out;
}

// Moves the interior poses away from obstacles towards preferred_m of clearance where the space allows,
// the ends kept: each pose climbs the grid's clearance field (half a cell a step, at most 8 steps a round,
// while the clearance does not fall), then the polyline is smoothed once (each interior pose halfway
// to its neighbours' mean), three rounds; yaws follow the new polyline. Written here because OMPL's
// simplifier only shortens: shortcuts graze the inflated obstacles, and through the apartment's 1 m
// doorways a path ran 2-3 cm inside the inflation's edge, where a controller's few centimetres of
// tracking error put the robot's side on the jamb.
std::vector<Pose2d> keep_clear(const OccupancyGrid& grid, std::vector<Pose2d> path, UnknownCells unknown,
                               double preferred_m) {
  if (path.size() < 3 || !(preferred_m > 0.0)) return path;
  const double cell_m = grid.config().resolution_m;
  const auto clearance_at = [&](const Eigen::Vector2d& p) {
    const std::optional<CellIndex> cell = grid.cell_of(p);
    return cell ? grid.clearance_m(*cell, unknown) : 0.0;
  };
  std::vector<Eigen::Vector2d> xy(path.size());
  for (std::size_t i = 0; i < path.size(); ++i) xy[i] = path[i].xy();
  for (int round = 0; round < 3; ++round) {
    for (std::size_t i = 1; i + 1 < xy.size(); ++i) {
      Eigen::Vector2d& p = xy[i];
      for (int step = 0; step < 8; ++step) {
        const double c = clearance_at(p);
        if (!(c < preferred_m) || !std::isfinite(c)) break;
        const Eigen::Vector2d dx(cell_m, 0.0), dy(0.0, cell_m);
        const Eigen::Vector2d gradient(clearance_at(p + dx) - clearance_at(p - dx), clearance_at(p + dy) - clearance_at(p - dy));
        if (!(gradient.norm() > 0.0) || !gradient.allFinite()) break;
        const Eigen::Vector2d next = p + 0.5 * cell_m * gradient.normalized();
        if (clearance_at(next) < c) break;
        p = next;
      }
    }
    std::vector<Eigen::Vector2d> smoothed = xy;
    for (std::size_t i = 1; i + 1 < xy.size(); ++i) smoothed[i] = 0.5 * xy[i] + 0.25 * (xy[i - 1] + xy[i + 1]);
    xy.swap(smoothed);
  }
  for (std::size_t i = 1; i + 1 < path.size(); ++i) {
    path[i].x_m = xy[i].x();
    path[i].y_m = xy[i].y();
    const Eigen::Vector2d ahead = xy[i + 1] - xy[i - 1];
    if (ahead.norm() > 1e-9) path[i].yaw_rad = std::atan2(ahead.y(), ahead.x());
  }
  return path;
}

}  // namespace

const char* to_string(PlanStatus status) {
  switch (status) {
    case PlanStatus::kSolved: return "solved";
    case PlanStatus::kApproximate: return "approximate";
    case PlanStatus::kNoPath: return "no_path";
    case PlanStatus::kStartInvalid: return "start_invalid";
    case PlanStatus::kGoalInvalid: return "goal_invalid";
  }
  return "unknown";
}

PathPlanner::PathPlanner(const Config& config, core::Logger logger) : config_(config), logger_(std::move(logger)) {
  if (config_.seed <= 0) throw InputError("planner.seed", "must be positive (OMPL ignores 0)");
  if (!(config_.path_step_m > 0.0)) throw InputError("planner.path_step_m", "must be positive");
  if (!(config_.goal_tolerance_m > 0.0)) throw InputError("planner.goal_tolerance_m", "must be positive");
  if (!logger_) logger_ = core::null_logger();
}

PlanResult PathPlanner::plan(const OccupancyGrid& grid, const Pose2d& start_world, const Eigen::Vector2d& goal_world,
                             const std::vector<Disk>& blocked) const {
  PlanResult result;
  result.goal_world = goal_world;
  const PositionCheck valid{&grid, config_.unknown_cells, &blocked};
  if (!std::isfinite(start_world.yaw_rad) || !valid(start_world.xy())) {
    result.status = PlanStatus::kStartInvalid;
    return result;
  }
  if (!valid(goal_world)) {
    const std::optional<Eigen::Vector2d> snapped =
        config_.goal_snap_radius_m > 0.0 && goal_world.allFinite()
            ? snap_goal(grid, valid, goal_world, config_.goal_snap_radius_m)
            : std::nullopt;
    if (!snapped) {
      result.status = PlanStatus::kGoalInvalid;
      return result;
    }
    result.goal_world = *snapped;
  }
  if (config_.check_reachability && !reachable(grid, valid, start_world.xy(), result.goal_world)) {
    result.status = PlanStatus::kNoPath;
    logger_->debug("planner: goal ({:.2f}, {:.2f}) not reachable in the grid", result.goal_world.x(),
                   result.goal_world.y());
    return result;
  }

  std::lock_guard<std::mutex> lock(ompl_global_mutex());
  LoggerOutputHandler output(logger_);
  ompl::RNG::setSeed(static_cast<std::uint_fast32_t>(config_.seed));

  const ob::StateSpacePtr space = make_space(config_, grid);
  auto si = std::make_shared<ob::SpaceInformation>(space);
  si->setStateValidityChecker([valid](const ob::State* st) {
    const auto* s = st->as<ob::SE2StateSpace::StateType>();
    return valid(Eigen::Vector2d(s->getX(), s->getY()));
  });
  si->setStateValidityCheckingResolution(0.5 * grid.resolution_m() / space->getMaximumExtent());
  si->setup();

  ob::ScopedState<ob::SE2StateSpace> start(space);
  start->setXY(start_world.x_m, start_world.y_m);
  // SO(2) bounds are [-pi, pi) in practice: a yaw of exactly pi (a robot facing -x) fails OMPL's bounds
  // check and the start is rejected silently, so the yaw is wrapped into [-pi, pi).
  start->setYaw(std::remainder(start_world.yaw_rad, 2.0 * kPi) >= kPi ? -kPi
                                                                          : std::remainder(start_world.yaw_rad, 2.0 * kPi));
  auto pdef = std::make_shared<ob::ProblemDefinition>(si);
  pdef->addStartState(start);
  pdef->setGoal(std::make_shared<XyGoal>(si, result.goal_world, config_.goal_tolerance_m));
  pdef->setOptimizationObjective(std::make_shared<ob::PathLengthOptimizationObjective>(si));

  const ob::PlannerPtr planner = make_planner(config_, si);
  planner->setProblemDefinition(pdef);
  planner->setup();

  std::atomic<int> calls{0};
  const int max_iterations = config_.max_iterations;
  ob::PlannerTerminationCondition ptc([&calls, max_iterations] { return ++calls > max_iterations; });
  if (config_.stop_at_first_solution) ptc = ob::plannerOrTerminationCondition(ptc, ob::exactSolnPlannerTerminationCondition(pdef));
  if (config_.time_limit_s > 0.0) ptc = ob::plannerOrTerminationCondition(ptc, ob::timedPlannerTerminationCondition(config_.time_limit_s));
  const ob::PlannerStatus status = planner->solve(ptc);
  result.iterations = std::min(calls.load(), max_iterations);

  if (status != ob::PlannerStatus::EXACT_SOLUTION && status != ob::PlannerStatus::APPROXIMATE_SOLUTION) {
    result.status = PlanStatus::kNoPath;
    logger_->debug("planner: no path after {} iterations ({})", result.iterations, status.asString());
    return result;
  }
  og::PathGeometric path = *pdef->getSolutionPath()->as<og::PathGeometric>();
  // RRTConnect's approximate solutions may lie in the goal tree (not starting at the start): not a path.
  const auto* first = path.getState(0)->as<ob::SE2StateSpace::StateType>();
  if (std::hypot(first->getX() - start_world.x_m, first->getY() - start_world.y_m) > 1e-9) {
    result.status = PlanStatus::kNoPath;
    logger_->debug("planner: approximate solution does not start at the start; no path");
    return result;
  }
  const og::PathGeometric raw = path;
  if (config_.simplify) {
    og::PathSimplifier simplifier(si, pdef->getGoal());
    simplifier.simplifyMax(path);
  }
  result.path_world = to_poses(path, config_, start_world);
  // The returned poses are checked again (curves are sampled more finely here than OMPL's motion checks):
  // a simplified path that fails falls back to the raw one, a raw one that fails is no path.
  if (first_blocked_pose(grid, result.path_world, config_.unknown_cells, blocked) >= 0 && config_.simplify) {
    logger_->debug("planner: simplified path touches an obstacle; using the raw path");
    result.path_world = to_poses(raw, config_, start_world);
  }
  if (config_.preferred_clearance_m > 0.0 && config_.state_space == StateSpaceKind::kSe2) {
    // Kept away from obstacles where it can be; a path that this makes touch anything stays as it was.
    // Not a Dubins or Reeds-Shepp path: moved, its poses would leave the turning-radius curves, and yaws
    // set along the polyline would turn a reverse segment's round.
    std::vector<Pose2d> clear = keep_clear(grid, result.path_world, config_.unknown_cells, config_.preferred_clearance_m);
    if (first_blocked_pose(grid, clear, config_.unknown_cells, blocked) < 0) result.path_world = std::move(clear);
  }
  if (first_blocked_pose(grid, result.path_world, config_.unknown_cells, blocked) >= 0) {
    logger_->debug("planner: the path found touches an obstacle between OMPL's checks; no path");
    result.path_world.clear();
    result.status = PlanStatus::kNoPath;
    return result;
  }
  result.length_m = xy_length(result.path_world);
  result.distance_to_goal_m = (result.path_world.back().xy() - result.goal_world).norm();
  result.status = status == ob::PlannerStatus::EXACT_SOLUTION ? PlanStatus::kSolved : PlanStatus::kApproximate;
  logger_->debug("planner: {} after {} iterations, {:.2f} m", to_string(result.status), result.iterations,
                 result.length_m);
  return result;
}

int first_blocked_pose(const OccupancyGrid& grid, const std::vector<Pose2d>& path_world, UnknownCells unknown,
                       const std::vector<Disk>& blocked) {
  const PositionCheck valid{&grid, unknown, &blocked};
  const double step = 0.5 * grid.resolution_m();
  for (std::size_t i = 0; i < path_world.size(); ++i) {
    if (!valid(path_world[i].xy())) return static_cast<int>(i);
    if (i + 1 == path_world.size()) break;
    const Eigen::Vector2d a = path_world[i].xy();
    const Eigen::Vector2d b = path_world[i + 1].xy();
    const int steps = static_cast<int>(std::ceil((b - a).norm() / step));
    for (int k = 1; k < steps; ++k) {
      if (!valid(a + (b - a) * (static_cast<double>(k) / steps))) return static_cast<int>(i + 1);
    }
  }
  return -1;
}

}  // namespace fleetslam::planners
