// Closed-loop scenario tests in the apartment: two robots whose paths the central unit plans through the
// doorways on the map they build together pass their criteria; two robots exploring by frontiers run to
// their scenario's verdict without touching anything.

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "cli_test_util.hpp"

namespace fleetslam {
namespace {

namespace fs = std::filesystem;
using test::read_text;

const fs::path kScenarios = fs::path(FLEETSLAM_SOURCE_DIR) / "tests" / "scenarios";

nlohmann::json run_scenario(const char* name, const fs::path& out, int expected_exit) {
  const test::CliResult r = test::run_cli("-q run '" + (kScenarios / name).string() + "' --out '" + out.string() + "'");
  EXPECT_TRUE(fs::exists(out / "metrics.json")) << r.output;
  if (!fs::exists(out / "metrics.json")) return {};
  const nlohmann::json metrics = nlohmann::json::parse(read_text(out / "metrics.json"));
  EXPECT_EQ(r.exit_code, expected_exit) << r.output << metrics["verdict"].dump(2);
  return metrics;
}

TEST(ScenarioApartment, TwoPlannedRobotsCrossTheApartmentAndPassTheirCriteria) {
  const nlohmann::json metrics = run_scenario("apartment_planned.yaml", test::fresh_test_dir("fleetslam_scenario_apartment") / "run", 0);
  ASSERT_FALSE(metrics.is_null());
  EXPECT_TRUE(metrics["verdict"]["passed"].get<bool>()) << metrics["verdict"].dump(2);
  for (const nlohmann::json& robot : metrics["robots"]) {
    EXPECT_EQ(robot["goals_reached"], robot["goals_total"]) << robot["mission_events"].dump(1);
    EXPECT_GE(robot["goals_total"].get<int>(), 6);
    EXPECT_EQ(robot["collisions"], 0);
  }
}

TEST(ScenarioApartment, FrontierExplorationRunsToItsVerdict) {
  const nlohmann::json metrics = run_scenario("apartment_explore.yaml", test::fresh_test_dir("fleetslam_scenario_explore") / "run", 0);
  ASSERT_FALSE(metrics.is_null());
  EXPECT_EQ(metrics["mission"], "explore");
  EXPECT_TRUE(metrics["verdict"]["passed"].get<bool>()) << metrics["verdict"].dump(2);
  int frontiers_reached = 0;
  for (const nlohmann::json& robot : metrics["robots"]) frontiers_reached += robot["goals_reached"].get<int>();
  EXPECT_GE(frontiers_reached, 2) << metrics["robots"].dump(1);
  EXPECT_GE(metrics["coverage"]["final"].get<double>(), 0.1);
}

}  // namespace
}  // namespace fleetslam
