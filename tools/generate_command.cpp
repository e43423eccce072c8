// fleetslam generate: run a scenario in the simulator and write each robot's stream as a recorded
// sequence (TUM RGB-D or EuRoC layout) with an ORB-SLAM3 settings file, so that the same data feeds our
// agents through the dataset readers and ORB-SLAM3 as it is.
//
//   DIR/scenario.yaml                      the effective scenario (every key, scene path absolute)
//   DIR/<robot>/...                        the robot's sequence (core::make_dataset_writer)
//   DIR/<robot>/orbslam_settings.yaml      its sensors as ORB-SLAM3 settings (core::write_orbslam_settings)


#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>
#include <spdlog/logger.h>

#include "cli_util.hpp"
#include "commands.hpp"
#include "fleetslam/core/config.hpp"
#include "fleetslam/core/dataset.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/core/orbslam_settings.hpp"
#include "fleetslam/runner/run_config.hpp"
#include "fleetslam/sim/scenario.hpp"
#include "fleetslam/sim/world.hpp"

namespace fleetslam::tools {
namespace {

namespace fs = std::filesystem;

constexpr const char* kScenarioFile = "scenario.yaml";
constexpr const char* kSettingsFile = "orbslam_settings.yaml";
// Close/far depth thresholds (in baselines) of ORB-SLAM3's own examples: EuRoC stereo and TUM RGB-D.
constexpr double kStereoThDepth = 60.0;
constexpr double kRgbdThDepth = 40.0;

struct GenerateOptions {
  std::string scenario;
  std::string format;
  std::string out;
  double duration_s = 0.0;
  bool duration_given = false;  // else the scenario's duration
  std::vector<std::string> robots;
};

// One robot being written.
struct RobotOutput {
  std::size_t index = 0;  // in the scenario (and the world)
  std::string name;
  core::SensorRig rig;    // as the written sequence describes it
  std::unique_ptr<core::FrameSink> sink;
};

std::string robot_key(const GenerateOptions& options, std::size_t index, const std::string& key) {
  return options.scenario + ":robots[" + std::to_string(index) + "]." + key;
}

// Refused before anything runs, so that nothing already there is touched.
void check_output_folder(const fs::path& out) {
  std::error_code ec;
  if (!fs::exists(out, ec)) return;
  if (!fs::is_directory(out, ec)) throw InputError(out.string(), "exists and is not a folder");
  if (!fs::is_empty(out, ec)) throw InputError(out.string(), "output folder exists and is not empty; give a new one");
}

sim::ScenarioConfig load(const GenerateOptions& options) {
  // A run scenario (its agent, planner, mission and criteria sections are checked, then not needed here).
  sim::ScenarioConfig scenario = runner::load_run_scenario(options.scenario).world;
  if (options.duration_given) {
    if (!(options.duration_s > 0.0 && options.duration_s <= 1e6)) {
      throw InputError("--duration", "must be in (0, 1e6] seconds");
    }
    scenario.duration_s = options.duration_s;
  }
  return scenario;
}

// Robot names become folder names beside scenario.yaml.
void check_folder_name(const GenerateOptions& options, std::size_t index, const std::string& name) {
  if (name == "." || name == ".." || name == kScenarioFile || name.find_first_of("/\\") != std::string::npos) {
    throw InputError(robot_key(options, index, "name"),
                     "'" + name + "' cannot name the robot's output folder (no '/', '.', '..' or " +
                         kScenarioFile + ")");
  }
}

// Indices of the robots to write: --robots in the order given, else every robot with a camera.
std::vector<std::size_t> select_robots(const GenerateOptions& options, const sim::ScenarioConfig& scenario,
                                       const core::Logger& logger) {
  std::vector<std::size_t> selected;
  for (const std::string& name : options.robots) {
    const auto it = std::find_if(scenario.robots.begin(), scenario.robots.end(),
                                 [&](const sim::RobotConfig& robot) { return robot.name == name; });
    if (it == scenario.robots.end()) {
      std::string names;
      for (const sim::RobotConfig& robot : scenario.robots) names += (names.empty() ? "" : ", ") + robot.name;
      throw InputError("--robots", "no robot '" + name + "' in " + options.scenario + " (robots: " + names + ")");
    }
    const auto index = static_cast<std::size_t>(it - scenario.robots.begin());
    if (std::find(selected.begin(), selected.end(), index) == selected.end()) selected.push_back(index);
  }
  if (!options.robots.empty()) return selected;
  for (std::size_t i = 0; i < scenario.robots.size(); ++i) {
    if (scenario.robots[i].camera.enabled) {
      selected.push_back(i);
    } else {
      logger->warn("robot '{}' has no camera: nothing to write for it", scenario.robots[i].name);
    }
  }
  return selected;
}

// What the layout needs from each robot, named by its scenario key.
void check_robots(const GenerateOptions& options, const sim::ScenarioConfig& scenario,
                  const std::vector<std::size_t>& selected, core::DatasetFormat format) {
  if (selected.empty()) throw InputError(options.scenario + ":robots", "no robot with a camera to write");
  for (const std::size_t i : selected) {
    const sim::RobotConfig& robot = scenario.robots[i];
    check_folder_name(options, i, robot.name);
    if (!robot.camera.enabled) {
      throw InputError(robot_key(options, i, "camera.enabled"), "robot '" + robot.name + "' has no camera to write");
    }
    if (format == core::DatasetFormat::kTumRgbd && !robot.camera.depth) {
      throw InputError(robot_key(options, i, "camera.depth"),
                       "robot '" + robot.name + "' renders no depth, which the TUM RGB-D layout needs: set it "
                       "to true, or use --format euroc (or tumvi)");
    }
  }
}

// The rig as the written sequence holds it. TUM RGB-D: the colour camera with depth (a stereo robot's
// right camera is not written), no IMU (the layout keeps only an accelerometer). EuRoC and TUM-VI: no
// depth, so an RGB-D robot becomes monocular (inertial with its IMU).
core::SensorRig sequence_rig(core::SensorRig rig, core::DatasetFormat format) {
  if (format == core::DatasetFormat::kTumRgbd) {
    rig.mode = core::SensorMode::kRgbd;
    rig.cam1.reset();
    rig.T_cam0_cam1 = Eigen::Isometry3d::Identity();
    rig.imu.reset();
  } else if (rig.mode == core::SensorMode::kRgbd) {
    rig.mode = rig.imu ? core::SensorMode::kMonoInertial : core::SensorMode::kMonocular;
    rig.bf = 0.0;
  }
  return rig;
}

core::OrbSlamSettings orbslam_settings(const core::SensorRig& rig) {
  core::OrbSlamSettings s;  // ORB extractor defaults
  s.rig = rig;
  const bool stereo = rig.mode == core::SensorMode::kStereo || rig.mode == core::SensorMode::kStereoInertial;
  if (stereo) s.th_depth = kStereoThDepth;
  if (rig.mode == core::SensorMode::kRgbd) s.th_depth = kRgbdThDepth;
  return s;
}

// The effective scenario, loadable from the output folder: the scene path made absolute.
void write_effective_scenario(const fs::path& file, sim::ScenarioConfig scenario) {
  scenario.scene = scenario.absolute_scene_path().string();
  std::ofstream out(file);
  out << "# Effective scenario written by fleetslam generate\n" << core::config_to_yaml(scenario);
  if (!out) throw InputError(file.string(), "cannot write the scenario");
}

std::vector<RobotOutput> open_outputs(const fs::path& out, const sim::World& world,
                                      const std::vector<std::size_t>& selected, core::DatasetFormat format,
                                      const core::Logger& logger) {
  std::vector<RobotOutput> outputs;
  for (const std::size_t i : selected) {
    RobotOutput output;
    output.index = i;
    output.name = world.robot_config(i).name;
    output.rig = sequence_rig(world.sensor_rig(i), format);
    output.sink = core::make_dataset_writer(out / output.name, format, output.rig, logger);
    outputs.push_back(std::move(output));
  }
  return outputs;
}

// EuRoC and TUM-VI hold gray images and no depth; converting here says so once in the log instead of the
// writer warning about it.
void prepare_for_mav0(core::SensorFrame& frame) {
  if (frame.image.channels() == 3) cv::cvtColor(frame.image, frame.image, cv::COLOR_BGR2GRAY);
  if (frame.right.channels() == 3) cv::cvtColor(frame.right, frame.right, cv::COLOR_BGR2GRAY);
  frame.depth_m.release();
}

// Steps the world to its end and hands each written robot's frames to its sink.
void run_world(sim::World& world, const fs::path& out, std::vector<RobotOutput>& outputs, core::DatasetFormat format,
               const core::Logger& logger) {
  const bool mav0 = format != core::DatasetFormat::kTumRgbd;
  if (mav0) logger->info("{} layout: images written gray, depth maps left out", core::to_string(format));
  core::Progress progress =
      make_progress(static_cast<std::size_t>(std::max<core::TimeNs>(world.end_ns() / 1000000, 1)), "simulated ms", logger);
  while (!world.finished()) {
    for (core::SensorFrame& frame : world.step()) {
      const auto output = std::find_if(outputs.begin(), outputs.end(), [&](const RobotOutput& o) {
        return o.index == static_cast<std::size_t>(frame.robot_id);
      });
      if (output == outputs.end()) continue;  // a robot of the world that is not written
      if (mav0) prepare_for_mav0(frame);
      output->sink->write(frame);
    }
    progress.update(static_cast<std::size_t>(world.time_ns() / 1000000));
  }
  progress.finish();
  // The settings go into each finished sequence's folder (the writer makes it complete at close()).
  for (RobotOutput& output : outputs) {
    output.sink->close();
    core::write_orbslam_settings(out / output.name / kSettingsFile, orbslam_settings(output.rig));
  }
}

void run_generate(const GenerateOptions& options, const GlobalOptions& global) {
  const core::Logger logger = make_cli_logger("generate", global);
  const fs::path out = options.out;
  check_output_folder(out);
  const core::DatasetFormat format = options.format == "tum"     ? core::DatasetFormat::kTumRgbd
                                     : options.format == "tumvi" ? core::DatasetFormat::kTumVi
                                                                 : core::DatasetFormat::kEuroc;
  const sim::ScenarioConfig scenario = load(options);
  const std::vector<std::size_t> selected = select_robots(options, scenario, logger);
  check_robots(options, scenario, selected, format);

  // Every robot of the scenario runs (they share the world), only the selected ones are written.
  create_output_folder(out);
  sim::World world(scenario, logger);
  write_effective_scenario(out / kScenarioFile, scenario);
  std::vector<RobotOutput> outputs = open_outputs(out, world, selected, format, logger);
  run_world(world, out, outputs, format, logger);
  for (const RobotOutput& output : outputs) {
    std::cout << output.name << ": " << output.sink->frames_written() << " frames ("
              << core::to_string(output.rig.mode) << ") -> " << (out / output.name).string() << "\n";
  }
  std::cout << "wrote " << outputs.size() << " " << core::to_string(format) << " sequence(s) of "
            << scenario.duration_s << " s to " << out.string() << "\n";
}

}  // namespace

void add_generate_command(CLI::App& app, const GlobalOptions& global) {
  auto options = std::make_shared<GenerateOptions>();
  CLI::App* generate = app.add_subcommand(
      "generate", "Run a scenario and write each robot's sensor stream as a TUM RGB-D, EuRoC or TUM-VI "
                  "sequence with ORB-SLAM3 settings");
  generate->add_option("scenario", options->scenario, "Scenario YAML file")->required();
  generate->add_option("--format", options->format,
                       "Layout: tum (RGB-D, needs depth), euroc (gray, IMU, stereo; state ground truth) or tumvi "
                       "(as euroc, with mocap0/ pose ground truth)")
      ->required()
      ->transform(CLI::Validator(
          [](std::string& format) -> std::string {
            if (format == "tum_rgbd") format = "tum";  // the name --format takes elsewhere
            if (format == "tum" || format == "euroc" || format == "tumvi") return {};
            return "'" + format + "' is no layout to write: tum (or tum_rgbd), euroc or tumvi";
          },
          "{tum,tum_rgbd,euroc,tumvi}"));
  generate->add_option("--out", options->out, "Output folder (new or empty)")->required();
  generate->add_option("--duration", options->duration_s, "Seconds to simulate (default: the scenario's)");
  generate->add_option("--robots", options->robots, "Robots to write, comma-separated (default: all with a camera)")
      ->delimiter(',');
  generate->callback([options, generate, &global] {
    options->duration_given = generate->count("--duration") > 0;
    run_generate(*options, global);
  });
}

}  // namespace fleetslam::tools
