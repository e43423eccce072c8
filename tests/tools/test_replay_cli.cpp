// End-to-end tests of `fleetslam replay`: a short stretch of the real TUM excerpt (skipped when
// ../shared/data is absent) writes every output, and bad input ends with one clear line.

#include <gtest/gtest.h>

#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "cli_test_util.hpp"

#include "fleetslam/core/euroc.hpp"
#include "fleetslam/core/point_cloud.hpp"
#include "fleetslam/core/trajectory.hpp"

namespace fleetslam {
namespace {

namespace fs = std::filesystem;
using test::read_text;
using RunResult = test::CliResult;

test::CliResult run(const std::string& arguments) { return test::run_cli(arguments); }
fs::path test_dir() { return test::fresh_test_dir("fleetslam_test_replay_cli"); }

const fs::path kData = FLEETSLAM_DATA_DIR;
const fs::path kTum = kData / "tum" / "rgbd_dataset_freiburg1_rpy_200";

std::size_t lines(const fs::path& path) {
  const std::string text = read_text(path);
  return static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n'));
}

TEST(ReplayCli, TumExcerptWritesEveryOutput) {
  if (!fs::exists(kTum)) GTEST_SKIP() << "no TUM excerpt at " << kTum;
  const fs::path out = test_dir() / "run";
  const RunResult r = run("-q replay '" + kTum.string() + "' --calibration '" + (kData / "calib" / "TUM1.yaml").string() +
                          "' --max-frames 30 --out '" + out.string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const core::Trajectory trajectory = core::read_trajectory(out / "trajectory.txt");
  EXPECT_EQ(trajectory.size(), 30u);
  EXPECT_GE(core::read_trajectory(out / "keyframes.txt").size(), 1u);
  EXPECT_EQ(lines(out / "timings.csv"), 31u);  // header + one row per frame
  EXPECT_NE(read_text(out / "timings.csv").find("sequence,t_s,status"), std::string::npos);
  EXPECT_GE(lines(out / "keyframe_decisions.csv"), 2u);
  EXPECT_NE(read_text(out / "keyframe_decisions.csv").find("T_H"), std::string::npos);  // exponential factors
  EXPECT_NE(read_text(out / "config.yaml").find("cross_validation:"), std::string::npos);
  std::ifstream metrics_file(out / "metrics.json");
  const nlohmann::json metrics = nlohmann::json::parse(metrics_file);
  EXPECT_EQ(metrics["frames"], 30);
  ASSERT_TRUE(metrics.contains("ate"));
  EXPECT_EQ(metrics["ate"]["pairs"], 30);
  EXPECT_LT(metrics["ate"]["ate_m"]["rmse"].get<double>(), 0.05);
  EXPECT_GT(metrics["tracking_ms"]["median"].get<double>(), 0.0);
}

// EuRoC's own data.csv holds body (IMU) poses: --groundtruth-body turns them into camera poses by the
// calibration's T_BS, and they agree with the excerpt's left-camera file; read as camera poses they do not.
TEST(ReplayCli, GroundTruthOfBodyPosesBecomesCameraPoses) {
  const fs::path euroc = kData / "euroc" / "V1_01_easy_micro";
  if (!fs::exists(euroc)) GTEST_SKIP() << "no EuRoC excerpt at " << euroc;
  const fs::path dir = test_dir();
  // The excerpt has camera poses only: body poses made from them with cam0's T_BS.
  const Eigen::Isometry3d T_body_cam = core::read_euroc_T_BS(euroc / "mav0" / "cam0" / "sensor.yaml");
  core::Trajectory bodies = core::read_trajectory(euroc / "groundtruth_leftcam_tum.txt");
  for (core::StampedPose& p : bodies) p.T_world_body = p.T_world_body * T_body_cam.inverse();
  core::write_trajectory(dir / "body.csv", bodies, core::TrajectoryFormat::kEuroc);
  const std::string body = " --groundtruth '" + (dir / "body.csv").string() + "'";
  const auto per_frame_truth = [&](const std::string& name, const std::string& options) {
    const RunResult r = run("-q replay '" + euroc.string() + "' --format euroc --sensor stereo --max-frames 30" +
                            options + " --out '" + (dir / name).string() + "'");
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return core::read_trajectory(dir / name / "groundtruth.txt");
  };
  const core::Trajectory camera =
      per_frame_truth("camera", " --groundtruth '" + (euroc / "groundtruth_leftcam_tum.txt").string() + "'");
  const core::Trajectory from_body = per_frame_truth("body", body + " --groundtruth-body");
  const core::Trajectory as_camera = per_frame_truth("as_camera", body);
  ASSERT_FALSE(camera.empty());
  ASSERT_EQ(from_body.size(), camera.size());
  ASSERT_EQ(as_camera.size(), camera.size());
  for (std::size_t i = 0; i < camera.size(); ++i) {
    EXPECT_LT((from_body[i].T_world_body.translation() - camera[i].T_world_body.translation()).norm(), 0.002) << i;
  }
  EXPECT_GT((as_camera[0].T_world_body.translation() - camera[0].T_world_body.translation()).norm(), 0.03);
}

TEST(ReplayCli, ConfigOverridesAndIsWrittenBack) {
  if (!fs::exists(kTum)) GTEST_SKIP() << "no TUM excerpt at " << kTum;
  const fs::path dir = test_dir();
  std::ofstream(dir / "agent.yaml") << "keyframes:\n  policy: fixed_interval\n  interval_frames: 5\n"
                                   << "matching:\n  cross_validation: true\n";
  const RunResult r = run("-q replay '" + kTum.string() + "' --config '" + (dir / "agent.yaml").string() +
                          "' --max-frames 12 --out '" + (dir / "run").string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string config = read_text(dir / "run" / "config.yaml");
  EXPECT_NE(config.find("policy: fixed_interval"), std::string::npos) << config;
  EXPECT_NE(config.find("cross_validation: true"), std::string::npos) << config;
  EXPECT_EQ(core::read_trajectory(dir / "run" / "keyframes.txt").size(), 3u);  // frames 0, 5 and 10
}

// The paper's multi-robot experiment (PAPER.md section 5) on the real sequence: its halves as two robots
// with ground-truth priors, merged by the central unit.
TEST(ReplayCli, SplitRunsTheHalvesAsTwoRobotsAndMergesTheirMaps) {
  if (!fs::exists(kTum)) GTEST_SKIP() << "no TUM excerpt at " << kTum;
  const fs::path out = test_dir() / "run";
  const RunResult r = run("-q replay '" + kTum.string() + "' --calibration '" + (kData / "calib" / "TUM1.yaml").string() +
                          "' --split 2 --out '" + out.string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream metrics_file(out / "metrics.json");
  const nlohmann::json metrics = nlohmann::json::parse(metrics_file);
  ASSERT_EQ(metrics["robots"].size(), 2u);
  EXPECT_EQ(metrics["frames"], 200);
  EXPECT_TRUE(metrics["unreadable_frames_skipped"].empty());
  for (const nlohmann::json& robot : metrics["robots"]) {
    EXPECT_EQ(robot["frames"], 100) << robot.dump();
    EXPECT_EQ(robot["tracked"], 100) << robot.dump();
    // Measured: 2.4 cm and 4.4 cm (6.5 cm for the second half with coarse placement only).
    EXPECT_LT(robot["ate_world_m"]["rmse"].get<double>(), 0.06) << robot.dump();
  }
  const nlohmann::json& merge = metrics["merge"];
  EXPECT_EQ(merge["robots"][1]["status"], "fine matched") << merge.dump();
  EXPECT_GT(merge["robots"][1]["overlap_points"].get<int>(), 1000);
  EXPECT_LT(merge["points_after_sampling"].get<int>(), merge["points_before_sampling"].get<int>());
  for (const char* file : {"merged_map.ply", "merge.json", "central_config.yaml", "robot_a/map.ply", "robot_a/trajectory.txt",
                           "robot_b/trajectory.txt", "robot_b/groundtruth.txt"}) {
    EXPECT_TRUE(fs::exists(out / file)) << file;
  }
  EXPECT_EQ(core::read_ply((out / "merged_map.ply").string()).size(), merge["points_after_filter"].get<std::size_t>());
  EXPECT_EQ(core::read_trajectory(out / "robot_b" / "trajectory.txt").size(), 100u);
}

// A part whose first frames start no map (their depth blanked) is placed from the frame that starts it:
// the robot's frame is that frame's camera, so its prior is that frame's true pose, not its first frame's.
TEST(ReplayCli, SplitPlacesAPartFromTheFrameThatStartsItsMap) {
  if (!fs::exists(kTum)) GTEST_SKIP() << "no TUM excerpt at " << kTum;
  const fs::path dir = test_dir();
  const fs::path copy = dir / "tum";
  fs::create_directories(copy / "depth");
  for (const char* file : {"rgb.txt", "depth.txt", "groundtruth.txt", "accelerometer.txt"}) fs::copy_file(kTum / file, copy / file);
  fs::create_directory_symlink(kTum / "rgb", copy / "rgb");
  std::vector<fs::path> depth_files;
  for (const auto& entry : fs::directory_iterator(kTum / "depth")) depth_files.push_back(entry.path());
  std::sort(depth_files.begin(), depth_files.end());
  ASSERT_EQ(depth_files.size(), 200u);
  for (std::size_t i = 0; i < depth_files.size(); ++i) {
    if (i >= 100 && i < 106) {  // part b's first frames: no depth, no map
      ASSERT_TRUE(cv::imwrite((copy / "depth" / depth_files[i].filename()).string(), cv::Mat(480, 640, CV_16UC1, cv::Scalar(0))));
    } else {
      fs::create_symlink(depth_files[i], copy / "depth" / depth_files[i].filename());
    }
  }
  const fs::path out = dir / "run";
  const RunResult r = run("-q replay '" + copy.string() + "' --calibration '" + (kData / "calib" / "TUM1.yaml").string() +
                          "' --split 2 --out '" + out.string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json metrics = nlohmann::json::parse(read_text(out / "metrics.json"));
  const nlohmann::json& b = metrics["robots"][1];
  ASSERT_EQ(b["first_frame"], 100) << b.dump();
  const std::int64_t start = b["map_start_frame"].get<std::int64_t>();
  EXPECT_GE(start, 105) << b.dump();
  EXPECT_EQ(b["tracked"].get<std::int64_t>(), 200 - start);
  // Its prior is the true pose of the frame that started its map.
  const core::Trajectory truth = core::read_trajectory(out / "robot_b" / "groundtruth.txt");
  ASSERT_EQ(truth.size(), 100u);
  const Eigen::Vector3d at_start = truth[static_cast<std::size_t>(start - 100)].T_world_body.translation();
  const nlohmann::json& prior = metrics["merge"]["robots"][1]["T_world_robot_prior"]["t"];
  EXPECT_LT((Eigen::Vector3d(prior[0].get<double>(), prior[1].get<double>(), prior[2].get<double>()) - at_start).norm(), 1e-6)
      << prior.dump();
}

// Input that replay refuses leaves an earlier run's results in --out alone: every check comes before the
// folder is touched. They were removed first, then the options refused.
TEST(ReplayCli, RefusedOptionsLeaveTheEarlierResults) {
  if (!fs::exists(kTum)) GTEST_SKIP() << "no TUM excerpt at " << kTum;
  const fs::path dir = test_dir();
  const fs::path out = dir / "earlier";
  fs::create_directories(out);
  std::ofstream(out / "metrics.json") << "{\"earlier\": true}\n";
  const std::string tum = "-q replay '" + kTum.string() + "' --out '" + out.string() + "'";
  const std::pair<std::string, std::string> refused[] = {
      {" --split 2 --save-map '" + (dir / "m.fsmap").string() + "'", "--split"},
      {" --split 2 --central-config '" + (dir / "absent.yaml").string() + "'", "absent.yaml"},
      {" --split 2 --max-frames 3", "needs at least 4 frames"},
      {" --load-map '" + (dir / "absent.fsmap").string() + "'", "absent.fsmap"},
      {" --central-config '" + (dir / "absent.yaml").string() + "'", "--central-config: needs --split"},
      {" --max-frames 0", "no frames selected"}};
  for (const auto& [options, why] : refused) {
    const RunResult r = run(tum + options);
    EXPECT_EQ(r.exit_code, 2) << options << ": " << r.output;
    EXPECT_NE(r.output.find(why), std::string::npos) << options << ": " << r.output;
    EXPECT_EQ(read_text(out / "metrics.json"), "{\"earlier\": true}\n") << options;
    EXPECT_FALSE(fs::exists(out / "config.yaml")) << options;
  }
}

// TUM RGB-D ground truth given as body poses (--groundtruth-body) is compared through the per-frame
// camera poses made of it, not read raw as camera poses.
TEST(ReplayCli, BodyPoseGroundTruthOfATumSequenceIsNotReadAsCameraPoses) {
  if (!fs::exists(kTum)) GTEST_SKIP() << "no TUM excerpt at " << kTum;
  const fs::path dir = test_dir();
  const fs::path out = dir / "run";
  // A calibration whose body sits 0.5 m beside the camera, turned 90 degrees, and the excerpt's camera
  // poses turned into that body's poses.
  Eigen::Isometry3d T_body_cam = Eigen::Isometry3d::Identity();
  T_body_cam.linear() = Eigen::AngleAxisd(M_PI / 2.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T_body_cam.translation() = Eigen::Vector3d(0.5, 0.0, 0.3);
  std::ofstream(dir / "calibration.yaml")
      << read_text(kData / "calib" / "TUM1.yaml")
      << "\nTbc: !!opencv-matrix\n  rows: 4\n  cols: 4\n  dt: f\n  data: [0,-1,0,0.5, 1,0,0,0, 0,0,1,0.3, 0,0,0,1]\n"
      << "IMU.NoiseGyro: 1.7e-04\nIMU.NoiseAcc: 2.0e-03\nIMU.GyroWalk: 1.9393e-05\nIMU.AccWalk: 3.e-03\nIMU.Frequency: 200.0\n";
  const core::Trajectory cameras = core::read_trajectory(kTum / "groundtruth.txt");
  core::Trajectory bodies = cameras;
  for (core::StampedPose& p : bodies) p.T_world_body = p.T_world_body * T_body_cam.inverse();
  core::write_trajectory(dir / "body.txt", bodies, core::TrajectoryFormat::kTum);
  const RunResult r = run("-q replay '" + kTum.string() + "' --calibration '" + (dir / "calibration.yaml").string() +
                          "' --max-frames 30 --groundtruth '" + (dir / "body.txt").string() +
                          "' --groundtruth-body --out '" + out.string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json metrics = nlohmann::json::parse(read_text(out / "metrics.json"));
  EXPECT_EQ(metrics["ate"]["groundtruth"], "per-frame ground truth of the dataset reader") << metrics["ate"].dump();
  EXPECT_EQ(metrics["ate"]["pairs"], 30);
  EXPECT_LT(metrics["ate"]["ate_m"]["rmse"].get<double>(), 0.03) << metrics["ate"].dump();
  // The per-frame truth is the camera's again: each pose lies on the excerpt's camera trajectory.
  const core::Trajectory per_frame = core::read_trajectory(out / "groundtruth.txt");
  ASSERT_EQ(per_frame.size(), 30u);
  for (const core::StampedPose& p : per_frame) {
    const auto nearest = std::min_element(cameras.begin(), cameras.end(), [&](const core::StampedPose& a, const core::StampedPose& b) {
      return std::llabs(a.t_ns - p.t_ns) < std::llabs(b.t_ns - p.t_ns);
    });
    EXPECT_LT((nearest->T_world_body.translation() - p.T_world_body.translation()).norm(), 0.02) << p.t_ns;
  }
}

TEST(ReplayCli, SplitNeedsEnoughFrames) {
  if (!fs::exists(kTum)) GTEST_SKIP() << "no TUM excerpt at " << kTum;
  const fs::path dir = test_dir();
  const RunResult r = run("replay '" + kTum.string() + "' --split 2 --max-frames 3 --out '" + (dir / "run").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--split 2 needs at least 4 frames"), std::string::npos) << r.output;
}

// A map saved after one run localises a second run over the same frames: every frame tracked, no keyframe
// added, metrics.json says so.
TEST(ReplayCli, SavedMapLocalisesASecondRun) {
  if (!fs::exists(kTum)) GTEST_SKIP() << "no TUM excerpt at " << kTum;
  const fs::path dir = test_dir();
  const std::string common = "-q replay '" + kTum.string() + "' --calibration '" +
                             (kData / "calib" / "TUM1.yaml").string() + "' --max-frames 40";
  const fs::path map = dir / "map.fsmap";
  RunResult r = run(common + " --save-map '" + map.string() + "' --out '" + (dir / "first").string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  ASSERT_TRUE(fs::exists(map));
  std::ifstream first_file(dir / "first" / "metrics.json");
  const nlohmann::json first = nlohmann::json::parse(first_file);
  EXPECT_EQ(first["localization_only"], false);
  EXPECT_EQ(first["saved_map"]["bytes"].get<std::uintmax_t>(), fs::file_size(map));

  r = run(common + " --load-map '" + map.string() + "' --out '" + (dir / "second").string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream second_file(dir / "second" / "metrics.json");
  const nlohmann::json second = nlohmann::json::parse(second_file);
  EXPECT_EQ(second["localization_only"], true);
  EXPECT_EQ(second["loaded_map"]["file"], map.string());
  EXPECT_EQ(second["status_counts"]["tracked"], 40) << second.dump();
  EXPECT_EQ(second["keyframes"], first["keyframes"]);
  EXPECT_EQ(second["map_points"], first["map_points"]);
  EXPECT_LT(second["ate"]["ate_m"]["rmse"].get<double>(), 0.05);
  EXPECT_EQ(core::read_trajectory(dir / "second" / "trajectory.txt").size(), 40u);
  EXPECT_NE(read_text(dir / "second" / "config.yaml").find("localization_only: true"), std::string::npos);
}

TEST(ReplayCli, BadMapFileEndsWithOneLine) {
  if (!fs::exists(kTum)) GTEST_SKIP() << "no TUM excerpt at " << kTum;
  const fs::path dir = test_dir();
  std::ofstream(dir / "foreign.fsmap", std::ios::binary) << "\x89PNG\r\n\x1a\n not a map at all, just some bytes";
  RunResult r = run("-q replay '" + kTum.string() + "' --load-map '" + (dir / "foreign.fsmap").string() + "' --out '" +
                    (dir / "run").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  EXPECT_NE(r.output.find("fleetslam: error: "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("foreign.fsmap"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("not a fleetslam map file"), std::string::npos) << r.output;
  r = run("-q replay '" + kTum.string() + "' --load-map '" + (dir / "missing.fsmap").string() + "' --out '" +
          (dir / "run").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("missing.fsmap"), std::string::npos) << r.output;
  r = run("-q replay '" + kTum.string() + "' --split 2 --load-map '" + (dir / "missing.fsmap").string() + "' --out '" +
          (dir / "run").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  // Outputs of an earlier replay into the same folder go (a split's merged map next to a plain run's
  // results read as this run's); other files stay.
  const fs::path reused = dir / "reused";
  fs::create_directories(reused);
  for (const char* name : {"merged_map.ply", "merge.json", "notes.txt"}) std::ofstream(reused / name) << "earlier";
  r = run("-q replay '" + kTum.string() + "' --max-frames 5 --out '" + reused.string() + "'");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_FALSE(fs::exists(reused / "merged_map.ply"));
  EXPECT_FALSE(fs::exists(reused / "merge.json"));
  EXPECT_TRUE(fs::exists(reused / "notes.txt"));
  EXPECT_TRUE(fs::exists(reused / "metrics.json"));
  // A map whose folder is not there (here a file) is refused before the run: nothing is written.
  std::ofstream(dir / "a_file") << "x";
  const fs::path unsaved = dir / "unsaved";
  r = run("-q replay '" + kTum.string() + "' --max-frames 5 --save-map '" + (dir / "a_file" / "m.fsmap").string() +
          "' --out '" + unsaved.string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("does not exist (--save-map)"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(unsaved));
  // A map that cannot be written (a name too long for the file system) fails the command, but the run's
  // other outputs are written first.
  const std::string long_name = std::string(300, 'm') + ".fsmap";
  r = run("-q replay '" + kTum.string() + "' --max-frames 5 --save-map '" + (dir / long_name).string() +
          "' --out '" + unsaved.string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("mmm.fsmap"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("the map was not saved"), std::string::npos) << r.output;
  EXPECT_EQ(core::read_trajectory(unsaved / "trajectory.txt").size(), 5u);
  const nlohmann::json metrics = nlohmann::json::parse(read_text(unsaved / "metrics.json"));
  EXPECT_TRUE(metrics["saved_map"].contains("error")) << metrics.dump();
}

TEST(ReplayCli, BadVocabularyFileEndsWithOneLine) {
  const fs::path dir = test_dir();
  std::ofstream(dir / "bad.fsvoc", std::ios::binary) << "FSVOCAB";
  RunResult r = run("-q replay '" + (dir / "absent").string() + "' --vocabulary '" + (dir / "bad.fsvoc").string() +
                    "' --out '" + (dir / "run").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  EXPECT_NE(r.output.find("bad.fsvoc"), std::string::npos) << r.output;
  r = run("-q replay '" + (dir / "absent").string() + "' --vocabulary '" + (dir / "missing.fsvoc").string() +
          "' --out '" + (dir / "run").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("missing.fsvoc"), std::string::npos) << r.output;
}

// The first `frames` rows of the TUM excerpt's image lists, with their images, and its other files.
void copy_tum_start(const fs::path& to, int frames) {
  fs::create_directories(to / "rgb");
  fs::create_directories(to / "depth");
  for (const char* list : {"rgb.txt", "depth.txt"}) {
    std::ifstream in(kTum / list);
    std::ofstream out(to / list);
    int rows = 0;
    for (std::string line; std::getline(in, line) && rows < frames;) {
      out << line << "\n";
      if (line.empty() || line[0] == '#') continue;
      ++rows;
      const std::string file = line.substr(line.find(' ') + 1);
      fs::copy_file(kTum / file, to / file);
    }
  }
  for (const char* file : {"groundtruth.txt", "accelerometer.txt"}) fs::copy_file(kTum / file, to / file);
}

// The image file of data row `row` (from 0) of a TUM list.
std::string tum_image(const fs::path& list, int row) {
  std::ifstream in(list);
  int rows = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    if (rows++ == row) return line.substr(line.find(' ') + 1);
  }
  return {};
}

TEST(ReplayCli, UnreadableFrameStopsTheRunButKeepsWhatCameBeforeItOrIsSkipped) {
  if (!fs::exists(kTum)) GTEST_SKIP() << "no TUM excerpt at " << kTum;
  const fs::path dir = test_dir();
  const fs::path sequence = dir / "sequence";
  copy_tum_start(sequence, 12);
  const std::string corrupt = tum_image(sequence / "rgb.txt", 7);
  ASSERT_FALSE(corrupt.empty());
  const std::string png = read_text(sequence / corrupt);
  std::ofstream(sequence / corrupt, std::ios::binary | std::ios::trunc) << png.substr(0, png.size() / 3);
  const std::string common = "-q replay '" + sequence.string() + "' --calibration '" +
                             (kData / "calib" / "TUM1.yaml").string() + "' --out '";

  RunResult r = run(common + (dir / "strict").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("fleetslam: error: "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("rgb.txt:11"), std::string::npos) << r.output;  // 3 header lines + row 7
  EXPECT_NE(r.output.find(fs::path(corrupt).filename().string()), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--skip-unreadable"), std::string::npos) << r.output;
  // The seven frames before it were processed and are written.
  EXPECT_EQ(core::read_trajectory(dir / "strict" / "trajectory.txt").size(), 7u);
  EXPECT_EQ(lines(dir / "strict" / "timings.csv"), 8u);
  std::ifstream strict_file(dir / "strict" / "metrics.json");
  const nlohmann::json strict = nlohmann::json::parse(strict_file);
  EXPECT_EQ(strict["frames"], 7);
  ASSERT_TRUE(strict.contains("stopped_at"));
  EXPECT_NE(strict["stopped_at"]["where"].get<std::string>().find("rgb.txt:11"), std::string::npos);
  EXPECT_TRUE(strict["unreadable_frames_skipped"].empty());
  EXPECT_TRUE(strict.contains("ate"));

  r = run(common + (dir / "skipping").string() + "' --skip-unreadable");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(core::read_trajectory(dir / "skipping" / "trajectory.txt").size(), 11u);
  std::ifstream skipping_file(dir / "skipping" / "metrics.json");
  const nlohmann::json skipping = nlohmann::json::parse(skipping_file);
  EXPECT_EQ(skipping["frames"], 11);
  EXPECT_FALSE(skipping.contains("stopped_at"));
  ASSERT_EQ(skipping["unreadable_frames_skipped"].size(), 1u);
  EXPECT_NE(skipping["unreadable_frames_skipped"][0]["where"].get<std::string>().find("rgb.txt:11"), std::string::npos);
  EXPECT_NE(skipping["unreadable_frames_skipped"][0]["why"].get<std::string>().find("cannot decode"), std::string::npos);

  // A missing image is found while the lists are read: an error before any frame, or a dropped row.
  fs::remove(sequence / tum_image(sequence / "rgb.txt", 4));
  r = run(common + (dir / "absent").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("is absent"), std::string::npos) << r.output;
  r = run(common + (dir / "absent").string() + "' --skip-unreadable");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream absent_file(dir / "absent" / "metrics.json");
  const nlohmann::json absent = nlohmann::json::parse(absent_file);
  EXPECT_EQ(absent["frames"], 10);
  ASSERT_FALSE(absent["skipped_rows"].empty());
  EXPECT_NE(absent["skipped_rows"].dump().find("rgb.txt:8"), std::string::npos) << absent["skipped_rows"].dump();
  EXPECT_EQ(absent["unreadable_frames_skipped"].size(), 1u);
}

// A run that could only end empty-handed is refused, or says why it has no ATE.
TEST(ReplayCli, MonocularRigsUnreadableRunsAndGroundTruthOutsideTheReplayAreSaid) {
  const fs::path dir = test_dir();
  // A monocular EuRoC sequence (one camera, no depth): the agent would never start a map.
  core::SensorRig rig;
  rig.mode = core::SensorMode::kMonocular;
  rig.cam0 = core::PinholeCamera(64, 48, 50.0, 50.0, 31.5, 23.5);
  rig.fps = 20.0;
  {
    core::EurocWriter writer(dir / "mono", rig, nullptr);
    for (int i = 0; i < 3; ++i) {
      core::SensorFrame frame;
      frame.sequence = i;
      frame.t_ns = 1'000'000'000 + i * 50'000'000;
      frame.image = cv::Mat(48, 64, CV_8UC1, cv::Scalar(40 * i));
      writer.write(frame);
    }
    writer.close();
  }
  RunResult r = run("-q replay '" + (dir / "mono").string() + "' --out '" + (dir / "mono_run").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("the agent runs RGB-D or stereo"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "mono_run"));
  r = run("-q replay '" + (dir / "mono").string() + "' --sensor rgbd --out '" + (dir / "mono_run").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("rgbd needs depth images"), std::string::npos) << r.output;

  if (!fs::exists(kTum)) GTEST_SKIP() << "no TUM excerpt at " << kTum << " (the checks above ran)";
  // Every frame unreadable and skipped: nothing was replayed.
  const fs::path sequence = dir / "unreadable";
  copy_tum_start(sequence, 4);
  for (int row = 0; row < 4; ++row) std::ofstream(sequence / tum_image(sequence / "rgb.txt", row), std::ios::trunc) << "x";
  r = run("-q replay '" + sequence.string() + "' --calibration '" + (kData / "calib" / "TUM1.yaml").string() +
          "' --skip-unreadable --out '" + (dir / "unreadable_run").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("no frame could be read"), std::string::npos) << r.output;
  // Ground truth that starts after the replayed frames: no ATE, and a warning saying why.
  const fs::path late_gt = dir / "late_groundtruth.txt";
  core::Trajectory gt = core::read_trajectory(kTum / "groundtruth.txt");
  core::TimeNs first_frame_ns = 0;
  {
    std::ifstream rgb(kTum / "rgb.txt");
    for (std::string line; std::getline(rgb, line);) {
      if (line.empty() || line[0] == '#') continue;
      first_frame_ns = static_cast<core::TimeNs>(std::llround(std::stod(line.substr(0, line.find(' '))) * 1e9));
      break;
    }
  }
  const core::TimeNs t_cut = first_frame_ns + 3'000'000'000;  // 3 s after the first frame: after frame 10
  gt.erase(std::remove_if(gt.begin(), gt.end(), [&](const core::StampedPose& p) { return p.t_ns < t_cut; }), gt.end());
  core::write_trajectory(late_gt, gt, core::TrajectoryFormat::kTum);
  r = run("-q replay '" + kTum.string() + "' --calibration '" + (kData / "calib" / "TUM1.yaml").string() +
          "' --groundtruth '" + late_gt.string() + "' --max-frames 10 --out '" + (dir / "late_run").string() + "'");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("no ATE: " + late_gt.string() + " gives none of the 10 replayed frame(s) a pose"),
            std::string::npos)
      << r.output;
}

TEST(ReplayCli, BadInputEndsWithOneClearLine) {
  const fs::path dir = test_dir();
  RunResult r = run("replay '" + (dir / "absent").string() + "' --out '" + (dir / "run").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("fleetslam: error: "), std::string::npos) << r.output;
  if (!fs::exists(kTum)) GTEST_SKIP() << "no TUM excerpt at " << kTum << " (the checks above ran)";
  std::ofstream(dir / "bad.yaml") << "tracking:\n  no_such_key: 1\n";
  r = run("replay '" + kTum.string() + "' --config '" + (dir / "bad.yaml").string() + "' --out '" +
          (dir / "run").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("bad.yaml"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("no_such_key"), std::string::npos) << r.output;
  r = run("replay '" + kTum.string() + "' --sensor stereo --out '" + (dir / "run").string() + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;  // a TUM RGB-D rig has no second camera
  EXPECT_NE(r.output.find("stereo"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace fleetslam
