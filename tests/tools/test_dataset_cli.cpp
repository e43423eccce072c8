// End-to-end tests of `fleetslam dataset info|convert` on the real sequences (skipped when absent).

#include <gtest/gtest.h>

#include "cli_test_util.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "fleetslam/core/dataset.hpp"

namespace fleetslam {
namespace {

namespace fs = std::filesystem;
using test::read_text;

const fs::path kData = FLEETSLAM_DATA_DIR;
const fs::path kTum = kData / "tum" / "rgbd_dataset_freiburg1_rpy_200";
const fs::path kEuroc = kData / "euroc" / "V1_01_easy_micro";
const std::string kEurocGt = "--groundtruth '" + (kEuroc / "groundtruth_leftcam_tum.txt").string() + "'";

#define SKIP_WITHOUT(folder)                                                                       \
  if (!fs::is_directory(folder)) {                                                                 \
    GTEST_SKIP() << "real data not found at " << (folder) << " (set FLEETSLAM_DATA_DIR to the shared data)"; \
  }

// A fresh folder per test.
class DatasetCli : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("fleetslam_dataset_cli_" + std::string(info->name()) + "_" +
                                        std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  struct Result {
    int exit_code = -1;
    std::string out;
    std::string err;
  };

  // Runs the CLI with stdout and stderr kept apart (logs go to stderr, results to stdout).
  Result run(const std::string& arguments) const {
    const std::string command = "'" FLEETSLAM_CLI "' " + arguments + " >'" + (dir_ / "stdout").string() + "' 2>'" +
                                (dir_ / "stderr").string() + "'";
    const int status = std::system(command.c_str());
    Result result;
    result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    result.out = read_text(dir_ / "stdout");
    result.err = read_text(dir_ / "stderr");
    return result;
  }

  nlohmann::json info_json(const std::string& arguments) const {
    const Result result = run("dataset info --json " + arguments);
    EXPECT_EQ(result.exit_code, 0) << result.err;
    return nlohmann::json::parse(result.out);
  }

  static std::string quoted(const fs::path& path) { return "'" + path.string() + "'"; }

  fs::path dir_;
};

TEST_F(DatasetCli, InfoOnTumRgbd) {
  SKIP_WITHOUT(kTum);
  const nlohmann::json j = info_json(quoted(kTum));
  EXPECT_EQ(j["format"], "tum_rgbd");
  EXPECT_EQ(j["frames"], 200);
  EXPECT_EQ(j["frames_with_groundtruth"], 200);
  EXPECT_EQ(j["skipped_rows"].size(), 0u);
  EXPECT_NEAR(j["rate_hz"].get<double>(), 30.0, 0.5);
  EXPECT_EQ(j["rig"]["mode"], "rgbd");
  EXPECT_DOUBLE_EQ(j["rig"]["cam0"]["fx"].get<double>(), 517.3);
  EXPECT_TRUE(j["accelerometer_only"].get<bool>());
  // The layout named as generate and eval name it, or in full.
  for (const char* format : {"tum", "tum_rgbd"}) {
    EXPECT_EQ(info_json(quoted(kTum) + " --format " + format)["format"], "tum_rgbd") << format;
  }
  const Result text = run("dataset info " + quoted(kTum));
  EXPECT_EQ(text.exit_code, 0);
  EXPECT_NE(text.out.find("frames:       200"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("200 of 200 frames covered"), std::string::npos) << text.out;
}

TEST_F(DatasetCli, InfoOnEurocWithGroundTruthFileAndCheck) {
  SKIP_WITHOUT(kEuroc);
  const nlohmann::json j = info_json(quoted(kEuroc) + " --check " + kEurocGt);
  EXPECT_EQ(j["format"], "euroc");
  EXPECT_EQ(j["frames"], 95);
  EXPECT_EQ(j["listed_frames"], 95);
  ASSERT_EQ(j["skipped_rows"].size(), 4u);
  EXPECT_NE(j["skipped_rows"][0]["where"].get<std::string>().find("cam1/data.csv:97"), std::string::npos);
  EXPECT_EQ(j["frames_with_groundtruth"], 74);
  EXPECT_NEAR(j["imu_rate_hz"].get<double>(), 200.0, 0.5);
  EXPECT_EQ(j["rig"]["mode"], "stereo_inertial");
  EXPECT_NEAR(j["rig"]["baseline_m"].get<double>(), 0.1101, 1e-4);
  EXPECT_EQ(j["check"]["decoded_frames"], 95);
  EXPECT_EQ(j["check"]["unreadable_frames"], 0);
}

TEST_F(DatasetCli, CalibrationFromAnOrbSlamSettingsFile) {
  SKIP_WITHOUT(kTum);
  SKIP_WITHOUT(kEuroc);
  nlohmann::json j = info_json(quoted(kTum) + " --calibration " + quoted(kData / "calib" / "TUM1.yaml"));
  EXPECT_DOUBLE_EQ(j["rig"]["cam0"]["fx"].get<double>(), 517.306408);
  EXPECT_NE(j["calibration_source"].get<std::string>().find("TUM1.yaml"), std::string::npos);
  j = info_json(quoted(kEuroc) + " --check --calibration " + quoted(kData / "calib" / "Stereo-Inertial_EuRoC.yaml"));
  EXPECT_EQ(j["rig"]["mode"], "stereo_inertial");
  EXPECT_NEAR(j["rig"]["baseline_m"].get<double>(), 0.1101, 1e-4);
  EXPECT_EQ(j["check"]["decoded_frames"], 95);
  // A calibration that does not fit the images (TUM's 640x480 for EuRoC's 752x480): every frame is
  // unreadable, and the check fails (exit 1) after its report.
  const Result bad = run("dataset info " + quoted(kEuroc) + " --check --calibration " + quoted(kData / "calib" / "TUM1.yaml"));
  EXPECT_EQ(bad.exit_code, 1) << bad.err;
  EXPECT_NE(bad.out.find("0 frames decoded, 95 unreadable"), std::string::npos) << bad.out;
  EXPECT_NE(bad.err.find("dataset check failed: 95 of 95 frame(s)"), std::string::npos) << bad.err;
}

TEST_F(DatasetCli, ConvertTumToTumKeepsFramesBitExact) {
  SKIP_WITHOUT(kTum);
  const fs::path out = dir_ / "tum";
  // "tum" is the alias of tum_rgbd here too, as for --format.
  const Result result = run("dataset convert " + quoted(kTum) + " --to tum --out " + quoted(out) + " --stop 10");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("wrote 10 frames"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("(tum_rgbd)"), std::string::npos) << result.out;
  const nlohmann::json j = info_json(quoted(out));
  EXPECT_EQ(j["frames"], 10);
  EXPECT_EQ(j["frames_with_groundtruth"], 10);
  EXPECT_NE(j["calibration_source"].get<std::string>().find("camera.yaml"), std::string::npos);

  const auto original = core::open_dataset(kTum, std::nullopt, {}, core::null_logger());
  const auto copy = core::open_dataset(out, std::nullopt, {}, core::null_logger());
  EXPECT_EQ(copy->rig().cam0.fx(), original->rig().cam0.fx());
  for (int i = 0; i < 10; ++i) {
    const auto a = original->next();
    const auto b = copy->next();
    ASSERT_TRUE(a && b);
    EXPECT_EQ(a->t_ns, b->t_ns);
    EXPECT_EQ(cv::norm(a->image, b->image, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(a->depth_m, b->depth_m, cv::NORM_INF), 0.0);  // raw -> metres -> raw is exact
    EXPECT_TRUE(a->T_world_cam_gt->isApprox(*b->T_world_cam_gt, 1e-12));
    if (i > 0) {  // frame 0 takes the samples of one median frame period before it
      EXPECT_EQ(a->imu.size(), b->imu.size());
    }
  }
  EXPECT_FALSE(copy->next().has_value());
}

TEST_F(DatasetCli, ConvertEurocToEurocAndTumToEuroc) {
  SKIP_WITHOUT(kEuroc);
  SKIP_WITHOUT(kTum);
  const fs::path out = dir_ / "euroc";
  Result result = run("dataset convert " + quoted(kEuroc) + " --to euroc --out " + quoted(out) + " --start 20 --stop 40 " +
                      kEurocGt);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  nlohmann::json j = info_json(quoted(out));
  EXPECT_EQ(j["frames"], 20);
  EXPECT_EQ(j["rig"]["mode"], "stereo_inertial");
  EXPECT_EQ(j["frames_with_groundtruth"], 19);  // the excerpt's ground truth starts at frame 21
  EXPECT_NEAR(j["rig"]["cam1"]["fx"].get<double>(), 457.587, 1e-12);
  EXPECT_EQ(j["skipped_rows"].size(), 0u);
  // The text names each camera's distortion model (a fisheye cam0 was once printed as radtan).
  Result text = run("dataset info " + quoted(out));
  EXPECT_NE(text.out.find("radial-tangential [-0.28340811"), std::string::npos) << text.out;
  const fs::path cam0 = out / "mav0" / "cam0" / "sensor.yaml";
  std::string sensor = test::read_text(cam0);
  const std::size_t model = sensor.find("distortion_model:");
  ASSERT_NE(model, std::string::npos) << sensor;
  sensor = sensor.substr(0, model) +
           "distortion_model: equidistant\ndistortion_coefficients: [0.0034823894022493434, 0.0007150348452162257, "
           "-0.0020532361418706202, 0.00020293673591811182]\n";
  std::ofstream(cam0) << sensor;
  text = run("dataset info " + quoted(out));
  EXPECT_EQ(text.exit_code, 0) << text.err;
  EXPECT_NE(text.out.find("equidistant [0.0034823894022493434"), std::string::npos) << text.out;

  // The same excerpt in TUM-VI's layout: its ground truth in mocap0/, read back as TUM-VI.
  result = run("dataset convert " + quoted(kEuroc) + " --to tumvi --out " + quoted(dir_ / "vi") + " --start 20 --stop 40 " +
               kEurocGt);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_TRUE(fs::is_regular_file(dir_ / "vi" / "mav0" / "mocap0" / "data.csv"));
  j = info_json(quoted(dir_ / "vi"));
  EXPECT_EQ(j["format"], "tumvi");
  EXPECT_EQ(j["frames"], 20);
  EXPECT_EQ(j["rig"]["mode"], "stereo_inertial");
  EXPECT_EQ(j["frames_with_groundtruth"], 19);

  result = run("dataset convert " + quoted(kTum) + " --to euroc --out " + quoted(dir_ / "mono") + " --stride 20");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.err.find("depth maps dropped"), std::string::npos) << result.err;
  j = info_json(quoted(dir_ / "mono"));
  EXPECT_EQ(j["frames"], 10);
  EXPECT_EQ(j["rig"]["mode"], "monocular");
  EXPECT_EQ(j["frames_with_groundtruth"], 10);
}

TEST_F(DatasetCli, BadRequestsFailWithOneClearLine) {
  SKIP_WITHOUT(kEuroc);
  Result result = run("dataset convert " + quoted(kEuroc) + " --to tum_rgbd --out " + quoted(dir_ / "x"));
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("no depth images"), std::string::npos) << result.err;
  EXPECT_FALSE(fs::exists(dir_ / "x"));

  result = run("dataset info " + quoted(dir_ / "nowhere"));
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("nowhere: no such folder"), std::string::npos) << result.err;
  std::ofstream(dir_ / "a_file") << "x";
  result = run("dataset info " + quoted(dir_ / "a_file"));
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("a_file: is a file; give the sequence's folder"), std::string::npos) << result.err;
  result = run("dataset info " + quoted(kEuroc) + " --groundtruth " + quoted(dir_));
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("is a folder; give the ground-truth file"), std::string::npos) << result.err;

  fs::create_directories(dir_ / "full");
  std::ofstream(dir_ / "full" / "file") << "x";
  result = run("dataset convert " + quoted(kEuroc) + " --to euroc --out " + quoted(dir_ / "full"));
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("not empty"), std::string::npos) << result.err;

  result = run("dataset info " + quoted(kEuroc) + " --format kitti");
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("kitti"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("tum_rgbd"), std::string::npos) << result.err;  // the names it takes
  result = run("dataset info " + quoted(kEuroc) + " --groundtruth " + quoted(dir_ / "gt.txt"));
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("gt.txt: missing ground-truth file"), std::string::npos) << result.err;
  // A frame range that holds no frame is an error, not "wrote 0 frames".
  result = run("dataset convert " + quoted(kEuroc) + " --to euroc --out " + quoted(dir_ / "backwards") + " --start 10 --stop 5");
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("--stop: must be -1 (to the end) or more than --start (10)"), std::string::npos) << result.err;
  result = run("dataset convert " + quoted(kEuroc) + " --to euroc --out " + quoted(dir_ / "beyond") + " --start 100000");
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("no frame to convert from index 100000 on"), std::string::npos) << result.err;
  EXPECT_FALSE(fs::exists(dir_ / "beyond")) << "nothing selected: no empty sequence laid out";
  // Whole-number options say what they take (CLI11's own check printed a range of 300 digits).
  result = run("dataset convert " + quoted(kEuroc) + " --to euroc --out " + quoted(dir_ / "stride") + " --stride 0");
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("--stride: must be at least 1, got 0"), std::string::npos) << result.err;
  result = run("dataset convert " + quoted(kEuroc) + " --to euroc --out " + quoted(dir_ / "stride") + " --start 1.5");
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("--start: must be a whole number, got '1.5'"), std::string::npos) << result.err;
}

}  // namespace
}  // namespace fleetslam
