#include "fleetslam/experiments/sequences.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <map>
#include <optional>
#include <regex>
#include <sstream>
#include <vector>

#include <opencv2/imgproc.hpp>

#include <spdlog/logger.h>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/experiments/table.hpp"
#include "fleetslam/runner/run_config.hpp"
#include "fleetslam/sim/scenario.hpp"
#include "fleetslam/sim/world.hpp"
#include "fleetslam/slam/orbslam_settings.hpp"

namespace fleetslam::experiments {
namespace {

namespace fs = std::filesystem;

constexpr const char* kRenderedFile = "rendered.txt";
constexpr double kRgbdThDepth = 40.0;  // ORB-SLAM3's TUM examples (as `fleetslam generate` writes)

std::string read_whole(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

void require_folder(const fs::path& folder, const std::string& what) {
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) throw InputError(folder.string(), what + ": no such folder");
}

void require_file(const fs::path& file, const std::string& what) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) throw InputError(file.string(), what + ": no such file");
}

// FNV-1a over a file's bytes: a fingerprint that notices a change, not a cryptographic hash (no packaged
// hash is at hand in the project's dependencies, and this needs no more). nullopt when unreadable.
std::optional<std::uint64_t> file_fingerprint(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return std::nullopt;
  std::uint64_t hash = 14695981039346656037ULL;
  std::vector<char> buffer(std::size_t{1} << 16);
  while (in) {
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    for (std::streamsize i = 0; i < in.gcount(); ++i) {
      hash ^= static_cast<unsigned char>(buffer[static_cast<std::size_t>(i)]);
      hash *= 1099511628211ULL;
    }
  }
  if (in.bad()) return std::nullopt;
  return hash;
}

std::string fingerprint_text(const std::optional<std::uint64_t>& hash) {
  if (!hash) return "missing";
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(*hash));
  return text;
}

// The files an MJCF file refers to (file="..." attributes), resolved against its folder, and theirs in
// turn for MJCF files, each once, in the order met.
void referenced_files(const fs::path& mjcf, std::vector<fs::path>& files) {
  static const std::regex kFileAttribute(R"re(\bfile\s*=\s*"([^"]*)")re");
  const std::string text = read_whole(mjcf);
  for (auto it = std::sregex_iterator(text.begin(), text.end(), kFileAttribute); it != std::sregex_iterator(); ++it) {
    fs::path file((*it)[1].str());
    if (file.is_relative()) file = mjcf.parent_path() / file;
    file = file.lexically_normal();
    if (std::find(files.begin(), files.end(), file) != files.end()) continue;
    files.push_back(file);
    if (file.extension() == ".xml") referenced_files(file, files);
  }
}

}  // namespace

std::optional<std::string> rendering_key(const fs::path& scenario, const fs::path& scene, double duration_s,
                                         const fs::path& program) {
  const std::optional<std::uint64_t> program_hash = file_fingerprint(program);
  if (!program_hash) return std::nullopt;
  std::string key = "scenario: " + fs::absolute(scenario).lexically_normal().string() +
                    "\nduration_s: " + fixed(duration_s, 3) + "\nprogram: " + fingerprint_text(program_hash) +
                    "\n--- scenario\n" + read_whole(scenario) + "\n--- scene\n" + read_whole(scene) +
                    "\n--- files the scene refers to\n";
  std::vector<fs::path> files;
  referenced_files(scene, files);
  for (const fs::path& file : files) key += file.string() + ": " + fingerprint_text(file_fingerprint(file)) + "\n";
  return key;
}

namespace {

core::SensorRig tum_rig(core::SensorRig rig) {
  rig.mode = core::SensorMode::kRgbd;
  rig.cam1.reset();
  rig.T_cam0_cam1 = Eigen::Isometry3d::Identity();
  rig.imu.reset();
  return rig;
}

// One scenario's world stepped to its end; each robot with a depth camera written as a TUM sequence.
std::vector<std::string> render_scenario(const sim::ScenarioConfig& world_config, const fs::path& dir,
                                         const core::Logger& logger) {
  sim::World world(world_config, logger);
  std::vector<std::size_t> robots;
  std::vector<std::unique_ptr<core::FrameSink>> sinks;
  std::vector<std::string> names;
  std::vector<core::SensorRig> rigs;
  for (std::size_t i = 0; i < world.robot_count(); ++i) {
    const sim::RobotConfig& robot = world.robot_config(i);
    if (!robot.camera.enabled || !robot.camera.depth) continue;
    rigs.push_back(tum_rig(world.sensor_rig(i)));
    sinks.push_back(core::make_dataset_writer(dir / robot.name, core::DatasetFormat::kTumRgbd, rigs.back(), logger));
    robots.push_back(i);
    names.push_back(robot.name);
  }
  while (!world.finished()) {
    for (core::SensorFrame& frame : world.step()) {
      for (std::size_t k = 0; k < robots.size(); ++k) {
        if (robots[k] == static_cast<std::size_t>(frame.robot_id)) sinks[k]->write(frame);
      }
    }
  }
  // The settings go into each finished sequence's folder (the writer makes it complete at close()).
  for (std::size_t k = 0; k < sinks.size(); ++k) {
    sinks[k]->close();
    core::OrbSlamSettings settings;
    settings.rig = rigs[k];
    settings.th_depth = kRgbdThDepth;
    core::write_orbslam_settings(dir / names[k] / "orbslam_settings.yaml", settings);
  }
  return names;
}

}  // namespace

void check_data_sources(const DataSourcesConfig& config) {
  if (!config.tum_dir.empty()) {
    require_folder(config.tum_dir, "TUM RGB-D sequence");
    require_file(config.tum_dir / "rgb.txt", "TUM RGB-D sequence list");
    if (!config.tum_calibration.empty()) require_file(config.tum_calibration, "TUM calibration");
  }
  if (!config.euroc_dir.empty()) require_folder(config.euroc_dir, "EuRoC sequence");
  for (const fs::path& scenario : config.scenarios) require_file(scenario, "scenario");
  if (!(config.synthetic_duration_s > 0.0 && config.synthetic_duration_s <= 3600.0)) {
    throw InputError("--synthetic-duration", "must be in (0, 3600] seconds");
  }
}

std::vector<SequenceSpec> real_sequences(const DataSourcesConfig& config) {
  std::vector<SequenceSpec> sequences;
  if (!config.tum_dir.empty()) {
    SequenceSpec tum;
    tum.name = "tum/" + config.tum_dir.filename().string();
    tum.origin = "real";
    tum.folder = config.tum_dir;
    tum.format = core::DatasetFormat::kTumRgbd;
    tum.calibration = config.tum_calibration;
    sequences.push_back(tum);
  }
  if (!config.euroc_dir.empty()) {
    SequenceSpec euroc;
    euroc.name = "euroc/" + config.euroc_dir.filename().string();
    euroc.origin = "real";
    euroc.folder = config.euroc_dir;
    euroc.format = core::DatasetFormat::kEuroc;
    euroc.stereo = true;
    const fs::path leftcam = config.euroc_dir / "groundtruth_leftcam_tum.txt";
    std::error_code ec;
    if (fs::is_regular_file(leftcam, ec)) euroc.groundtruth = leftcam;
    sequences.push_back(euroc);
  }
  return sequences;
}

std::vector<SequenceSpec> render_synthetic(const DataSourcesConfig& config, const core::Logger& logger) {
  // Renderings and sequences are named by the file name: two scenarios of one name would share them.
  std::map<std::string, fs::path> by_stem;
  for (const fs::path& scenario_file : config.scenarios) {
    const auto [it, inserted] = by_stem.emplace(scenario_file.stem().string(), scenario_file);
    if (!inserted) {
      throw InputError("--scenario", "'" + it->second.string() + "' and '" + scenario_file.string() +
                                         "' have one name (" + it->first +
                                         "), which names their renderings and sequences: give each its own");
    }
  }
  std::vector<SequenceSpec> sequences;
  for (const fs::path& scenario_file : config.scenarios) {
    sim::ScenarioConfig world = runner::load_run_scenario(scenario_file).world;
    world.duration_s = config.synthetic_duration_s;
    const std::string stem = scenario_file.stem().string();
    const fs::path dir = config.synthetic_dir / (stem + "_" + fixed(config.synthetic_duration_s, 1) + "s");
    const std::optional<std::string> key =
        rendering_key(scenario_file, world.scene_path(), config.synthetic_duration_s, "/proc/self/exe");
    if (!key) logger->info("this program's executable cannot be read: renderings are made anew, not reused");
    std::error_code ec;
    if (config.rerender || !key ||
        !(fs::exists(dir / kRenderedFile, ec) && read_whole(dir / kRenderedFile) == *key)) {
      logger->info("rendering {} ({} s) into {}", scenario_file.string(), config.synthetic_duration_s, dir.string());
      fs::remove_all(dir, ec);
      fs::create_directories(dir, ec);
      if (ec) throw InputError(dir.string(), "cannot create the folder: " + ec.message());
      render_scenario(world, dir, logger);
      write_text(dir / kRenderedFile, key ? *key : std::string("no key: not to be reused\n"));
    } else {
      logger->info("reusing the rendering of {} in {}", scenario_file.string(), dir.string());
    }
    for (const sim::RobotConfig& robot : world.robots) {
      if (!robot.camera.enabled || !robot.camera.depth) continue;
      SequenceSpec spec;
      spec.name = stem + "/" + robot.name;
      spec.origin = "synthetic";
      spec.folder = dir / robot.name;
      spec.format = core::DatasetFormat::kTumRgbd;
      spec.calibration = dir / robot.name / "orbslam_settings.yaml";
      spec.scenario = scenario_file.string();
      sequences.push_back(spec);
    }
  }
  return sequences;
}

std::optional<core::OrbSlamSettings> sequence_settings(const SequenceSpec& spec) {
  if (spec.calibration.empty()) return std::nullopt;
  return core::read_orbslam_settings(spec.calibration);
}

std::unique_ptr<core::FrameSource> open_sequence(const SequenceSpec& spec, std::int64_t start, std::int64_t stop,
                                                 const core::Logger& logger) {
  core::DatasetConfig config;
  config.load_imu = false;
  config.stereo = spec.stereo;
  config.start_index = start;
  config.stop_index = stop;
  config.groundtruth_file = spec.groundtruth.string();
  if (const auto settings = sequence_settings(spec)) {
    config.rig = settings->rig;
    config.rig_source = spec.calibration.string();
  }
  return core::open_dataset(spec.folder, spec.format, config, logger);
}

slam::AgentConfig agent_config_for(const SequenceSpec& spec) {
  slam::AgentConfig config;
  if (const auto settings = sequence_settings(spec)) slam::apply_orbslam_settings(*settings, config.frontend);
  config.sensor = spec.stereo ? slam::AgentSensor::kStereo : slam::AgentSensor::kRgbd;
  return config;
}

core::Trajectory groundtruth_for(const SequenceSpec& spec, const core::FrameSource& source,
                                 const core::Trajectory& per_frame) {
  const std::string& file = source.info().groundtruth_file;
  const bool camera_poses = !spec.groundtruth.empty() || source.info().format == core::DatasetFormat::kTumRgbd;
  if (!file.empty() && camera_poses) {
    core::TrajectoryReadOptions options;
    options.duplicate_stamps = core::DuplicateStamps::kKeepLast;
    return core::read_trajectory_file(file, options).trajectory;
  }
  return per_frame;
}

}  // namespace fleetslam::experiments
