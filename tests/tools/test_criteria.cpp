// Pass criteria against metrics: each criterion on its own, disabled ones absent, and values that were
// not measured failing with a note (never a silent pass).

#include <gtest/gtest.h>

#include <limits>

#include <nlohmann/json.hpp>

#include "fleetslam/runner/criteria.hpp"

namespace fleetslam::runner {
namespace {

nlohmann::json metrics() {
  return {{"robots",
           {{{"name", "a"}, {"frames", 100}, {"tracked", 98}, {"lost", 2}, {"collisions", 0}, {"planned", true}, {"goals_total", 4},
             {"goals_reached", 4}, {"ate_world_m", {{"rmse", 0.01}}}},
            {{"name", "b"}, {"frames", 100}, {"tracked", 90}, {"lost", 10}, {"collisions", 1}, {"planned", true}, {"goals_total", 4},
             {"goals_reached", 3}, {"ate_world_m", {{"rmse", 0.03}}}}}},
          {"merged_map_accuracy", {{"mean_m", 0.012}, {"p95_m", 0.04}, {"completeness", 0.4}}},
          {"coverage", {{"final", 0.7}}},
          {"real_time_factor", 0.3}};
}

const nlohmann::json* find(const nlohmann::json& verdict, const std::string& name, const std::string& robot) {
  for (const nlohmann::json& c : verdict["criteria"]) {
    if (c["name"] == name && c["robot"] == robot) return &c;
  }
  return nullptr;
}

TEST(Criteria, NoneEnabledPasses) {
  const nlohmann::json v = judge(CriteriaConfig{}, metrics());
  EXPECT_TRUE(v["passed"].get<bool>());
  EXPECT_TRUE(v["criteria"].empty());
}

TEST(Criteria, EachCriterionJudgesItsValue) {
  CriteriaConfig c;
  c.max_ate_m = 0.02;
  c.max_lost_share = 0.05;
  c.no_collisions = true;
  c.goals_reached = true;
  c.max_map_accuracy_mean_m = 0.02;
  c.max_map_accuracy_p95_m = 0.03;
  c.min_map_completeness = 0.3;
  c.min_coverage = 0.8;
  c.min_real_time_factor = 0.2;
  const nlohmann::json v = judge(c, metrics());
  EXPECT_FALSE(v["passed"].get<bool>());
  EXPECT_EQ(v["criteria"].size(), 4u * 2u + 5u);
  const auto passed = [&](const char* name, const char* robot) {
    const nlohmann::json* j = find(v, name, robot);
    EXPECT_NE(j, nullptr) << name << " " << robot;
    return j != nullptr && (*j)["passed"].get<bool>();
  };
  EXPECT_TRUE(passed("ate_world_rmse_m", "a"));
  EXPECT_FALSE(passed("ate_world_rmse_m", "b"));
  EXPECT_TRUE(passed("lost_share", "a"));
  EXPECT_FALSE(passed("lost_share", "b"));
  EXPECT_TRUE(passed("collisions", "a"));
  EXPECT_FALSE(passed("collisions", "b"));
  EXPECT_TRUE(passed("goals_reached_share", "a"));
  EXPECT_FALSE(passed("goals_reached_share", "b"));
  EXPECT_EQ((*find(v, "goals_reached_share", "b"))["note"], "3 of 4");
  // A planned robot given no goal passes vacuously, and the note says so.
  nlohmann::json no_goals = metrics();
  no_goals["robots"][0]["goals_total"] = 0;
  no_goals["robots"][0]["goals_reached"] = 0;
  const nlohmann::json no_goals_verdict = judge(c, no_goals);
  const nlohmann::json* vacuous = find(no_goals_verdict, "goals_reached_share", "a");
  ASSERT_NE(vacuous, nullptr);
  EXPECT_TRUE((*vacuous)["passed"].get<bool>());
  EXPECT_EQ((*vacuous)["note"], "no goals given");
  EXPECT_TRUE(passed("map_accuracy_mean_m", ""));
  EXPECT_FALSE(passed("map_accuracy_p95_m", ""));
  EXPECT_TRUE(passed("map_completeness", ""));
  EXPECT_FALSE(passed("coverage", ""));
  EXPECT_TRUE(passed("real_time_factor", ""));
  EXPECT_EQ((*find(v, "coverage", ""))["comparison"], ">=");
  EXPECT_EQ((*find(v, "collisions", "b"))["comparison"], "<=");
  // At the limit passes.
  c = CriteriaConfig{};
  c.max_ate_m = 0.03;
  EXPECT_TRUE(judge(c, metrics())["passed"].get<bool>());
}

// The truth judges the mission's "reached": the largest true distance over a robot's reached goals.
TEST(Criteria, GoalTrueDistanceJudgesTheFarthestReachedGoal) {
  nlohmann::json m = metrics();
  m["robots"][0]["goals_reached_true_distance_m"] = {0.1, 0.31, 0.2, 0.05};
  m["robots"][1]["goals_reached_true_distance_m"] = {0.1, 0.2, 0.3};
  CriteriaConfig c;
  c.max_goal_true_distance_m = 0.3;
  nlohmann::json v = judge(c, m);
  ASSERT_EQ(v["criteria"].size(), 2u);
  const nlohmann::json* a = find(v, "goal_true_distance_m", "a");
  ASSERT_NE(a, nullptr);
  EXPECT_FALSE((*a)["passed"].get<bool>());
  EXPECT_DOUBLE_EQ((*a)["value"].get<double>(), 0.31);
  EXPECT_EQ((*a)["comparison"], "<=");
  const nlohmann::json* b = find(v, "goal_true_distance_m", "b");
  ASSERT_NE(b, nullptr);
  EXPECT_TRUE((*b)["passed"].get<bool>());  // at the limit
  EXPECT_FALSE(v["passed"].get<bool>());
  // No goal reached: nothing to judge, a failure with a note; no goals given: vacuous, said.
  m["robots"][0]["goals_reached_true_distance_m"] = nlohmann::json::array();
  a = find(v = judge(c, m), "goal_true_distance_m", "a");
  ASSERT_NE(a, nullptr);
  EXPECT_FALSE((*a)["passed"].get<bool>());
  EXPECT_TRUE((*a)["value"].is_null());
  EXPECT_EQ((*a)["note"], "no goal reached");
  m["robots"][0]["goals_total"] = 0;
  a = find(v = judge(c, m), "goal_true_distance_m", "a");
  ASSERT_NE(a, nullptr);
  EXPECT_TRUE((*a)["passed"].get<bool>());
  EXPECT_EQ((*a)["note"], "no goals given");
  // A missing or malformed list is not measured; a robot that is not planned is not judged.
  m["robots"][0]["goals_total"] = 4;
  m["robots"][0].erase("goals_reached_true_distance_m");
  m["robots"][1]["goals_reached_true_distance_m"] = {0.1, "far"};
  v = judge(c, m);
  EXPECT_EQ((*find(v, "goal_true_distance_m", "a"))["note"], "not measured");
  EXPECT_TRUE((*find(v, "goal_true_distance_m", "b"))["value"].is_null());
  // The vacuous pass needs an empty list: a malformed one with no goals given is still not measured.
  m["robots"][1]["goals_total"] = 0;
  EXPECT_TRUE((*find(judge(c, m), "goal_true_distance_m", "b"))["value"].is_null());
  m["robots"][1]["planned"] = false;
  v = judge(c, m);
  EXPECT_EQ(find(v, "goal_true_distance_m", "b"), nullptr);
  EXPECT_EQ(find(v, "goals", ""), nullptr);  // a is planned
  // With no robot at all, or none planned (a scripted mission), the goal criteria fail rather than pass
  // on nothing.
  EXPECT_FALSE(judge(c, nlohmann::json{{"robots", nlohmann::json::array()}})["passed"].get<bool>());
  m["robots"][0]["planned"] = false;
  for (const bool distance : {true, false}) {
    CriteriaConfig goals;
    goals.goals_reached = !distance;
    goals.max_goal_true_distance_m = distance ? 0.3 : -1.0;
    v = judge(goals, m);
    EXPECT_FALSE(v["passed"].get<bool>());
    ASSERT_EQ(v["criteria"].size(), 1u) << v.dump();
    EXPECT_EQ(v["criteria"][0]["name"], "goals");
    EXPECT_EQ(v["criteria"][0]["note"], "no robot's path is planned: no goals to judge");
  }
}

// A frame without a pose counts whatever the reason: a robot that never started a map (no frame lost,
// none tracked) has lost every frame.
TEST(Criteria, LostShareCountsEveryFrameWithoutAPose) {
  nlohmann::json m = metrics();
  m["robots"][0]["tracked"] = 0;
  m["robots"][0]["lost"] = 0;
  m["robots"][1]["tracked"] = 96;
  CriteriaConfig c;
  c.max_lost_share = 0.05;
  const nlohmann::json v = judge(c, m);
  const nlohmann::json* a = find(v, "lost_share", "a");
  ASSERT_NE(a, nullptr);
  EXPECT_FALSE((*a)["passed"].get<bool>());
  EXPECT_DOUBLE_EQ((*a)["value"].get<double>(), 1.0);
  const nlohmann::json* b = find(v, "lost_share", "b");
  ASSERT_NE(b, nullptr);
  EXPECT_TRUE((*b)["passed"].get<bool>());  // 4 of 100, though 10 were counted lost before
  EXPECT_DOUBLE_EQ((*b)["value"].get<double>(), 0.04);
  // More tracked than frames is no measurement.
  m["robots"][1]["tracked"] = 101;
  EXPECT_TRUE((*find(judge(c, m), "lost_share", "b"))["value"].is_null());
}

// An empty merged map has no error statistics (null in metrics.json): the accuracy bounds fail and say why.
TEST(Criteria, AnEmptyMergedMapFailsTheAccuracyBounds) {
  nlohmann::json m = metrics();
  m["merged_map_accuracy"] = {{"map_points", 0}, {"mean_m", nullptr}, {"p95_m", nullptr}, {"completeness", 0.0}};
  CriteriaConfig c;
  c.max_map_accuracy_mean_m = 0.05;
  c.max_map_accuracy_p95_m = 0.1;
  const nlohmann::json v = judge(c, m);
  EXPECT_FALSE(v["passed"].get<bool>());
  for (const char* name : {"map_accuracy_mean_m", "map_accuracy_p95_m"}) {
    const nlohmann::json* j = find(v, name, "");
    ASSERT_NE(j, nullptr) << name;
    EXPECT_FALSE((*j)["passed"].get<bool>()) << name;
    EXPECT_EQ((*j)["note"], "the merged map is empty") << name;
  }
}

TEST(Criteria, UnmeasuredValuesFailWithANote) {
  nlohmann::json m = metrics();
  m["robots"][1].erase("ate_world_m");
  m["coverage"]["final"] = nullptr;
  m["merged_map_accuracy"]["mean_m"] = std::numeric_limits<double>::quiet_NaN();
  m["robots"][0]["frames"] = 0;
  CriteriaConfig c;
  c.max_ate_m = 1.0;
  c.min_coverage = 0.0;
  c.max_map_accuracy_mean_m = 1.0;
  c.max_lost_share = 1.0;
  const nlohmann::json v = judge(c, m);
  EXPECT_FALSE(v["passed"].get<bool>());
  const nlohmann::json* ate = find(v, "ate_world_rmse_m", "b");
  ASSERT_NE(ate, nullptr);
  EXPECT_FALSE((*ate)["passed"].get<bool>());
  EXPECT_TRUE((*ate)["value"].is_null());
  EXPECT_EQ((*ate)["note"], "no estimated trajectory to judge");
  EXPECT_FALSE((*find(v, "coverage", ""))["passed"].get<bool>());
  EXPECT_FALSE((*find(v, "map_accuracy_mean_m", ""))["passed"].get<bool>());
  EXPECT_EQ((*find(v, "lost_share", "a"))["note"], "no frames");
  // Robots that are not planned have no goals criterion.
  m["robots"][0]["planned"] = false;
  c = CriteriaConfig{};
  c.goals_reached = true;
  EXPECT_EQ(judge(c, m)["criteria"].size(), 1u);
  // Per-robot criteria with no robot to judge fail with a note (they passed, judging nothing).
  for (const nlohmann::json& nothing : {nlohmann::json::object(), nlohmann::json("odd"), nlohmann::json{{"robots", nlohmann::json::array()}}}) {
    const nlohmann::json verdict = judge(c, nothing);
    EXPECT_FALSE(verdict["passed"].get<bool>()) << nothing.dump();
    ASSERT_EQ(verdict["criteria"].size(), 1u) << nothing.dump();
    EXPECT_EQ(verdict["criteria"][0]["note"], "no robots to judge");
  }
  c = CriteriaConfig{};
  EXPECT_TRUE(judge(c, nlohmann::json::object())["passed"].get<bool>()) << "no criteria: nothing to fail";
  // Fields of the wrong type are treated as absent, not thrown on: a robot named by a number is "?", one
  // whose "planned" is not a boolean is not planned (b, planned, is judged).
  m["robots"][0]["name"] = 7;
  m["robots"][0]["planned"] = "yes";
  m["robots"][1]["planned"] = true;
  c = CriteriaConfig{};
  c.goals_reached = true;
  c.max_ate_m = 1.0;
  const nlohmann::json odd = judge(c, m);
  EXPECT_NE(find(odd, "ate_world_rmse_m", "?"), nullptr);
  EXPECT_EQ(find(odd, "goals_reached_share", "?"), nullptr);
  EXPECT_NE(find(odd, "goals_reached_share", "b"), nullptr);
}

}  // namespace
}  // namespace fleetslam::runner
