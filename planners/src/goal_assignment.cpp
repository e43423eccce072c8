#include "fleetslam/planners/goal_assignment.hpp"

#include <cmath>
#include <limits>
#include <string>

#include "fleetslam/core/error.hpp"

namespace fleetslam::planners {

GoalAssignment GoalAssigner::assign(const std::vector<Eigen::Vector2d>& robots_world,
                                    const std::vector<Eigen::Vector2d>& goals_world, const OccupancyGrid* grid,
                                    const std::vector<double>& gains_m2) const {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  if (config_.cost == AssignmentCost::kGridPath && grid == nullptr) {
    throw InputError("goal_assignment.cost", "grid_path needs an occupancy grid");
  }
  if (!gains_m2.empty() && gains_m2.size() != goals_world.size()) {
    throw InputError("goal assignment", "gains: " + std::to_string(gains_m2.size()) + " for " +
                                            std::to_string(goals_world.size()) + " goals");
  }
  for (double gain : gains_m2) {
    if (!(std::isfinite(gain) && gain >= 0.0)) throw InputError("goal assignment", "a gain is negative or not finite");
  }
  const std::size_t nr = robots_world.size();
  const std::size_t ng = goals_world.size();
  std::vector<std::vector<double>> travel(nr, std::vector<double>(ng, kInf));
  for (std::size_t r = 0; r < nr; ++r) {
    if (config_.cost == AssignmentCost::kStraightLine) {
      for (std::size_t g = 0; g < ng; ++g) travel[r][g] = (goals_world[g] - robots_world[r]).norm();
      continue;
    }
    const std::vector<double> field = grid->geodesic_distances_m(robots_world[r], config_.unknown_cells);
    for (std::size_t g = 0; g < ng; ++g) {
      const auto cell = grid->cell_of(goals_world[g]);
      if (cell) travel[r][g] = field[grid->index(*cell)];
    }
  }
  GoalAssignment out;
  out.goal_of_robot.assign(nr, -1);
  out.cost_m.assign(nr, kInf);
  std::vector<bool> goal_taken(ng, false);
  std::vector<Eigen::Vector2d> assigned;
  for (std::size_t round = 0; round < nr; ++round) {
    double best = kInf;
    int best_r = -1, best_g = -1;
    for (std::size_t r = 0; r < nr; ++r) {
      if (out.goal_of_robot[r] >= 0) continue;
      for (std::size_t g = 0; g < ng; ++g) {
        if (goal_taken[g] || !std::isfinite(travel[r][g])) continue;
        double penalty = 0.0;
        bool same = false;
        for (const Eigen::Vector2d& a : assigned) {
          const double d = (a - goals_world[g]).norm();
          same = same || d <= config_.same_goal_m;
          if (d < config_.separation_m) penalty += config_.separation_penalty_m * (1.0 - d / config_.separation_m);
        }
        if (same) continue;
        const double gain = gains_m2.empty() ? 0.0 : config_.gain_weight_m_per_m2 * gains_m2[g];
        const double cost = travel[r][g] + penalty - gain;
        if (cost < best) {
          best = cost;
          best_r = static_cast<int>(r);
          best_g = static_cast<int>(g);
        }
      }
    }
    if (best_r < 0) break;
    out.goal_of_robot[static_cast<std::size_t>(best_r)] = best_g;
    out.cost_m[static_cast<std::size_t>(best_r)] = travel[static_cast<std::size_t>(best_r)][static_cast<std::size_t>(best_g)];
    goal_taken[static_cast<std::size_t>(best_g)] = true;
    assigned.push_back(goals_world[static_cast<std::size_t>(best_g)]);
  }
  return out;
}

std::vector<Eigen::Vector2d> frontier_goals(const std::vector<Frontier>& frontiers) {
  std::vector<Eigen::Vector2d> goals;
  for (const Frontier& f : frontiers) {
    if (f.has_goal) goals.push_back(f.goal_world);
  }
  return goals;
}

}  // namespace fleetslam::planners
