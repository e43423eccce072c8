// Pass criteria against a run's metrics (criteria.hpp).

#include "fleetslam/runner/criteria.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>

namespace fleetslam::runner {
namespace {

// metrics[path...] as a finite number, or nullopt.
std::optional<double> number_at(const nlohmann::json& j, std::initializer_list<const char*> path) {
  const nlohmann::json* node = &j;
  for (const char* key : path) {
    if (!node->is_object() || !node->contains(key)) return std::nullopt;
    node = &(*node)[key];
  }
  if (!node->is_number()) return std::nullopt;
  const double value = node->get<double>();
  return std::isfinite(value) ? std::optional<double>(value) : std::nullopt;
}

// The largest of metrics[key], an array of finite numbers; nullopt when it is missing, empty or holds
// anything else.
std::optional<double> largest_number(const nlohmann::json& j, const char* key) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_array() || j[key].empty()) return std::nullopt;
  double largest = -std::numeric_limits<double>::infinity();
  for (const nlohmann::json& value : j[key]) {
    if (!value.is_number() || !std::isfinite(value.get<double>())) return std::nullopt;
    largest = std::max(largest, value.get<double>());
  }
  return largest;
}

class Verdict {
 public:
  void add(const std::string& name, const std::string& robot, std::optional<double> value, double limit, bool at_most,
           std::string note = "") {
    const bool ok = value && (at_most ? *value <= limit : *value >= limit);
    if (!value && note.empty()) note = "not measured";
    criteria_.push_back({{"name", name}, {"robot", robot}, {"value", value ? nlohmann::json(*value) : nlohmann::json()},
                         {"limit", limit}, {"comparison", at_most ? "<=" : ">="}, {"passed", ok}, {"note", note}});
    passed_ = passed_ && ok;
  }
  nlohmann::json json() const { return {{"passed", passed_}, {"criteria", criteria_}}; }

 private:
  nlohmann::json criteria_ = nlohmann::json::array();
  bool passed_ = true;
};

}  // namespace

nlohmann::json judge(const CriteriaConfig& c, const nlohmann::json& metrics) {
  Verdict verdict;
  const nlohmann::json robots =
      metrics.is_object() && metrics.contains("robots") && metrics["robots"].is_array() ? metrics["robots"] : nlohmann::json::array();
  // Per-robot criteria with no robot to judge fail (they would otherwise add nothing and pass).
  const bool per_robot = c.max_ate_m >= 0.0 || c.max_lost_share >= 0.0 || c.no_collisions || c.goals_reached ||
                         c.max_goal_true_distance_m >= 0.0;
  if (per_robot && robots.empty()) verdict.add("robots", "", std::nullopt, 1.0, false, "no robots to judge");
  for (const nlohmann::json& robot : robots) {
    const auto name_field = robot.find("name");
    const std::string name =
        name_field != robot.end() && name_field->is_string() ? name_field->get_ref<const std::string&>() : "?";
    if (c.max_ate_m >= 0.0) {
      verdict.add("ate_world_rmse_m", name, number_at(robot, {"ate_world_m", "rmse"}), c.max_ate_m, true,
                  robot.contains("ate_world_m") ? "" : "no estimated trajectory to judge");
    }
    if (c.max_lost_share >= 0.0) {
      // Every frame without a pose counts: lost ones, and those before a map was started or rejected.
      const std::optional<double> frames = number_at(robot, {"frames"});
      const std::optional<double> tracked = number_at(robot, {"tracked"});
      std::optional<double> share;
      if (frames && tracked && *frames > 0 && *tracked >= 0.0 && *tracked <= *frames) share = (*frames - *tracked) / *frames;
      verdict.add("lost_share", name, share, c.max_lost_share, true, share ? "" : "no frames");
    }
    if (c.no_collisions) verdict.add("collisions", name, number_at(robot, {"collisions"}), 0.0, true);
    const auto planned = robot.find("planned");
    const bool is_planned = planned != robot.end() && planned->is_boolean() && *planned == true;
    const std::optional<double> total = number_at(robot, {"goals_total"});
    if (c.goals_reached && is_planned) {
      const std::optional<double> reached = number_at(robot, {"goals_reached"});
      std::optional<double> share;
      if (total && reached) share = *total > 0 ? *reached / *total : 1.0;
      std::string note;
      if (total && reached) note = std::to_string(static_cast<long>(*reached)) + " of " + std::to_string(static_cast<long>(*total));
      // Vacuous (exploration may leave a robot no frontier), but said: coverage and lost_share judge the rest.
      if (total && *total == 0.0) note = "no goals given";
      verdict.add("goals_reached_share", name, share, 1.0, false, note);
    }
    if (c.max_goal_true_distance_m >= 0.0 && is_planned) {
      // The mission counts a goal reached from the robot's estimate; the true body's distance judges that.
      std::optional<double> farthest = largest_number(robot, "goals_reached_true_distance_m");
      const auto list = robot.find("goals_reached_true_distance_m");
      const bool empty_list = list != robot.end() && list->is_array() && list->empty();
      std::string note;
      if (empty_list && total && *total == 0.0) {
        farthest = 0.0;  // vacuous, as above
        note = "no goals given";
      } else if (empty_list) {
        note = "no goal reached";
      }
      verdict.add("goal_true_distance_m", name, farthest, c.max_goal_true_distance_m, true, note);
    }
  }
  // Goal criteria on a run with robots but none planned (a scripted mission) judge nothing: said, and failed.
  const bool goal_criteria = c.goals_reached || c.max_goal_true_distance_m >= 0.0;
  const bool any_planned = std::any_of(robots.begin(), robots.end(), [](const nlohmann::json& robot) {
    const auto planned = robot.find("planned");
    return planned != robot.end() && planned->is_boolean() && *planned == true;
  });
  if (goal_criteria && !robots.empty() && !any_planned) {
    verdict.add("goals", "", std::nullopt, 1.0, false, "no robot's path is planned: no goals to judge");
  }
  const std::optional<double> map_points = number_at(metrics, {"merged_map_accuracy", "map_points"});
  const std::string map_note = map_points && *map_points == 0.0 ? "the merged map is empty" : "";
  if (c.max_map_accuracy_mean_m >= 0.0) {
    verdict.add("map_accuracy_mean_m", "", number_at(metrics, {"merged_map_accuracy", "mean_m"}), c.max_map_accuracy_mean_m,
                true, map_note);
  }
  if (c.max_map_accuracy_p95_m >= 0.0) {
    verdict.add("map_accuracy_p95_m", "", number_at(metrics, {"merged_map_accuracy", "p95_m"}), c.max_map_accuracy_p95_m,
                true, map_note);
  }
  if (c.min_map_completeness >= 0.0) {
    verdict.add("map_completeness", "", number_at(metrics, {"merged_map_accuracy", "completeness"}), c.min_map_completeness, false);
  }
  if (c.min_coverage >= 0.0) verdict.add("coverage", "", number_at(metrics, {"coverage", "final"}), c.min_coverage, false);
  if (c.min_real_time_factor >= 0.0) {
    verdict.add("real_time_factor", "", number_at(metrics, {"real_time_factor"}), c.min_real_time_factor, false);
  }
  return verdict.json();
}

}  // namespace fleetslam::runner
