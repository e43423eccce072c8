// End-to-end tests of `fleetslam generate`: a tiny scenario (a box room with coloured boxes, an RGB-D
// diff-drive robot and a stereo RGB-D free rig, 64x48, 1 s) written as TUM RGB-D and as EuRoC, read back
// through core::open_dataset and compared with what sim::World gives for the same scenario (it is
// deterministic); and the requests the command must refuse with one clear line.

#include <gtest/gtest.h>

#include "cli_test_util.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iterator>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "fleetslam/core/dataset.hpp"
#include "fleetslam/core/orbslam_settings.hpp"
#include "fleetslam/core/se3.hpp"
#include "fleetslam/core/trajectory.hpp"
#include "fleetslam/sim/scenario.hpp"
#include "fleetslam/sim/world.hpp"

namespace fleetslam {
namespace {

namespace fs = std::filesystem;
using test::read_text;

constexpr double kPoseTolerance = 1e-9;        // metres and radians
constexpr double kDepthTolerance = 1.0 / 5000;  // one raw unit of the TUM depth PNGs

const char* const kScene = R"(<mujoco model="box_room">
  <worldbody>
    <light pos="0 0 3" dir="0 0 -1" castshadow="false"/>
    <geom name="floor" type="plane" size="3 3 0.1" rgba="0.6 0.6 0.6 1"/>
    <geom name="wall_n" type="box" pos="0 3 1" size="3 0.05 1" rgba="0.8 0.7 0.6 1"/>
    <geom name="wall_s" type="box" pos="0 -3 1" size="3 0.05 1" rgba="0.6 0.7 0.8 1"/>
    <geom name="wall_e" type="box" pos="3 0 1" size="0.05 3 1" rgba="0.7 0.8 0.6 1"/>
    <geom name="wall_w" type="box" pos="-3 0 1" size="0.05 3 1" rgba="0.8 0.6 0.7 1"/>
    <geom name="red" type="box" pos="2 0.5 0.3" size="0.3 0.3 0.3" rgba="1 0 0 1"/>
    <geom name="green" type="box" pos="2 -0.8 0.2" size="0.2 0.2 0.2" rgba="0 1 0 1"/>
    <geom name="blue" type="box" pos="1 2 0.4" size="0.25 0.25 0.4" rgba="0 0 1 1"/>
  </worldbody>
</mujoco>
)";

// alpha: RGB-D on a diff-drive base; beta: a stereo pair with depth on a free rig. Both carry an IMU.
const char* const kScenario = R"(scene: scene.xml
duration_s: 1.0
seed: 3
robots:
  - name: alpha
    type: diff_drive
    initial_pose: {x: -0.5, y: 0.0, yaw_deg: 0}
    camera: {width: 64, height: 48, fovy_deg: 60, rate_hz: 20, depth: true}
    waypoints: [{x: 0.5, y: 0.0}]
  - name: beta
    type: free_rig
    initial_pose: {x: 0.0, y: 1.0, z: 1.0}
    camera: {width: 64, height: 48, fovy_deg: 60, rate_hz: 15, depth: true}
    stereo: {enabled: true, baseline_m: 0.1}
    waypoints: [{t_s: 0, x: 0, y: 1, z: 1}, {t_s: 2, x: 0.5, y: 1.2, z: 1.1, yaw_deg: 20}]
)";

// What the simulator gives for the scenario: every robot's frames and rig.
struct Simulated {
  std::vector<std::string> names;
  std::vector<std::vector<core::SensorFrame>> frames;  // per robot
  std::vector<core::SensorRig> rigs;
};

Simulated simulate(const fs::path& scenario_file) {
  sim::World world(sim::load_scenario(scenario_file), core::null_logger());
  Simulated out;
  out.frames.resize(world.robot_count());
  for (std::size_t i = 0; i < world.robot_count(); ++i) {
    out.names.push_back(world.robot_config(i).name);
    out.rigs.push_back(world.sensor_rig(i));
  }
  while (!world.finished()) {
    for (core::SensorFrame& frame : world.step()) {
      out.frames[static_cast<std::size_t>(frame.robot_id)].push_back(std::move(frame));
    }
  }
  return out;
}

std::vector<core::SensorFrame> read_all(const fs::path& root) {
  const auto source = core::open_dataset(root, std::nullopt, {}, core::null_logger());
  std::vector<core::SensorFrame> frames;
  while (auto frame = source->next()) frames.push_back(std::move(*frame));
  return frames;
}

std::size_t imu_samples(const std::vector<core::SensorFrame>& frames) {
  std::size_t count = 0;
  for (const core::SensorFrame& frame : frames) count += frame.imu.size();
  return count;
}

void expect_same_pose(const Eigen::Isometry3d& read, const Eigen::Isometry3d& simulated) {
  EXPECT_LT((read.translation() - simulated.translation()).norm(), kPoseTolerance);
  EXPECT_LT(core::rotation_angle_rad(read.linear().transpose() * simulated.linear()), kPoseTolerance);
}

// Stamps, ground truth and IMU samples as the simulator gave them.
void expect_same_stream(const std::vector<core::SensorFrame>& read, const std::vector<core::SensorFrame>& simulated,
                        bool gyro_kept) {
  ASSERT_GE(simulated.size(), 15u);  // a second at 15 or 20 Hz
  EXPECT_GT(imu_samples(simulated), 150u);  // and at 200 Hz
  ASSERT_EQ(read.size(), simulated.size());
  EXPECT_EQ(imu_samples(read), imu_samples(simulated));
  for (std::size_t k = 0; k < read.size(); ++k) {
    SCOPED_TRACE("frame " + std::to_string(k));
    EXPECT_EQ(read[k].t_ns, simulated[k].t_ns);
    ASSERT_TRUE(read[k].T_world_cam_gt.has_value());
    expect_same_pose(*read[k].T_world_cam_gt, *simulated[k].T_world_cam_gt);
    ASSERT_EQ(read[k].imu.size(), simulated[k].imu.size());
    for (std::size_t j = 0; j < read[k].imu.size(); ++j) {
      EXPECT_EQ(read[k].imu[j].t_ns, simulated[k].imu[j].t_ns);
      EXPECT_EQ(read[k].imu[j].accel_mps2, simulated[k].imu[j].accel_mps2);
      if (gyro_kept) {
        EXPECT_EQ(read[k].imu[j].gyro_radps, simulated[k].imu[j].gyro_radps);
      }
    }
  }
}

// The mav0 ground-truth file of a simulated robot: a row at every IMU sample and every frame, in time
// order, one per instant, each the simulator's body pose there; `columns` per row (17: with the state).
void expect_truth_at_every_instant(const fs::path& file, const std::vector<core::SensorFrame>& simulated,
                                   const Eigen::Isometry3d& T_body_cam0, std::size_t columns) {
  std::vector<std::pair<core::TimeNs, Eigen::Isometry3d>> expected;
  for (const core::SensorFrame& frame : simulated) {
    ASSERT_EQ(frame.imu_truth.size(), frame.imu.size());
    for (const core::ImuTruth& truth : frame.imu_truth) expected.emplace_back(truth.t_ns, truth.T_world_body);
    expected.emplace_back(frame.t_ns, *frame.T_world_cam_gt * T_body_cam0.inverse());
  }
  std::stable_sort(expected.begin(), expected.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  expected.erase(std::unique(expected.begin(), expected.end(), [](const auto& a, const auto& b) { return a.first == b.first; }),
                 expected.end());
  std::ifstream in(file);
  ASSERT_TRUE(in.good()) << file;
  std::string line;
  std::getline(in, line);  // header
  std::size_t row = 0;
  while (std::getline(in, line)) {
    std::vector<double> f;
    std::stringstream fields(line);
    for (std::string field; std::getline(fields, field, ',');) f.push_back(std::stod(field));
    ASSERT_LT(row, expected.size());
    SCOPED_TRACE("row " + std::to_string(row));
    ASSERT_EQ(f.size(), columns);
    EXPECT_EQ(std::stoll(line.substr(0, line.find(','))), expected[row].first);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(f[1], f[2], f[3]);
    T.linear() = Eigen::Quaterniond(f[4], f[5], f[6], f[7]).normalized().toRotationMatrix();
    EXPECT_LT((T.matrix() - expected[row].second.matrix()).cwiseAbs().maxCoeff(), 1e-9);
    ++row;
  }
  EXPECT_EQ(row, expected.size());
  EXPECT_GE(row, imu_samples(simulated));  // at least the IMU's rate (frames off its ticks add rows)
}

// Largest depth difference over the pixels the simulator measured (0 = no measurement), which must be
// most of the image in a closed room.
double worst_depth_error(const cv::Mat& read, const cv::Mat& simulated) {
  double worst = 0.0;
  int measured = 0;
  for (int v = 0; v < simulated.rows; ++v) {
    for (int u = 0; u < simulated.cols; ++u) {
      const double truth = simulated.at<float>(v, u);
      if (!(truth > 0.0)) continue;
      worst = std::max(worst, std::abs(static_cast<double>(read.at<float>(v, u)) - truth));
      ++measured;
    }
  }
  EXPECT_GT(measured, simulated.rows * simulated.cols / 2);
  return worst;
}

cv::Mat gray(const cv::Mat& image) {
  if (image.channels() == 1) return image;
  cv::Mat out;
  cv::cvtColor(image, out, cv::COLOR_BGR2GRAY);
  return out;
}

void expect_same_camera(const core::PinholeCamera& read, const core::PinholeCamera& rig) {
  EXPECT_EQ(read.width(), rig.width());
  EXPECT_EQ(read.height(), rig.height());
  EXPECT_EQ(read.fx(), rig.fx());
  EXPECT_EQ(read.fy(), rig.fy());
  EXPECT_EQ(read.cx(), rig.cx());
  EXPECT_EQ(read.cy(), rig.cy());
}

class GenerateCli : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("fleetslam_generate_cli_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    std::ofstream(dir_ / "scene.xml") << kScene;
    std::ofstream(dir_ / "scenario.yaml") << kScenario;
  }
  void TearDown() override { fs::remove_all(dir_); }

  struct Result {
    int exit_code = -1;
    std::string out;
    std::string err;
  };

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

  // Runs generate into dir_/<name> and returns that folder.
  fs::path generate(const std::string& format, const std::string& name) const {
    const fs::path out = dir_ / name;
    const Result result = run("generate " + quoted(dir_ / "scenario.yaml") + " --format " + format + " --out " +
                              quoted(out));
    EXPECT_EQ(result.exit_code, 0) << result.err;
    return out;
  }

  static std::string quoted(const fs::path& path) { return "'" + path.string() + "'"; }

  // A bad request: exit code 2 and one line on stderr naming `where`.
  void expect_refused(const std::string& arguments, const std::string& where) const {
    const Result result = run(arguments);
    EXPECT_EQ(result.exit_code, 2) << result.err;
    EXPECT_NE(result.err.find(where), std::string::npos) << result.err;
    EXPECT_EQ(result.err.find('\n'), result.err.size() - 1) << "not one line: " << result.err;
  }

  fs::path dir_;
};

TEST_F(GenerateCli, TumSequencesMatchTheSimulator) {
  const fs::path out = generate("tum", "tum");
  const Simulated simulated = simulate(dir_ / "scenario.yaml");
  ASSERT_EQ(simulated.names.size(), 2u);
  EXPECT_TRUE(fs::is_regular_file(out / "scenario.yaml"));
  for (std::size_t i = 0; i < simulated.names.size(); ++i) {
    SCOPED_TRACE(simulated.names[i]);
    const fs::path root = out / simulated.names[i];
    const std::vector<core::SensorFrame> read = read_all(root);
    expect_same_stream(read, simulated.frames[i], /*gyro_kept=*/false);  // TUM keeps the accelerometer
    ASSERT_EQ(read.size(), simulated.frames[i].size());
    for (std::size_t k = 0; k < read.size(); ++k) {
      EXPECT_EQ(cv::norm(read[k].image, simulated.frames[i][k].image, cv::NORM_INF), 0.0);
      EXPECT_LE(worst_depth_error(read[k].depth_m, simulated.frames[i][k].depth_m), kDepthTolerance);
    }
    const core::OrbSlamSettings settings = core::read_orbslam_settings(root / "orbslam_settings.yaml");
    EXPECT_EQ(settings.rig.mode, core::SensorMode::kRgbd);
    expect_same_camera(settings.rig.cam0, simulated.rigs[i].cam0);
    EXPECT_EQ(settings.rig.bf, simulated.rigs[i].bf);  // RGB-D: the virtual baseline, or beta's stereo one
    EXPECT_EQ(settings.rig.depth_scale, 5000.0);
    // The camera's ground truth at every IMU sample and every frame, one row per instant.
    std::vector<core::TimeNs> instants;
    for (const core::SensorFrame& frame : simulated.frames[i]) {
      for (const core::ImuSample& sample : frame.imu) instants.push_back(sample.t_ns);
      instants.push_back(frame.t_ns);
    }
    std::sort(instants.begin(), instants.end());
    instants.erase(std::unique(instants.begin(), instants.end()), instants.end());
    const core::Trajectory groundtruth = core::read_trajectory(root / "groundtruth.txt", core::TrajectoryFormat::kTum);
    ASSERT_EQ(groundtruth.size(), instants.size());
    for (std::size_t k = 0; k < instants.size(); ++k) EXPECT_EQ(groundtruth[k].t_ns, instants[k]);
  }
}

TEST_F(GenerateCli, EurocSequencesMatchTheSimulator) {
  const fs::path out = generate("euroc", "euroc");
  const Simulated simulated = simulate(dir_ / "scenario.yaml");
  for (std::size_t i = 0; i < simulated.names.size(); ++i) {
    SCOPED_TRACE(simulated.names[i]);
    const fs::path root = out / simulated.names[i];
    const std::vector<core::SensorFrame> read = read_all(root);
    expect_same_stream(read, simulated.frames[i], /*gyro_kept=*/true);
    const bool stereo = simulated.rigs[i].cam1.has_value();
    ASSERT_EQ(read.size(), simulated.frames[i].size());
    for (std::size_t k = 0; k < read.size(); ++k) {
      EXPECT_EQ(cv::norm(read[k].image, gray(simulated.frames[i][k].image), cv::NORM_INF), 0.0);
      ASSERT_EQ(read[k].is_stereo(), stereo);
      if (stereo) {
        EXPECT_EQ(cv::norm(read[k].right, gray(simulated.frames[i][k].right), cv::NORM_INF), 0.0);
      }
    }
    const core::OrbSlamSettings settings = core::read_orbslam_settings(root / "orbslam_settings.yaml");
    EXPECT_EQ(settings.rig.mode, stereo ? core::SensorMode::kStereoInertial : core::SensorMode::kMonoInertial);
    expect_same_camera(settings.rig.cam0, simulated.rigs[i].cam0);
    ASSERT_TRUE(settings.rig.T_body_cam0.has_value());
    expect_same_pose(*settings.rig.T_body_cam0, *simulated.rigs[i].T_body_cam0);
    if (stereo) {
      ASSERT_TRUE(settings.rig.cam1.has_value());
      expect_same_camera(*settings.rig.cam1, *simulated.rigs[i].cam1);
      EXPECT_EQ(settings.rig.T_cam0_cam1.translation(), simulated.rigs[i].T_cam0_cam1.translation());  // baseline
      EXPECT_EQ(settings.rig.bf, simulated.rigs[i].bf);
    }
    expect_truth_at_every_instant(root / "mav0" / "state_groundtruth_estimate0" / "data.csv", simulated.frames[i],
                                  *simulated.rigs[i].T_body_cam0, 17);
    // Read back, the frames carry the simulator's truth at their IMU samples again, state included.
    std::size_t samples = 0;
    for (std::size_t k = 0; k < read.size(); ++k) {
      SCOPED_TRACE("frame " + std::to_string(k));
      const std::vector<core::ImuTruth>& want = simulated.frames[i][k].imu_truth;
      ASSERT_EQ(read[k].imu_truth.size(), want.size());
      for (std::size_t j = 0; j < want.size(); ++j) {
        EXPECT_EQ(read[k].imu_truth[j].t_ns, want[j].t_ns);
        expect_same_pose(read[k].imu_truth[j].T_world_body, want[j].T_world_body);
        ASSERT_TRUE(read[k].imu_truth[j].state.has_value() && want[j].state.has_value());
        EXPECT_EQ(read[k].imu_truth[j].state->v_world_mps, want[j].state->v_world_mps);
        EXPECT_EQ(read[k].imu_truth[j].state->accel_bias_mps2, want[j].state->accel_bias_mps2);
      }
      samples += want.size();
    }
    const Result info = run("dataset info " + quoted(root));
    ASSERT_EQ(info.exit_code, 0) << info.err;
    EXPECT_NE(info.out.find(std::to_string(samples) + " with ground truth"), std::string::npos) << info.out;
  }
}

// TUM-VI: EuRoC's layout with the body poses in mocap0/ (pose columns only); read back as TUM-VI.
TEST_F(GenerateCli, TumViSequencesMatchTheSimulator) {
  const fs::path out = generate("tumvi", "tumvi");
  const Simulated simulated = simulate(dir_ / "scenario.yaml");
  for (std::size_t i = 0; i < simulated.names.size(); ++i) {
    SCOPED_TRACE(simulated.names[i]);
    const fs::path root = out / simulated.names[i];
    EXPECT_EQ(core::detect_dataset_format(root), core::DatasetFormat::kTumVi);
    EXPECT_FALSE(fs::exists(root / "mav0" / "state_groundtruth_estimate0"));
    const std::vector<core::SensorFrame> read = read_all(root);
    expect_same_stream(read, simulated.frames[i], /*gyro_kept=*/true);
    ASSERT_EQ(read.size(), simulated.frames[i].size());
    for (std::size_t k = 0; k < read.size(); ++k) {
      EXPECT_EQ(cv::norm(read[k].image, gray(simulated.frames[i][k].image), cv::NORM_INF), 0.0);
    }
    expect_truth_at_every_instant(root / "mav0" / "mocap0" / "data.csv", simulated.frames[i],
                                  *simulated.rigs[i].T_body_cam0, 8);
  }
}

TEST_F(GenerateCli, RobotsDurationAndTheEffectiveScenario) {
  const fs::path out = dir_ / "beta_only";
  const Result result = run("generate " + quoted(dir_ / "scenario.yaml") + " --format euroc --out " + quoted(out) +
                            " --robots beta --duration 0.5");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_FALSE(fs::exists(out / "alpha"));
  EXPECT_EQ(read_all(out / "beta").size(), 8u);  // 15 Hz over [0, 0.5 s)
  // The effective scenario loads from where it was written and says what ran.
  const sim::ScenarioConfig scenario = sim::load_scenario(out / "scenario.yaml");
  EXPECT_EQ(scenario.duration_s, 0.5);
  EXPECT_EQ(scenario.robots.size(), 2u);  // every robot ran; only beta was written
}

TEST_F(GenerateCli, BadRequestsFailWithOneClearLine) {
  const std::string scenario = quoted(dir_ / "scenario.yaml");
  expect_refused("generate " + quoted(dir_ / "nope.yaml") + " --format tum --out " + quoted(dir_ / "a"), "nope.yaml");
  EXPECT_FALSE(fs::exists(dir_ / "a"));

  std::string no_depth = kScenario;
  no_depth.replace(no_depth.find("rate_hz: 15, depth: true"), 24, "rate_hz: 15, depth: false");
  std::ofstream(dir_ / "no_depth.yaml") << no_depth;
  expect_refused("generate " + quoted(dir_ / "no_depth.yaml") + " --format tum --out " + quoted(dir_ / "b"),
                 "no_depth.yaml:robots[1].camera.depth");
  EXPECT_FALSE(fs::exists(dir_ / "b"));

  fs::create_directories(dir_ / "full");
  std::ofstream(dir_ / "full" / "keep.txt") << "precious";
  expect_refused("generate " + scenario + " --format euroc --out " + quoted(dir_ / "full"), "not empty");
  EXPECT_EQ(read_text(dir_ / "full" / "keep.txt"), "precious");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_ / "full"), fs::directory_iterator()), 1);

  expect_refused("generate " + scenario + " --format euroc --out " + quoted(dir_ / "c") + " --robots gamma", "gamma");
  expect_refused("generate " + scenario + " --format euroc --out " + quoted(dir_ / "c") + " --duration 0",
                 "--duration");
  EXPECT_NE(run("generate " + scenario + " --format kitti --out " + quoted(dir_ / "c")).exit_code, 0);
  EXPECT_FALSE(fs::exists(dir_ / "c"));
}

}  // namespace
}  // namespace fleetslam
