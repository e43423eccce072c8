#pragma once
// The data experiments run on: recorded sequences (the real TUM RGB-D and EuRoC excerpts of
// ../shared/data) and synthetic ones rendered from the shipped scenarios through the same writer
// `fleetslam generate --format tum` uses, then read back like any recorded TUM sequence.

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fleetslam/core/dataset.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/core/orbslam_settings.hpp"
#include "fleetslam/core/trajectory.hpp"
#include "fleetslam/slam/agent.hpp"

namespace fleetslam::experiments {

// One sequence an experiment reads.
struct SequenceSpec {
  std::string name;    // short, unique among the experiment's sequences ("tum_fr1_rpy_200", "office/alpha")
  std::string origin;  // "real" or "synthetic"
  std::filesystem::path folder;
  std::optional<core::DatasetFormat> format;  // nullopt: detected
  std::filesystem::path calibration;          // ORB-SLAM settings file (rig, ORB, ThDepth); empty: the dataset's
  std::filesystem::path groundtruth;          // camera poses to score against instead of the dataset's; may be empty
  bool stereo = false;                        // the agent runs stereo (else RGB-D)
  std::string scenario;                       // synthetic: the scenario file it was rendered from
};

// Where the data comes from. An empty path leaves that source out.
struct DataSourcesConfig {
  std::filesystem::path tum_dir;          // a TUM RGB-D folder (rgb.txt, depth.txt, groundtruth.txt)
  std::filesystem::path tum_calibration;  // its ORB-SLAM settings file (TUM1.yaml)
  std::filesystem::path euroc_dir;        // an EuRoC folder (mav0/); ground truth: groundtruth_leftcam_tum.txt if there
  std::vector<std::filesystem::path> scenarios;  // run scenarios to render
  double synthetic_duration_s = 10.0;     // simulated seconds per scenario
  std::filesystem::path synthetic_dir;    // where rendered sequences go (reused when already rendered the same way)
  // Render even when a rendering with the same key (rendering_key) is there: the reuse check does not see
  // the shared libraries (MuJoCo, OSMesa) the program runs with.
  bool rerender = false;
};

// Checks that every given folder and file exists before anything runs: InputError "path: why".
void check_data_sources(const DataSourcesConfig& config);

// The real sequences of `config` (TUM first, then EuRoC).
std::vector<SequenceSpec> real_sequences(const DataSourcesConfig& config);

// What identifies a rendering: the scenario's path and text, the duration, the scene's text, the content
// of every file the scene refers to (file="..." attributes, relative to the file naming them: textures,
// meshes, included MJCF, whose own references are followed; a missing one as missing) and the content of
// `program`, the executable that renders (a rebuilt simulator renders anew). nullopt when `program`
// cannot be read.
std::optional<std::string> rendering_key(const std::filesystem::path& scenario, const std::filesystem::path& scene,
                                         double duration_s, const std::filesystem::path& program);

// Renders each scenario (world only, like `fleetslam generate --format tum`; robots without a depth camera are
// left out) into synthetic_dir/<scenario stem>_<duration>s/<robot>/ and returns one sequence per robot, named
// "<stem>/<robot>". A folder rendered before with the same rendering_key (this program: /proc/self/exe)
// is reused (its rendered.txt records the key); without a key nothing is reused.
std::vector<SequenceSpec> render_synthetic(const DataSourcesConfig& config, const core::Logger& logger);

// Opens frames [start, stop) of a sequence (stop -1: to the end), images loaded, no IMU.
std::unique_ptr<core::FrameSource> open_sequence(const SequenceSpec& spec, std::int64_t start, std::int64_t stop,
                                                 const core::Logger& logger);

// The sequence's ORB-SLAM settings (none for a dataset without a settings file).
std::optional<core::OrbSlamSettings> sequence_settings(const SequenceSpec& spec);

// The agent config `fleetslam replay` would use for the sequence: defaults, the settings file's ORB and
// ThDepth values, and the sensor (stereo or RGB-D).
slam::AgentConfig agent_config_for(const SequenceSpec& spec);

// The ground truth to score an estimate against, as `fleetslam replay` does: the sequence's camera-pose
// file when it has one (TUM layout or an explicit file), else the poses the reader attached to the frames.
core::Trajectory groundtruth_for(const SequenceSpec& spec, const core::FrameSource& source,
                                 const core::Trajectory& per_frame);

}  // namespace fleetslam::experiments
