// fleetslam dataset info|convert: inspect a recorded sequence, or rewrite it in another layout.

#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "cli_util.hpp"
#include "commands.hpp"
#include "fleetslam/core/dataset.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/core/log.hpp"
#include "fleetslam/core/orbslam_settings.hpp"

namespace fleetslam::tools {
namespace {

struct DatasetOptions {
  std::string path;
  std::string format;  // empty: detect
  std::string groundtruth;
  bool groundtruth_body = false;
  std::string calibration;
  bool json = false;
  bool check = false;
  std::string to;
  std::string out;
  std::int64_t start = 0;
  std::int64_t stop = -1;
  std::int64_t stride = 1;
  bool skip_unreadable = false;
};

std::unique_ptr<core::FrameSource> open_source(const DatasetOptions& options, core::DatasetConfig config,
                                               const core::Logger& logger) {
  config.groundtruth_file = options.groundtruth;
  config.groundtruth_in_body_frame = options.groundtruth_body;
  if (!options.calibration.empty()) {
    config.rig = core::read_orbslam_settings(options.calibration).rig;
    config.rig_source = options.calibration;
  }
  std::optional<core::DatasetFormat> format;
  if (!options.format.empty()) format = core::dataset_format_from_string(options.format);
  return core::open_dataset(options.path, format, config, logger);
}

std::string fixed(double value, int decimals) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*f", decimals, value);
  return buffer;
}

nlohmann::json camera_json(const core::PinholeCamera& c) {
  const core::Distortion& d = c.distortion();
  return {{"width", c.width()}, {"height", c.height()}, {"fx", c.fx()}, {"fy", c.fy()}, {"cx", c.cx()},
          {"cy", c.cy()}, {"distortion_model", core::to_string(d.model)},
          {"distortion", d.is_equidistant() ? nlohmann::json{d.k1, d.k2, d.k3, d.k4}
                                            : nlohmann::json{d.k1, d.k2, d.p1, d.p2, d.k3}}};
}

nlohmann::json translation_json(const Eigen::Isometry3d& T) {
  return {T.translation().x(), T.translation().y(), T.translation().z()};
}

nlohmann::json rig_json(const core::SensorRig& rig) {
  nlohmann::json j = {{"mode", core::to_string(rig.mode)}, {"fps", rig.fps}, {"cam0", camera_json(rig.cam0)}};
  if (rig.mode == core::SensorMode::kRgbd) j["depth_scale"] = rig.depth_scale;
  if (rig.cam1) {
    j["cam1"] = camera_json(*rig.cam1);
    j["t_cam0_cam1"] = translation_json(rig.T_cam0_cam1);
    j["baseline_m"] = rig.T_cam0_cam1.translation().norm();
  }
  if (rig.T_body_cam0) j["t_body_cam0"] = translation_json(*rig.T_body_cam0);
  if (rig.imu) {
    j["imu"] = {{"rate_hz", rig.imu->rate_hz}, {"gyro_noise_density", rig.imu->gyro_noise_density},
                {"accel_noise_density", rig.imu->accel_noise_density}};
  }
  return j;
}

nlohmann::json info_json(const core::FrameSource& source) {
  const core::DatasetInfo& info = source.info();
  return {{"path", info.root.string()},
          {"format", core::to_string(info.format)},
          {"frames", info.frames},
          {"listed_frames", info.listed_frames},
          {"skipped_rows", skipped_rows_json(info.skipped)},
          {"first_t_ns", info.first_t_ns},
          {"last_t_ns", info.last_t_ns},
          {"duration_s", info.duration_s()},
          {"rate_hz", info.rate_hz()},
          {"calibration_source", info.calibration_source},
          {"rig", rig_json(source.rig())},
          {"groundtruth_file", info.groundtruth_file},
          {"groundtruth_poses", info.groundtruth_poses},
          {"frames_with_groundtruth", info.frames_with_groundtruth},
          {"imu_file", info.imu_file},
          {"imu_samples", info.imu_samples},
          {"imu_samples_with_groundtruth", info.imu_samples_with_groundtruth},
          {"imu_rate_hz", info.imu_rate_hz},
          {"accelerometer_only", info.accelerometer_only}};
}

std::string camera_text(const char* name, const nlohmann::json& c) {
  std::ostringstream out;
  out << "  " << name << ": " << c["width"] << "x" << c["height"] << "  fx " << c["fx"] << " fy " << c["fy"]
      << " cx " << c["cx"] << " cy " << c["cy"] << "  " << c["distortion_model"].get<std::string>() << " "
      << c["distortion"].dump() << "\n";
  return out.str();
}

void print_info(const nlohmann::json& j, std::ostream& out) {
  out << "dataset:      " << j["path"].get<std::string>() << " (" << j["format"].get<std::string>() << ")\n"
      << "frames:       " << j["frames"] << " (rows listed " << j["listed_frames"] << ", skipped "
      << j["skipped_rows"].size() << ")\n"
      << "time:         " << core::format_seconds(j["first_t_ns"].get<core::TimeNs>(), 6) << " .. "
      << core::format_seconds(j["last_t_ns"].get<core::TimeNs>(), 6) << " s, duration "
      << fixed(j["duration_s"].get<double>(), 3) << " s, rate " << fixed(j["rate_hz"].get<double>(), 2) << " Hz\n";
  const nlohmann::json& rig = j["rig"];
  out << "sensors:      " << rig["mode"].get<std::string>() << "\ncalibration:  "
      << j["calibration_source"].get<std::string>() << "\n"
      << camera_text("cam0", rig["cam0"]);
  if (rig.contains("cam1")) {
    out << camera_text("cam1", rig["cam1"]) << "  baseline " << fixed(rig["baseline_m"].get<double>(), 4) << " m\n";
  }
  if (rig.contains("depth_scale")) out << "  depth scale " << rig["depth_scale"] << " units per metre\n";
  const std::string gt = j["groundtruth_file"];
  out << "ground truth: "
      << (gt.empty() ? std::string("none") : gt + " (" + j["groundtruth_poses"].dump() + " poses), " +
                                                 j["frames_with_groundtruth"].dump() + " of " + j["frames"].dump() +
                                                 " frames covered")
      << "\n";
  const std::string imu = j["imu_file"];
  out << "imu:          "
      << (imu.empty() ? std::string("none") : imu + " (" + j["imu_samples"].dump() + " samples, " +
                                                  fixed(j["imu_rate_hz"].get<double>(), 1) + " Hz" +
                                                  (j["accelerometer_only"].get<bool>() ? ", accelerometer only" : "") + ")" +
                                                  (j["imu_samples_with_groundtruth"].get<std::size_t>() > 0
                                                       ? ", " + j["imu_samples_with_groundtruth"].dump() +
                                                             " with ground truth"
                                                       : std::string()))
      << "\n";
  for (const nlohmann::json& row : j["skipped_rows"]) {
    out << "skipped:      " << row["where"].get<std::string>() << ": " << row["why"].get<std::string>() << "\n";
  }
}

// Decodes every frame (info --check): corrupt images show up as warnings and in the count.
nlohmann::json check_frames(const DatasetOptions& options, const core::Logger& logger) {
  core::DatasetConfig config;
  config.skip_unreadable_frames = true;
  const auto source = open_source(options, config, logger);
  std::size_t decoded = 0;
  while (source->next()) ++decoded;
  return {{"decoded_frames", decoded}, {"unreadable_frames", source->size() - decoded}};
}

void run_info(const DatasetOptions& options, const GlobalOptions& global) {
  const core::Logger logger = make_cli_logger("dataset", global);
  core::DatasetConfig config;
  config.load_images = false;
  config.skip_unreadable_frames = true;  // inspection reports absent images instead of stopping at them
  const auto source = open_source(options, config, logger);
  nlohmann::json j = info_json(*source);
  if (options.check) j["check"] = check_frames(options, logger);
  if (options.json) {
    std::cout << j.dump(2) << "\n";
  } else {
    print_info(j, std::cout);
    if (options.check) {
      std::cout << "check:        " << j["check"]["decoded_frames"] << " frames decoded, "
                << j["check"]["unreadable_frames"] << " unreadable\n";
    }
  }
  // A check that found unreadable frames fails (exit 1), so that scripts can tell.
  if (options.check && j["check"]["unreadable_frames"].get<std::size_t>() > 0) {
    throw CriteriaFailed("dataset check failed: " + std::to_string(j["check"]["unreadable_frames"].get<std::size_t>()) +
                         " of " + std::to_string(source->size()) + " frame(s) of " + options.path +
                         " cannot be decoded (or do not fit the calibration)");
  }
}

void run_convert(const DatasetOptions& options, const GlobalOptions& global) {
  const core::Logger logger = make_cli_logger("dataset", global);
  if (options.stop != -1 && !(options.stop > options.start)) {
    throw InputError("--stop", "must be -1 (to the end) or more than --start (" + std::to_string(options.start) + ")");
  }
  core::DatasetConfig config;
  config.start_index = options.start;
  config.stop_index = options.stop;
  config.stride = options.stride;
  config.skip_unreadable_frames = options.skip_unreadable;
  const auto source = open_source(options, config, logger);
  const core::DatasetFormat to = *core::dataset_format_from_string(options.to);
  // TUM RGB-D needs depth maps, which only RGB-D sources have; inventing them would be meaningless.
  if (to == core::DatasetFormat::kTumRgbd && source->rig().mode != core::SensorMode::kRgbd) {
    throw InputError(options.path, "cannot convert " + core::to_string(source->info().format) +
                                       " to tum_rgbd: the sequence has no depth images (TUM RGB-D needs RGB-D frames)");
  }
  // Nothing selected: refused before the writer lays out an empty sequence in --out.
  if (source->size() == 0) {
    throw InputError(options.path, "no frame to convert from index " + std::to_string(options.start) + " on (the sequence has " +
                                       std::to_string(source->info().listed_frames) + " listed frames)");
  }
  const auto sink = core::make_dataset_writer(options.out, to, source->rig(), logger);
  const std::size_t written = core::copy_frames(*source, *sink, logger);
  if (written == 0) {
    throw InputError(options.path, "no frame to convert from index " + std::to_string(options.start) + " on (the sequence has " +
                                       std::to_string(source->info().listed_frames) + " listed frames); " + options.out +
                                       " holds no frames");
  }
  std::cout << "wrote " << written << " frames to " << options.out << " (" << options.to << ")\n";
}

void add_source_options(CLI::App& command, DatasetOptions& options) {
  command.add_option("path", options.path, "Sequence folder")->required();
  command.add_option("--format", options.format, "Layout (detected when not given)")
      ->transform(dataset_format_check());
  command.add_option("--groundtruth", options.groundtruth,
                     "Ground-truth file of camera poses (TUM, EuRoC csv or KITTI) instead of the dataset's own");
  command.add_flag("--groundtruth-body", options.groundtruth_body,
                   "The --groundtruth file holds body (IMU) poses, as EuRoC's data.csv: turned into camera poses "
                   "by the calibration's body-to-camera transform");
  command.add_option("--calibration", options.calibration,
                     "ORB-SLAM settings file to use instead of the dataset's calibration (needed for TUM-VI "
                     "equidistant cameras and TUM folders of unknown cameras)");
}

}  // namespace

void add_dataset_command(CLI::App& app, const GlobalOptions& global) {
  CLI::App* dataset = app.add_subcommand("dataset", "Inspect or convert a TUM RGB-D / EuRoC / TUM-VI sequence");
  dataset->require_subcommand(1);
  auto options = std::make_shared<DatasetOptions>();

  CLI::App* info = dataset->add_subcommand("info", "Frames, duration, sensors, calibration, ground truth, IMU");
  add_source_options(*info, *options);
  info->add_flag("--json", options->json, "Print JSON instead of text");
  info->add_flag("--check", options->check, "Decode every frame and count unreadable ones (exit 1 when there are)");
  info->callback([options, &global] { run_info(*options, global); });

  CLI::App* convert = dataset->add_subcommand(
      "convert",
      "Rewrite a sequence: tum_rgbd -> tum_rgbd|euroc|tumvi (euroc and tumvi drop depth), euroc/tumvi -> euroc|tumvi");
  add_source_options(*convert, *options);
  convert->add_option("--to", options->to, "Output layout")
      ->required()
      ->transform(CLI::Validator(
          [](std::string& to) -> std::string {
            if (to == "tum") to = "tum_rgbd";  // the alias --format takes
            if (to == "tum_rgbd" || to == "euroc" || to == "tumvi") return {};
            return "'" + to + "' is no layout to write: tum_rgbd (or tum), euroc or tumvi";
          },
          "{tum_rgbd,tum,euroc,tumvi}"));
  convert->add_option("--out", options->out, "Output folder (new or empty)")->required();
  convert->add_option("--start", options->start, "First frame index")->check(whole_number_at_least(0));
  convert->add_option("--stop", options->stop, "One past the last frame index (-1: to the end)");
  convert->add_option("--stride", options->stride, "Keep every n-th frame")->check(whole_number_at_least(1));
  convert->add_flag("--skip-unreadable", options->skip_unreadable, "Skip unreadable frames instead of stopping");
  convert->callback([options, &global] { run_convert(*options, global); });
}

}  // namespace fleetslam::tools
