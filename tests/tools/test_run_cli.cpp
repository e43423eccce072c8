// End-to-end tests of `fleetslam run`: a short two-robot office run writes every output with metrics
// judged against the simulator's truth, and bad input ends with one clear line.

#include <gtest/gtest.h>

#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "cli_test_util.hpp"

#include "fleetslam/core/point_cloud.hpp"
#include "fleetslam/core/trajectory.hpp"
#include "fleetslam/runner/run_config.hpp"

namespace fleetslam {
namespace {

namespace fs = std::filesystem;
using test::read_text;
using RunResult = test::CliResult;

test::CliResult run(const std::string& arguments) { return test::run_cli(arguments); }
fs::path test_dir() { return test::fresh_test_dir("fleetslam_test_run_cli"); }

// The office with scripted waypoints and no criteria (tests/scenarios/office_scripted.yaml).
const fs::path kOffice = fs::path(FLEETSLAM_SOURCE_DIR) / "tests" / "scenarios" / "office_scripted.yaml";
const fs::path kOfficeScene = fs::path(FLEETSLAM_SOURCE_DIR) / "scenes" / "office" / "office.xml";

TEST(RunCli, TwoRobotOfficeRunIsJudgedAgainstTruth) {
  const fs::path out = test_dir() / "run";
  const RunResult r = run("-q run '" + kOffice.string() + "' --duration 3 --prior-error 0.06 -0.08 0 5 --out '" +
                          out.string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream metrics_file(out / "metrics.json");
  const nlohmann::json metrics = nlohmann::json::parse(metrics_file);
  ASSERT_EQ(metrics["robots"].size(), 2u);
  for (const nlohmann::json& robot : metrics["robots"]) {
    EXPECT_EQ(robot["frames"], 90) << robot.dump();
    EXPECT_EQ(robot["tracked"], 90) << robot.dump();
    EXPECT_LT(robot["ate_se3_m"]["rmse"].get<double>(), 0.01) << robot.dump();
  }
  // The reference robot's map lies on the true surfaces; the second robot's placement is no worse than
  // its prior (how much better depends on the overlap a 3 s run gives).
  EXPECT_LT(metrics["robots"][0]["map_accuracy"]["median_m"].get<double>(), 0.02);
  const nlohmann::json& bravo = metrics["robots"][1];
  EXPECT_LE(bravo["refined_error"]["rotation_deg"].get<double>(), bravo["prior_error"]["rotation_deg"].get<double>() + 1e-6)
      << bravo.dump();
  // Nor in translation, nor in the world frame: a wide registration on 3 % of the cloud had moved it from
  // 10 cm off to 59 cm off (world-frame ATE 0.61 m); kept at its prior it is 0.14 m.
  EXPECT_LE(bravo["refined_error"]["translation_m"].get<double>(), bravo["prior_error"]["translation_m"].get<double>() + 1e-6)
      << bravo.dump();
  EXPECT_LT(bravo["ate_world_m"]["rmse"].get<double>(), 0.2) << bravo.dump();
  EXPECT_LT(metrics["robots"][0]["ate_world_m"]["rmse"].get<double>(), 0.01);
  EXPECT_NEAR(metrics["robots"][1]["prior_error"]["rotation_deg"].get<double>(), 5.0, 1e-6);
  EXPECT_NEAR(metrics["robots"][1]["prior_error"]["translation_m"].get<double>(), 0.1, 1e-6);
  EXPECT_GT(metrics["merged_map_accuracy"]["completeness"].get<double>(), 0.0);
  EXPECT_GT(metrics["real_time_factor"].get<double>(), 0.0);
  // A scripted run with no criteria passes; the verdict says so.
  EXPECT_TRUE(metrics["verdict"]["passed"].get<bool>()) << metrics["verdict"].dump();
  EXPECT_TRUE(metrics["verdict"]["criteria"].empty());
  EXPECT_EQ(metrics["mission"], "scripted");
  for (const char* file : {"scenario.yaml", "merged_map.ply", "merge.json", "metrics.json", "mission.json", "run.log",
                           "report.html", "occupancy.pgm", "alpha/map.ply", "alpha/trajectory.txt", "alpha/groundtruth.txt",
                           "bravo/trajectory.txt"}) {
    EXPECT_TRUE(fs::exists(out / file)) << file;
  }
  EXPECT_EQ(core::read_trajectory(out / "bravo" / "groundtruth.txt").size(), 90u);
}

// With --threads 2 the robots' agents track each camera tick's frames concurrently (and map on workers):
// every robot still gets each of its frames once and in order, and tracks them as well as inline.
TEST(RunCli, ThreadedRunTracksEveryFrameOfEveryRobot) {
  const fs::path out = test_dir() / "threaded";
  const RunResult r = run("-q run '" + kOffice.string() + "' --duration 3 --threads 2 --out '" + out.string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json metrics = nlohmann::json::parse(read_text(out / "metrics.json"));
  ASSERT_EQ(metrics["robots"].size(), 2u);
  for (const nlohmann::json& robot : metrics["robots"]) {
    EXPECT_EQ(robot["frames"], 90) << robot.dump();
    EXPECT_EQ(robot["tracked"], 90) << robot.dump();
    EXPECT_LT(robot["ate_se3_m"]["rmse"].get<double>(), 0.01) << robot.dump();
    const std::string name = robot["name"].get<std::string>();
    const core::Trajectory estimated = core::read_trajectory(out / name / "trajectory.txt");
    ASSERT_EQ(estimated.size(), 90u) << name;
    for (std::size_t i = 1; i < estimated.size(); ++i) EXPECT_LT(estimated[i - 1].t_ns, estimated[i].t_ns) << name;
  }
  // The effective scenario names its scene by an absolute path, so it runs again from the output folder
  // (a relative one was looked for beside the written file).
  const runner::RunScenarioConfig again = runner::load_run_scenario(out / "scenario.yaml");
  EXPECT_TRUE(fs::path(again.world.scene).is_absolute()) << again.world.scene;
  EXPECT_TRUE(fs::exists(again.world.scene_path())) << again.world.scene_path();
}

// A criterion that cannot hold fails the run: exit 1, one line naming it, and the verdict in the outputs.
// The folder held an earlier run's files: those are removed by name first.
TEST(RunCli, FailedCriterionExitsOneWithTheVerdict) {
  const fs::path dir = test_dir();
  // The scene path is relative to the scenario file: point at the real one.
  std::string scenario = read_text(kOffice);
  const std::string scene_key = "scene: ../../scenes/office/office.xml";
  scenario.replace(scenario.find(scene_key), scene_key.size(), "scene: '" + kOfficeScene.string() + "'");
  std::ofstream(dir / "strict.yaml") << scenario << "criteria:\n  max_ate_m: 0.0\n  min_real_time_factor: 1000\n";
  const fs::path out = dir / "run";
  // An earlier run of a scenario with a robot "ghost" left its folder: removed. A folder holding anything
  // else, an empty folder and files of other names stay.
  fs::create_directories(out / "ghost");
  fs::create_directories(out / "notes");
  fs::create_directories(out / "plots");
  std::ofstream(out / "ghost" / "trajectory.txt") << "1 0 0 0 0 0 0 1\n";
  std::ofstream(out / "ghost" / "map.ply") << "stale\n";
  std::ofstream(out / "notes" / "trajectory.txt") << "mine\n";
  std::ofstream(out / "notes" / "todo.md") << "mine\n";
  std::ofstream(out / "todo.md") << "mine\n";
  const RunResult r = run("-q run '" + (dir / "strict.yaml").string() + "' --duration 1 --out '" + out.string() + "'");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_FALSE(fs::exists(out / "ghost"));
  EXPECT_TRUE(fs::exists(out / "notes" / "trajectory.txt"));
  EXPECT_TRUE(fs::exists(out / "notes" / "todo.md"));
  EXPECT_TRUE(fs::exists(out / "todo.md"));
  EXPECT_TRUE(fs::is_directory(out / "plots"));
  EXPECT_NE(read_text(out / "run.log").find("removed 2 output file(s) of an earlier run"), std::string::npos);
  EXPECT_NE(r.output.find("failed its pass criteria: ate_world_rmse_m (alpha)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("real_time_factor"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--duration 1 s cut the scenario's 25 s short"), std::string::npos) << r.output;
  const nlohmann::json metrics = nlohmann::json::parse(read_text(out / "metrics.json"));
  EXPECT_FALSE(metrics["verdict"]["passed"].get<bool>());
  EXPECT_EQ(metrics["verdict"]["criteria"].size(), 3u);  // ATE for each robot and the real-time factor
  EXPECT_NE(read_text(out / "report.html").find("FAIL"), std::string::npos);
}

// A robot's frame is cam0 of the frame that started its map: a rig that first looks at the floor from
// closer than the depth range (no map) and then rises 1 m is judged from where its map started. Its prior
// was the first frame's pose, and the world-frame ATE of the reference robot was 0.45 m.
TEST(RunCli, ARobotWhoseMapStartsLateIsPlacedFromThatFrame) {
  const fs::path dir = test_dir();
  std::ofstream(dir / "late.yaml")
      << "scene: '" << kOfficeScene.string() << "'\nduration_s: 3\nseed: 3\nrobots:\n"
      << "  - name: rig\n    type: free_rig\n    camera: {width: 640, height: 480, fovy_deg: 45, rate_hz: 30, depth: true}\n"
      << "    waypoints: [{t_s: 0, x: 3.0, y: 2.5, z: 0.12, pitch_deg: 90}, {t_s: 1.0, x: 3.0, y: 2.5, z: 0.12, pitch_deg: 90},"
      << " {t_s: 2.0, x: 3.0, y: 2.5, z: 1.2}, {t_s: 3.0, x: 3.2, y: 2.5, z: 1.2}]\n";
  const fs::path out = dir / "run";
  const RunResult r = run("-q run '" + (dir / "late.yaml").string() + "' --out '" + out.string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json rig = nlohmann::json::parse(read_text(out / "metrics.json"))["robots"][0];
  EXPECT_LT(rig["tracked"].get<int>(), rig["frames"].get<int>() - 10) << "the map must start late for this test";
  EXPECT_LT(rig["ate_world_m"]["rmse"].get<double>(), 0.03) << rig.dump();
}

// Contact time is simulated time: bravo (10 Hz camera) drives into the east bookshelf while alpha's 30 Hz
// camera sets the world's steps. Each step added 1 / 10 s for bravo: three times its time in contact.
TEST(RunCli, ContactTimeIsSimulatedTimeWhateverTheCameraRate) {
  const fs::path dir = test_dir();
  std::ofstream(dir / "bump.yaml")
      << "scene: '" << kOfficeScene.string() << "'\nduration_s: 5\nseed: 3\nrobots:\n"
      << "  - name: alpha\n    type: diff_drive\n    initial_pose: {x: 1.5, y: 2.0, yaw_deg: 0}\n"
      << "    camera: {width: 320, height: 240, fovy_deg: 45, rate_hz: 30, depth: true}\n"
      << "  - name: bravo\n    type: diff_drive\n    initial_pose: {x: 4.5, y: 2.5, yaw_deg: 0}\n"
      << "    camera: {width: 320, height: 240, fovy_deg: 45, rate_hz: 10, depth: true}\n"
      << "    waypoints: [{x: 6.5, y: 2.5}]\n";
  const fs::path out = dir / "run";
  const RunResult r = run("-q run '" + (dir / "bump.yaml").string() + "' --out '" + out.string() + "'");
  ASSERT_LE(r.exit_code, 1) << r.output;
  const nlohmann::json bravo = nlohmann::json::parse(read_text(out / "metrics.json"))["robots"][1];
  ASSERT_GE(bravo["collisions"].get<int>(), 1) << "bravo must touch the wall for this test";
  const double first_s = bravo["collision_events"][0]["t_s"].get<double>();
  EXPECT_GT(bravo["contact_s"].get<double>(), 0.0);
  EXPECT_LE(bravo["contact_s"].get<double>(), 5.0 - first_s + 0.05) << bravo.dump();
}

// --seed replaces the scenario's seed before the robots derive theirs from it: the simulation's noise
// follows it, and a robot with a seed of its own keeps that.
TEST(RunCli, SeedReachesTheRobots) {
  const runner::RunScenarioConfig file = runner::load_run_scenario(kOffice);
  const runner::RunScenarioConfig seeded = runner::load_run_scenario(kOffice, 7);
  ASSERT_EQ(seeded.world.robots.size(), 2u);
  EXPECT_EQ(seeded.world.seed, 7);
  EXPECT_EQ(seeded.world.robots[0].seed, 7001);
  EXPECT_EQ(seeded.world.robots[1].seed, 7002);
  EXPECT_NE(file.world.robots[0].seed, seeded.world.robots[0].seed);
  const fs::path dir = test_dir();
  std::string scenario = read_text(kOffice);
  const std::string scene_key = "scene: ../../scenes/office/office.xml";
  scenario.replace(scenario.find(scene_key), scene_key.size(), "scene: '" + kOfficeScene.string() + "'");
  const std::string bravo = "- name: bravo\n";
  ASSERT_NE(scenario.find(bravo), std::string::npos);
  scenario.insert(scenario.find(bravo) + bravo.size(), "    seed: 55\n");
  std::ofstream(dir / "own_seed.yaml") << scenario;
  const runner::RunScenarioConfig own = runner::load_run_scenario(dir / "own_seed.yaml", 7);
  EXPECT_EQ(own.world.robots[0].seed, 7001);
  EXPECT_EQ(own.world.robots[1].seed, 55);
}

// A planned run times its deconfliction by the robots' controllers: the office robots drive at most
// 0.4 m/s (the planner's nominal speed is 0.5), turn at 0.5 rad/s, and on the spot beyond 60 degrees.
TEST(RunCli, DeconflictionIsTimedByTheSlowestRobot) {
  const fs::path out = test_dir() / "planned";
  const fs::path planned = fs::path(FLEETSLAM_SOURCE_DIR) / "tests" / "scenarios" / "office_planned.yaml";
  const RunResult r = run("-q run '" + planned.string() + "' --duration 0.2 --out '" + out.string() + "'");
  EXPECT_LE(r.exit_code, 1) << r.output;  // a 0.2 s run may fail its criteria; it runs to its verdict
  const std::string log = read_text(out / "run.log");
  EXPECT_NE(log.find("deconfliction: paths timed at 0.400 m/s, turns at 0.500 rad/s, on the spot beyond 60.0 deg"),
            std::string::npos)
      << log;
}

TEST(RunCli, BadInputEndsWithOneClearLine) {
  const fs::path dir = test_dir();
  RunResult r = run("run '" + (dir / "absent.yaml").string() + "' --out '" + (dir / "run").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("absent.yaml"), std::string::npos) << r.output;
  // The scene's XML where the scenario YAML belongs: said so (it was "malformed YAML").
  const fs::path scene = kOffice.parent_path() / "office.xml";
  r = run("run '" + scene.string() + "' --out '" + (dir / "run").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("office.xml: is a MuJoCo scene (XML); give the scenario YAML"), std::string::npos) << r.output;
  r = run("run '" + kOffice.string() + "' --prior-error 0.1 0 0 --out '" + (dir / "run").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = run("run '" + kOffice.string() + "' --prior-error nan 0 0 0 --out '" + (dir / "nan_prior").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--prior-error: values must be finite"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "nan_prior")) << "refused before the output folder is made";
  std::ofstream(dir / "agent.yaml") << "tracking:\n  no_such_key: 1\n";
  r = run("run '" + kOffice.string() + "' --agent-config '" + (dir / "agent.yaml").string() + "' --out '" +
          (dir / "run").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("no_such_key"), std::string::npos) << r.output;
  // Run sections are checked like the rest: unknown keys and bad choices name file:key.
  std::ofstream(dir / "mission.yaml") << read_text(kOffice) << "mission:\n  kind: wander\n";
  r = run("run '" + (dir / "mission.yaml").string() + "' --out '" + (dir / "run").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("mission.kind"), std::string::npos) << r.output;
  // A robot without a camera has nothing for its agent to track: refused naming it (an internal error).
  std::string blind = read_text(kOffice);
  blind.replace(blind.find("scene: "), 7, "scene: " + kOffice.parent_path().string() + "/");  // written elsewhere
  const std::size_t second_camera = blind.find("camera: {", blind.find("camera: {") + 1);
  ASSERT_NE(second_camera, std::string::npos);
  blind.insert(blind.find('\n', second_camera), "\n    imu: {enabled: false}");  // an IMU needs the camera too
  blind.insert(second_camera + std::string("camera: {").size(), "enabled: false, ");
  std::ofstream(dir / "blind.yaml") << blind;
  r = run("run '" + (dir / "blind.yaml").string() + "' --out '" + (dir / "run").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("robots[1].camera.enabled: robot 'bravo' has no camera"), std::string::npos) << r.output;
  std::ofstream(dir / "criteria.yaml") << read_text(kOffice) << "criteria:\n  max_ate: 0.1\n";
  r = run("run '" + (dir / "criteria.yaml").string() + "' --out '" + (dir / "run").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("max_ate"), std::string::npos) << r.output;
  // Options out of range name the option (NaN passed CLI11's PositiveNumber; a tiny truth spacing ran out
  // of memory; a negative seed would give the robots negative seeds).
  for (const char* option : {"--duration nan", "--duration -1", "--truth-spacing 1e-9", "--truth-spacing nan", "--seed -1"}) {
    r = run("run '" + kOffice.string() + "' " + option + " --out '" + (dir / "run").string() + "'");
    EXPECT_EQ(r.exit_code, 2) << option << ": " << r.output;
    const std::string name = std::string(option).substr(0, std::string(option).find(' '));
    EXPECT_NE(r.output.find(name), std::string::npos) << option << ": " << r.output;
  }
  std::ofstream(dir / "bad.fsvoc", std::ios::binary) << "not a vocabulary";
  r = run("-q run '" + kOffice.string() + "' --vocabulary '" + (dir / "bad.fsvoc").string() + "' --out '" +
          (dir / "run").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  EXPECT_NE(r.output.find("bad.fsvoc"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace fleetslam
