// fleetslam run: a scenario with the whole system in lockstep (runner::Runner): world, one SLAM agent
// per robot, the central unit merging maps, fusing trajectories and planning the ground robots' paths,
// judged against ground truth and the scenario's pass criteria. Exit 0 when every criterion holds, 1
// when one fails, 2 for bad input.

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <spdlog/fmt/fmt.h>

#include "cli_util.hpp"
#include "commands.hpp"
#include "fleetslam/runner/run_config.hpp"
#include "fleetslam/runner/runner.hpp"

namespace fleetslam::tools {
namespace {

namespace fs = std::filesystem;

struct RunOptions {
  std::string scenario;
  std::string out = "run_out";
  std::optional<std::int64_t> seed;
  std::optional<double> duration_s;
  int threads = 1;
  std::string agent_config;
  std::string central_config;
  std::vector<double> prior_error;  // dx dy dz (m) yaw (deg), applied to robots after the first
  double truth_spacing_m = 0.01;
  std::string vocabulary;  // place_recognition.vocabulary of every agent; empty: the config's
};

// A metric with `decimals` decimals ("n/a" when it was not measured); %g style for decimals < 0.
std::string number(const nlohmann::json& j, int decimals, double scale = 1.0) {
  if (!j.is_number()) return "n/a";
  char buffer[64];
  if (decimals < 0) {
    std::snprintf(buffer, sizeof(buffer), "%.4g", j.get<double>() * scale);
  } else {
    std::snprintf(buffer, sizeof(buffer), "%.*f", decimals, j.get<double>() * scale);
  }
  return buffer;
}

void print_summary(const nlohmann::json& metrics, const fs::path& out) {
  for (const nlohmann::json& r : metrics["robots"]) {
    std::printf("%-10s %s frames, tracked %s, collisions %d", r["name"].get<std::string>().c_str(),
                r["frames"].dump().c_str(), r["tracked"].dump().c_str(), r["collisions"].get<int>());
    if (r["planned"].get<bool>()) {
      std::printf(", goals %d/%d", r["goals_reached"].get<int>(), r["goals_total"].get<int>());
      double farthest = -1.0;  // of the true body from a goal counted reached
      for (const nlohmann::json& d : r["goals_reached_true_distance_m"]) farthest = std::max(farthest, d.get<double>());
      if (farthest >= 0.0) std::printf(" (truly within %.2f m)", farthest);
    }
    if (r.contains("ate_world_m")) std::printf(", ATE world %s m", number(r["ate_world_m"]["rmse"], 4).c_str());
    if (r.contains("refined_error")) {
      std::printf(", placed to %s m / %s deg (prior %s m / %s deg)", number(r["refined_error"]["translation_m"], 4).c_str(),
                  number(r["refined_error"]["rotation_deg"], 3).c_str(), number(r["prior_error"]["translation_m"], 4).c_str(),
                  number(r["prior_error"]["rotation_deg"], 3).c_str());
    }
    std::printf("\n           %s\n", r["status"].get<std::string>().c_str());
  }
  const nlohmann::json& a = metrics["merged_map_accuracy"];
  std::printf("merged map: %s points, accuracy mean %s m, p95 %s m, completeness %s %%; coverage %s %%\n",
              a["map_points"].dump().c_str(), number(a["mean_m"], 4).c_str(), number(a["p95_m"], 4).c_str(),
              number(a["completeness"], 1, 100.0).c_str(), number(metrics["coverage"]["final"], 1, 100.0).c_str());
  std::printf("time:       %s s simulated in %s s (real-time factor %s)\n", number(metrics["simulated_s"], 1).c_str(),
              number(metrics["wall_s"], 1).c_str(), number(metrics["real_time_factor"], 2).c_str());
  for (const nlohmann::json& c : metrics["verdict"]["criteria"]) {
    std::printf("%s %-22s %-8s %s %s %s %s\n", c["passed"].get<bool>() ? "pass" : "FAIL", c["name"].get<std::string>().c_str(),
                c["robot"].get<std::string>().c_str(), number(c["value"], -1).c_str(), c["comparison"].get<std::string>().c_str(),
                number(c["limit"], -1).c_str(), c["note"].get<std::string>().c_str());
  }
  std::printf("verdict:    %s\n", metrics["verdict"]["passed"].get<bool>() ? "PASS" : "FAIL");
  std::printf("wrote:      %s/{report.html,metrics.json,merged_map.ply,<robot>/...}\n", out.string().c_str());
}

void run_scenario(const RunOptions& o, const GlobalOptions& global) {
  const core::Logger logger = make_cli_logger("run", global);
  // Checked here rather than by CLI11's PositiveNumber, which lets NaN through.
  if (o.duration_s && !(*o.duration_s > 0.0 && *o.duration_s <= 1e6)) {
    throw InputError("--duration", "must be in (0, 1e6] seconds");
  }
  // Below a millimetre the sampled surfaces of a room no longer fit in memory.
  if (!(o.truth_spacing_m >= 1e-3 && o.truth_spacing_m <= 1.0)) {
    throw InputError("--truth-spacing", "must be in [0.001, 1] m");
  }
  if (o.seed && (*o.seed < 0 || *o.seed > sim::ScenarioConfig::kMaxSeed)) {
    throw InputError("--seed", "must be in [0, " + std::to_string(sim::ScenarioConfig::kMaxSeed) + "]");
  }
  // The seed goes in before the robots' seeds are derived from it.
  runner::RunScenarioConfig config = runner::load_run_scenario(o.scenario, o.seed);
  const double scenario_duration_s = config.world.duration_s;
  if (o.duration_s) config.world.duration_s = *o.duration_s;
  config.agent = read_config_file<slam::AgentConfig>(o.agent_config, config.agent);
  config.central = read_config_file<central::ServerConfig>(o.central_config, config.central);
  if (o.threads > 1) config.agent.threaded = true;
  if (!o.vocabulary.empty()) {
    config.agent.place_recognition.vocabulary = o.vocabulary;
    slam::load_place_vocabulary(config.agent.place_recognition);  // a bad file fails before the world is built
  }
  runner::RunnerOptions options;
  options.out = o.out;
  options.scenario_name = fs::path(o.scenario).filename().string();
  options.prior_error = o.prior_error;
  options.truth_spacing_m = o.truth_spacing_m;
  options.threads = o.threads;
  runner::Runner run(config, options, logger);
  const bool show = !global.quiet;
  const runner::RunOutcome outcome = run.run([show](const runner::RunProgress& p) {
    if (!show) return;
    std::string line;
    for (const std::string& s : p.robot_states) line += "  " + s;
    std::fprintf(stderr, "[%6.1f / %.1f s, real-time factor %.2f]%s\n", p.simulated_s, p.duration_s, p.real_time_factor,
                 line.c_str());
  });
  if (show) print_summary(outcome.metrics, o.out);
  if (!outcome.passed) {
    std::string failed;
    for (const nlohmann::json& c : outcome.metrics["verdict"]["criteria"]) {
      if (c["passed"].get<bool>()) continue;
      failed += (failed.empty() ? "" : ", ") + c["name"].get<std::string>();
      if (!c["robot"].get<std::string>().empty()) failed += " (" + c["robot"].get<std::string>() + ")";
    }
    // A run cut short by --duration is judged by the scenario's criteria all the same: say so.
    const std::string cut = o.duration_s && *o.duration_s < scenario_duration_s
                                ? fmt::format("; --duration {:g} s cut the scenario's {:g} s short", *o.duration_s,
                                              scenario_duration_s)
                                : std::string();
    throw CriteriaFailed("run failed its pass criteria: " + failed + " (see " + (fs::path(o.out) / "report.html").string() +
                         ")" + cut);
  }
}

}  // namespace

void add_run_command(CLI::App& app, const GlobalOptions& global) {
  auto options = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand(
      "run", "Run a scenario with the whole system in lockstep (world, one agent per robot, central unit, planner), "
             "judge it against ground truth and its pass criteria (exit 1 when one fails)");
  cmd->add_option("scenario", options->scenario, "Scenario YAML file")->required();
  cmd->add_option("--out", options->out, "Output folder")->capture_default_str();
  cmd->add_option("--seed", options->seed, "Seed of the simulation's noise (default: the scenario's); robots without a seed of their own derive theirs from it");
  cmd->add_option("--duration", options->duration_s, "Seconds to simulate, in (0, 1e6] (default: the scenario's)");
  cmd->add_option("--threads", options->threads,
                  "1: deterministic (everything inline, bit-identical repeats); more: agents map on worker threads and "
                  "the robots' agents track a camera tick's frames concurrently")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  cmd->add_option("--agent-config", options->agent_config, "Agent config YAML for every robot (over the scenario's agent section)");
  cmd->add_option("--central-config", options->central_config, "Central unit config YAML (over the scenario's central section)");
  cmd->add_option("--vocabulary", options->vocabulary,
                  "Vocabulary file for every agent's place recognition (binary or DBoW2 text; default: the "
                  "config's, else the shipped one)");
  cmd->add_option("--prior-error", options->prior_error,
                  "Error added to the initial-pose prior of every robot but the first: dx dy dz (m) yaw (deg)")
      ->expected(4);
  cmd->add_option("--truth-spacing", options->truth_spacing_m, "Spacing of the true-surface samples maps are judged against, in [0.001, 1] m")
      ->capture_default_str();
  cmd->callback([options, &global] { run_scenario(*options, global); });
}

}  // namespace fleetslam::tools
