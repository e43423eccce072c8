// fleetslam experiment NAME: the paper's experiments (issue 8; tools/experiments/) on the real sequences
// and rendered scenarios, each writing CSV + Markdown + SVG into DIR/<name>/:
//   matching    Table 1: matching time, matches, precision and recall per matcher and feature count
//   keyframes   Table 2 and Fig. 7: ATE of each keyframe policy, cumulative ATE over time
//   sampling    Table 3: merged-map points before and after uniform sampling in multi-robot runs
//   all         the three; with --doc FILE the results document (e.g. docs/RESULTS.md) and its plots
// Rendered scenarios go to DIR/synthetic/ and are reused by later runs with the same scenario and duration.
// A data source given as "none" is left out.

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <spdlog/logger.h>

#include "cli_util.hpp"
#include "commands.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/experiments/keyframes.hpp"
#include "fleetslam/experiments/matching.hpp"
#include "fleetslam/experiments/results_document.hpp"
#include "fleetslam/experiments/sampling.hpp"
#include "fleetslam/experiments/sequences.hpp"

namespace fleetslam::tools {
namespace {

namespace fs = std::filesystem;
namespace ex = experiments;

struct ExperimentOptions {
  std::string name;
  std::string out = "experiment_out";
  std::string tum = "../shared/data/tum/rgbd_dataset_freiburg1_rpy_200";
  std::string tum_calibration = "../shared/data/calib/TUM1.yaml";
  std::string euroc = "../shared/data/euroc/V1_01_easy_micro";
  std::vector<std::string> scenarios = {"scenes/office/office_2robots.yaml"};
  double synthetic_duration_s = 10.0;
  bool rerender = false;
  std::int64_t frames = -1;
  int repetitions = 100;
  int pairs = 4;
  int runs = 10;
  bool threaded = false;
  int split = 2;
  std::vector<int> features = {250, 1000, 2000};
  std::vector<std::string> matchers;  // empty: all
  std::string doc;
};

fs::path optional_path(const std::string& value) { return value == "none" ? fs::path() : fs::path(value); }

ex::DataSourcesConfig data_sources(const ExperimentOptions& o) {
  ex::DataSourcesConfig config;
  config.tum_dir = optional_path(o.tum);
  config.tum_calibration = config.tum_dir.empty() ? fs::path() : optional_path(o.tum_calibration);
  config.euroc_dir = optional_path(o.euroc);
  for (const std::string& s : o.scenarios) {
    if (s != "none") config.scenarios.push_back(s);
  }
  config.synthetic_duration_s = o.synthetic_duration_s;
  config.synthetic_dir = fs::path(o.out) / "synthetic";
  config.rerender = o.rerender;
  return config;
}

// Sequences with per-frame depth (matching needs it): everything but stereo ones.
std::vector<ex::SequenceSpec> rgbd_only(const std::vector<ex::SequenceSpec>& sequences) {
  std::vector<ex::SequenceSpec> out;
  for (const ex::SequenceSpec& s : sequences) {
    if (!s.stereo) out.push_back(s);
  }
  return out;
}

// One sequence per scenario (its first robot) for the single-agent experiments.
std::vector<ex::SequenceSpec> first_robot_per_scenario(const std::vector<ex::SequenceSpec>& synthetic) {
  std::vector<ex::SequenceSpec> out;
  for (const ex::SequenceSpec& s : synthetic) {
    if (out.empty() || out.back().scenario != s.scenario) out.push_back(s);
  }
  return out;
}

void print_written(const std::vector<fs::path>& files, const GlobalOptions& global) {
  if (global.quiet) return;
  for (const fs::path& f : files) std::printf("wrote %s\n", f.string().c_str());
}

void run_experiment(const ExperimentOptions& o, const GlobalOptions& global) {
  const auto start = std::chrono::steady_clock::now();
  const core::Logger logger = make_cli_logger("experiment", global);
  const bool all = o.name == "all";
  if (!o.doc.empty() && !all) throw InputError("--doc", "is written by `fleetslam experiment all` only");
  if (o.frames != -1 && o.frames < 1) throw InputError("--frames", "must be -1 (all) or at least 1");
  const ex::DataSourcesConfig sources = data_sources(o);
  ex::check_data_sources(sources);
  // Settings are checked before anything is rendered.
  ex::MatchingConfig matching_config;
  matching_config.features = o.features;
  matching_config.repetitions = o.repetitions;
  matching_config.pairs = o.pairs;
  matching_config.max_frames = o.frames;
  if (!o.matchers.empty()) {
    if (o.name != "matching") {
      throw InputError("--matchers", "only with `fleetslam experiment matching` (the results document compares every matcher)");
    }
    matching_config.matchers.clear();
    for (const std::string& name : o.matchers) {
      const std::optional<ex::MatcherKind> kind = ex::matcher_from_string(name);
      if (!kind) {
        throw InputError("--matchers", "'" + name + "' is no matcher: brute_force, brute_force_opencv, flann_lsh, grid "
                                       "or cross_validation");
      }
      matching_config.matchers.push_back(*kind);
    }
  }
  const ex::MatchingExperiment matching(matching_config, logger);
  ex::KeyframesConfig keyframes_config;
  keyframes_config.runs = o.runs;
  keyframes_config.threaded = o.threaded;
  keyframes_config.max_frames = o.frames;
  const ex::KeyframesExperiment keyframes(keyframes_config, logger);
  ex::SamplingConfig sampling_config;
  sampling_config.split = o.split;
  sampling_config.max_frames = o.frames;
  const ex::SamplingExperiment sampling(sampling_config, logger);

  if (sources.tum_dir.empty() && sources.euroc_dir.empty() && sources.scenarios.empty()) {
    throw InputError("--tum, --euroc, --scenario", "all are none: there is no sequence to run the experiments on");
  }
  const fs::path out = o.out;
  create_output_folder(out);
  const std::vector<ex::SequenceSpec> real = ex::real_sequences(sources);
  const std::vector<ex::SequenceSpec> synthetic = ex::render_synthetic(sources, logger);
  ex::ResultsInput doc;
  doc.sequences = real;
  doc.sequences.insert(doc.sequences.end(), synthetic.begin(), synthetic.end());
  std::vector<ex::SequenceSpec> single = real;
  for (const ex::SequenceSpec& s : first_robot_per_scenario(synthetic)) single.push_back(s);

  const auto keep = [&](const std::vector<fs::path>& files) {
    print_written(files, global);
    for (const fs::path& f : files) {
      if (f.extension() == ".svg") doc.plots.push_back(f);
    }
  };
  if (all || o.name == "matching") {
    doc.matching = matching.run(rgbd_only(single));
    keep(ex::write_matching_outputs(*doc.matching, out / "matching"));
  }
  if (all || o.name == "sampling") {
    std::vector<ex::SequenceSpec> inputs = real;
    inputs.insert(inputs.end(), synthetic.begin(), synthetic.end());
    doc.sampling = sampling.run(inputs);
    keep(ex::write_sampling_outputs(*doc.sampling, out / "sampling"));
  }
  if (all || o.name == "keyframes") {
    doc.keyframes = keyframes.run(single);
    keep(ex::write_keyframes_outputs(*doc.keyframes, out / "keyframes"));
  }
  if (!o.doc.empty()) {
    doc.machine = ex::MachineInfo::probe();
    doc.command = ex::current_command_line();
    doc.total_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ex::write_results_document(doc, o.doc);
    if (!global.quiet) std::printf("wrote %s\n", o.doc.c_str());
  }
}

}  // namespace

void add_experiment_command(CLI::App& app, const GlobalOptions& global) {
  auto o = std::make_shared<ExperimentOptions>();
  CLI::App* cmd = app.add_subcommand(
      "experiment", "Run the paper's experiments (matching: Table 1, keyframes: Table 2 + Fig. 7, sampling: Table 3, "
                    "all) on the real sequences and rendered scenarios; CSV, Markdown and SVG in --out/<name>/");
  cmd->add_option("name", o->name, "Experiment")->required()->check(CLI::IsMember({"matching", "keyframes", "sampling", "all"}));
  cmd->add_option("--out", o->out, "Output folder")->capture_default_str();
  cmd->add_option("--tum", o->tum, "TUM RGB-D sequence folder, or none")->capture_default_str();
  cmd->add_option("--tum-calibration", o->tum_calibration, "ORB-SLAM settings of the TUM sequence")->capture_default_str();
  cmd->add_option("--euroc", o->euroc, "EuRoC sequence folder (stereo; keyframes only), or none")->capture_default_str();
  cmd->add_option("--scenario", o->scenarios, "Run scenario(s) to render as synthetic sequences, or none")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--synthetic-duration", o->synthetic_duration_s, "Simulated seconds per scenario")->capture_default_str();
  cmd->add_flag("--rerender", o->rerender,
                "Render the scenarios again even when OUT/synthetic has them (the reuse check sees the scenario, the "
                "scene and every file it refers to, and this program, but not the shared libraries it runs with)");
  cmd->add_option("--frames", o->frames, "Use at most this many frames of each sequence (-1: all)")->capture_default_str();
  cmd->add_option("--repetitions", o->repetitions, "matching: timed repetitions per pair and matcher")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  cmd->add_option("--pairs", o->pairs, "matching: adjacent frame pairs per sequence")->capture_default_str()->check(CLI::Range(1, 1000));
  cmd->add_option("--features", o->features, "matching: features per frame, comma-separated")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--matchers", o->matchers,
                  "matching: the matchers to run, comma-separated (default all: brute_force, brute_force_opencv, "
                  "flann_lsh, grid, cross_validation)")
      ->delimiter(',');
  cmd->add_option("--runs", o->runs, "keyframes: runs per sequence and policy")->capture_default_str()->check(CLI::Range(1, 1000));
  cmd->add_flag("--threaded", o->threaded, "keyframes: run the agents' threaded mode (runs vary, outputs not repeatable)");
  cmd->add_option("--split", o->split, "sampling: robots a real sequence is split into")->capture_default_str()->check(CLI::Range(2, 26));
  cmd->add_option("--doc", o->doc, "all: write the results document here (plots to its folder's results/)");
  cmd->callback([o, &global] { run_experiment(*o, global); });
}

}  // namespace fleetslam::tools
