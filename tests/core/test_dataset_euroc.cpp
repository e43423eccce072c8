// EuRoC / TUM-VI reader and writer on synthetic sequences written by the writer (seeded content),
// and every kind of bad input the reader must name by file and line (or file and key).

#include <gtest/gtest.h>

#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "dataset_test_util.hpp"
#include "fleetslam/core/dataset.hpp"
#include "fleetslam/core/euroc.hpp"
#include "fleetslam/core/trajectory.hpp"

namespace fleetslam::core {
namespace {

using test::expect_input_error;
using test::TempDir;

constexpr TimeNs kT0 = 1403715273262142976;
constexpr TimeNs kPeriod = 50000000;    // 20 Hz cameras
constexpr TimeNs kImuPeriod = 5000000;  // 200 Hz IMU
constexpr int kFrames = 12;
constexpr int kWidth = 48;
constexpr int kHeight = 32;

SensorRig stereo_rig() {
  std::mt19937 rng(11);
  SensorRig rig;
  rig.mode = SensorMode::kStereoInertial;
  rig.cam0 = PinholeCamera(kWidth, kHeight, 40.0, 41.0, 23.5, 15.5, Distortion{-0.28, 0.07, 0.0002, 1.7e-5, 0.0});
  rig.cam1 = PinholeCamera(kWidth, kHeight, 40.5, 40.2, 24.0, 16.0, Distortion{-0.27, 0.075, -1e-4, 0.0, 0.001});
  rig.T_body_cam0 = test::random_pose(rng);
  rig.T_cam0_cam1 = test::random_pose(rng);
  rig.T_cam0_cam1.translation() = Eigen::Vector3d(0.11, 0.001, -0.002);
  rig.bf = 0.11 * 40.0;
  rig.fps = 20.0;
  ImuNoise noise;
  noise.gyro_noise_density = 1.5e-4;
  noise.accel_random_walk = 2.5e-3;
  rig.imu = noise;
  return rig;
}

SensorRig mono_rig() {
  SensorRig rig = stereo_rig();
  rig.mode = SensorMode::kMonocular;
  rig.cam1.reset();
  rig.imu.reset();
  return rig;
}

// Gray stereo frames, ten IMU samples in (previous frame, frame] each, poses on all frames but 4.
std::vector<SensorFrame> make_frames(std::uint64_t seed, bool stereo = true, bool imu = true) {
  std::mt19937 rng(static_cast<std::mt19937::result_type>(seed));
  std::normal_distribution<double> value(0.0, 1.0);
  std::vector<SensorFrame> frames;
  for (int i = 0; i < kFrames; ++i) {
    SensorFrame frame;
    frame.sequence = i;
    frame.t_ns = kT0 + i * kPeriod;
    frame.image = test::random_image(kWidth, kHeight, CV_8UC1, seed * 100 + static_cast<std::uint64_t>(i));
    if (stereo) frame.right = test::random_image(kWidth, kHeight, CV_8UC1, seed * 100 + 50 + static_cast<std::uint64_t>(i));
    for (TimeNs t = frame.t_ns - kPeriod + kImuPeriod; imu && t <= frame.t_ns; t += kImuPeriod) {
      ImuSample sample;
      sample.t_ns = t;
      sample.gyro_radps = {value(rng), value(rng), value(rng)};
      sample.accel_mps2 = {value(rng), value(rng), 9.81 + value(rng)};
      frame.imu.push_back(sample);
    }
    if (i != 4) frame.T_world_cam_gt = test::random_pose(rng);
    frames.push_back(frame);
  }
  return frames;
}

void write_sequence(const std::filesystem::path& root, const std::vector<SensorFrame>& frames,
                    const SensorRig& rig = stereo_rig()) {
  EurocWriter writer(root, rig, null_logger());
  for (const SensorFrame& frame : frames) writer.write(frame);
  writer.close();
}

std::vector<SensorFrame> read_all(FrameSource& source) {
  std::vector<SensorFrame> frames;
  while (auto frame = source.next()) frames.push_back(std::move(*frame));
  return frames;
}

std::unique_ptr<FrameSource> open(const std::filesystem::path& root, const DatasetConfig& config = {}) {
  return open_dataset(root, std::nullopt, config, null_logger());
}

void expect_same_camera(const PinholeCamera& a, const PinholeCamera& b) {
  EXPECT_EQ(a.width(), b.width());
  EXPECT_EQ(a.height(), b.height());
  EXPECT_EQ(a.K(), b.K());
  EXPECT_EQ(a.distortion().k1, b.distortion().k1);
  EXPECT_EQ(a.distortion().p2, b.distortion().p2);
  EXPECT_EQ(a.distortion().k3, b.distortion().k3);
}

TEST(Euroc, StereoInertialRoundTripKeepsEverything) {
  TempDir dir;
  const SensorRig rig = stereo_rig();
  const std::vector<SensorFrame> written = make_frames(3);
  write_sequence(dir.path(), written, rig);
  EXPECT_EQ(detect_dataset_format(dir.path()), DatasetFormat::kEuroc);
  const auto source = open(dir.path());
  const SensorRig& read_rig = source->rig();
  EXPECT_EQ(read_rig.mode, SensorMode::kStereoInertial);
  expect_same_camera(read_rig.cam0, rig.cam0);
  ASSERT_TRUE(read_rig.cam1.has_value());
  expect_same_camera(*read_rig.cam1, *rig.cam1);
  ASSERT_TRUE(read_rig.T_body_cam0.has_value());
  EXPECT_TRUE(read_rig.T_body_cam0->isApprox(*rig.T_body_cam0, 1e-12));
  EXPECT_TRUE(read_rig.T_cam0_cam1.isApprox(rig.T_cam0_cam1, 1e-12));
  EXPECT_NEAR(read_rig.bf, rig.T_cam0_cam1.translation().norm() * 40.0, 1e-12);
  ASSERT_TRUE(read_rig.imu.has_value());
  EXPECT_EQ(read_rig.imu->gyro_noise_density, 1.5e-4);
  EXPECT_EQ(read_rig.imu->accel_random_walk, 2.5e-3);
  EXPECT_DOUBLE_EQ(read_rig.fps, 20.0);
  EXPECT_EQ(source->info().frames_with_groundtruth, written.size() - 1);
  EXPECT_NEAR(source->info().imu_rate_hz, 200.0, 1e-9);

  const std::vector<SensorFrame> read = read_all(*source);
  ASSERT_EQ(read.size(), written.size());
  for (std::size_t i = 0; i < read.size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(read[i].t_ns, written[i].t_ns);
    EXPECT_TRUE(test::same_image(read[i].image, written[i].image));
    EXPECT_TRUE(test::same_image(read[i].right, written[i].right));
    EXPECT_FALSE(read[i].has_depth());
    ASSERT_EQ(read[i].imu.size(), 10u);  // the samples in (previous frame, frame], the first frame included
    for (std::size_t k = 0; k < read[i].imu.size(); ++k) {
      EXPECT_EQ(read[i].imu[k].t_ns, written[i].imu[k].t_ns);
      EXPECT_EQ(read[i].imu[k].gyro_radps, written[i].imu[k].gyro_radps);
      EXPECT_EQ(read[i].imu[k].accel_mps2, written[i].imu[k].accel_mps2);
    }
    ASSERT_EQ(read[i].T_world_cam_gt.has_value(), written[i].T_world_cam_gt.has_value());
    if (read[i].T_world_cam_gt) {
      EXPECT_TRUE(read[i].T_world_cam_gt->isApprox(*written[i].T_world_cam_gt, 1e-10));
    }
  }
}

TEST(Euroc, MonocularWithoutImuAndStereoSwitchedOff) {
  TempDir dir;
  write_sequence(dir / "mono", make_frames(4, false, false), mono_rig());
  EXPECT_FALSE(std::filesystem::exists(dir / "mono" / "mav0" / "cam1"));
  EXPECT_FALSE(std::filesystem::exists(dir / "mono" / "mav0" / "imu0"));
  auto source = open(dir / "mono");
  EXPECT_EQ(source->rig().mode, SensorMode::kMonocular);
  auto frames = read_all(*source);
  ASSERT_EQ(frames.size(), static_cast<std::size_t>(kFrames));
  EXPECT_FALSE(frames[0].is_stereo());
  EXPECT_TRUE(frames[0].imu.empty());

  write_sequence(dir / "stereo", make_frames(4));
  DatasetConfig config;
  config.stereo = false;
  config.load_imu = false;
  source = open(dir / "stereo" / "mav0", config);  // the mav0 folder itself opens too
  EXPECT_EQ(source->rig().mode, SensorMode::kMonocular);
  frames = read_all(*source);
  EXPECT_FALSE(frames[3].is_stereo());
  EXPECT_TRUE(frames[3].imu.empty());
}

TEST(Euroc, ColourFramesAreWrittenGrayAndStereoRigsNeedRightImages) {
  TempDir dir;
  std::vector<SensorFrame> frames = make_frames(5, false, false);
  for (SensorFrame& frame : frames) frame.image = test::random_image(kWidth, kHeight, CV_8UC3, 9);
  write_sequence(dir / "gray", frames, mono_rig());
  const auto frame = open(dir / "gray")->next();
  ASSERT_TRUE(frame.has_value());
  EXPECT_EQ(frame->image.type(), CV_8UC1);
  expect_input_error([&] { write_sequence(dir / "stereo", make_frames(5, false)); }, {"frame 0", "no right image"});
  frames = make_frames(5);
  frames[2].image = cv::Mat(10, 10, CV_8UC1);
  expect_input_error([&] { write_sequence(dir / "size", frames); }, {"frame 2", "size"});
  // A frame is checked whole before any of it is written: a bad right image or IMU stamps that go back
  // leave no row of it in cam0/data.csv (or an image of it). The failed write stays in .partial.
  frames = make_frames(5);
  frames[2].right = cv::Mat(10, 10, CV_8UC1);
  expect_input_error([&] { write_sequence(dir / "right", frames); }, {"frame 2", "right image size"});
  frames = make_frames(5);
  frames[3].imu.back().t_ns = frames[1].t_ns;
  expect_input_error([&] { write_sequence(dir / "imu", frames); }, {"frame 3", "IMU stamps do not increase"});
  for (const auto& [name, written] : {std::make_pair("right", 2), std::make_pair("imu", 3)}) {
    const std::filesystem::path partial = dir / (std::string(name) + ".partial") / "mav0";
    EXPECT_FALSE(std::filesystem::exists(dir / name)) << name;
    std::size_t rows = 0;
    std::ifstream csv(partial / "cam0" / "data.csv");
    for (std::string line; std::getline(csv, line);) rows += line.empty() || line[0] == '#' ? 0 : 1;
    EXPECT_EQ(rows, static_cast<std::size_t>(written)) << name;
    std::size_t images = 0;
    for (const auto& entry : std::filesystem::directory_iterator(partial / "cam0" / "data")) images += entry.is_regular_file();
    EXPECT_EQ(images, static_cast<std::size_t>(written)) << name;
  }
}

// A rig with an IMU whose frames bring no sample: imu0/ is left out, so the sequence reads back as a rig
// without IMU; the reader refuses an IMU list without samples.
TEST(Euroc, AnImuRigWithoutSamplesWritesNoImuFolder) {
  TempDir dir;
  write_sequence(dir / "seq", make_frames(6, true, false));
  EXPECT_FALSE(std::filesystem::exists(dir / "seq" / "mav0" / "imu0"));
  const auto source = open(dir / "seq");
  EXPECT_FALSE(source->rig().imu.has_value());
  EXPECT_EQ(source->rig().mode, SensorMode::kStereo);
  write_sequence(dir / "inertial", make_frames(6));
  const auto imu_csv = dir / "inertial" / "mav0" / "imu0" / "data.csv";
  test::write_file(imu_csv, "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
                            "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n");
  expect_input_error([&] { open(dir / "inertial"); }, {"imu0/data.csv", "lists no IMU samples"});
}

// Lines of a CSV file after its header, split at commas.
std::vector<std::vector<std::string>> csv_rows(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::vector<std::vector<std::string>> rows;
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::vector<std::string> fields;
    std::stringstream fields_in(line);
    for (std::string field; std::getline(fields_in, field, ',');) fields.push_back(field);
    rows.push_back(fields);
  }
  return rows;
}

// Frames that carry the IMU state (as the simulator's do) get EuRoC's 17-column state ground truth, exact,
// and the reader gives it back with the same poses as from the 8-column file. One posed frame without a
// state, or a rig without an IMU, gives the 8 pose columns.
TEST(Euroc, TheImuStateOfTheFramesIsWrittenAsEurocsStateGroundTruth) {
  TempDir dir;
  std::vector<SensorFrame> frames = make_frames(8);
  std::mt19937 rng(5);
  std::normal_distribution<double> value(0.0, 1.0);
  for (SensorFrame& frame : frames) {
    ImuStateGt state;
    state.v_world_mps = {value(rng), value(rng), value(rng)};
    state.gyro_bias_radps = {1e-3 * value(rng), 1e-3 * value(rng), 1e-3 * value(rng)};
    state.accel_bias_mps2 = {1e-2 * value(rng), 1e-2 * value(rng), 1e-2 * value(rng)};
    frame.imu_state_gt = state;
  }
  write_sequence(dir / "full", frames);
  const auto file = dir / "full" / "mav0" / "state_groundtruth_estimate0" / "data.csv";
  std::ifstream in(file);
  std::string header;
  std::getline(in, header);
  EXPECT_NE(header.find("v_RS_R_x [m s^-1]"), std::string::npos);
  EXPECT_NE(header.find("b_a_RS_S_z [m s^-2]"), std::string::npos);
  const std::vector<std::vector<std::string>> rows = csv_rows(file);
  ASSERT_EQ(rows.size(), frames.size() - 1);  // frame 4 has no pose
  std::size_t row = 0;
  for (const SensorFrame& frame : frames) {
    if (!frame.T_world_cam_gt) continue;
    SCOPED_TRACE(frame.sequence);
    const std::vector<std::string>& f = rows[row++];
    ASSERT_EQ(f.size(), 17u);
    EXPECT_EQ(std::stoll(f[0]), frame.t_ns);
    const ImuStateGt& state = *frame.imu_state_gt;
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(std::stod(f[8 + static_cast<std::size_t>(k)]), state.v_world_mps(k));
      EXPECT_EQ(std::stod(f[11 + static_cast<std::size_t>(k)]), state.gyro_bias_radps(k));
      EXPECT_EQ(std::stod(f[14 + static_cast<std::size_t>(k)]), state.accel_bias_mps2(k));
    }
  }
  write_sequence(dir / "poses", make_frames(8));
  const std::vector<SensorFrame> full = read_all(*open(dir / "full"));
  const std::vector<SensorFrame> poses = read_all(*open(dir / "poses"));
  ASSERT_EQ(full.size(), poses.size());
  for (std::size_t i = 0; i < full.size(); ++i) {
    SCOPED_TRACE(i);
    ASSERT_EQ(full[i].T_world_cam_gt.has_value(), poses[i].T_world_cam_gt.has_value());
    EXPECT_FALSE(poses[i].imu_state_gt.has_value());
    ASSERT_EQ(full[i].imu_state_gt.has_value(), full[i].T_world_cam_gt.has_value());
    if (!full[i].T_world_cam_gt) continue;
    EXPECT_TRUE(full[i].T_world_cam_gt->isApprox(*poses[i].T_world_cam_gt, 1e-15));
    EXPECT_EQ(full[i].imu_state_gt->v_world_mps, frames[i].imu_state_gt->v_world_mps);
    EXPECT_EQ(full[i].imu_state_gt->gyro_bias_radps, frames[i].imu_state_gt->gyro_bias_radps);
    EXPECT_EQ(full[i].imu_state_gt->accel_bias_mps2, frames[i].imu_state_gt->accel_bias_mps2);
  }

  // A given state file of body poses between the frames: states interpolated as the poses are. Given as
  // camera poses, the states are not the camera's: none.
  const auto given = dir / "states.csv";
  std::string text = "#timestamp [ns],p_RS_R_x [m],p_RS_R_y [m],p_RS_R_z [m],q_RS_w [],q_RS_x [],q_RS_y [],q_RS_z []\n";
  for (int k = 0; k < kFrames; ++k) {
    const TimeNs t = kT0 + k * kPeriod - kPeriod / 4;
    const double x = k;
    text += std::to_string(t) + ",0,0,0,1,0,0,0," + std::to_string(x) + ",0,0,0," + std::to_string(2 * x) + ",0,0,0," +
            std::to_string(-x) + "\n";
  }
  test::write_file(given, text);
  DatasetConfig config;
  config.groundtruth_file = given.string();
  config.groundtruth_in_body_frame = true;
  config.max_groundtruth_gap_s = 0.05;  // the rows are a camera period apart
  const std::vector<SensorFrame> interpolated = read_all(*open(dir / "poses", config));
  ASSERT_EQ(interpolated.size(), static_cast<std::size_t>(kFrames));
  EXPECT_FALSE(interpolated.back().imu_state_gt.has_value());  // after the last state
  for (int k = 0; k + 1 < kFrames; ++k) {
    SCOPED_TRACE(k);
    ASSERT_TRUE(interpolated[static_cast<std::size_t>(k)].imu_state_gt.has_value());
    const ImuStateGt& state = *interpolated[static_cast<std::size_t>(k)].imu_state_gt;
    EXPECT_NEAR(state.v_world_mps.x(), k + 0.25, 1e-12);
    EXPECT_NEAR(state.gyro_bias_radps.y(), 2 * (k + 0.25), 1e-12);
    EXPECT_NEAR(state.accel_bias_mps2.z(), -(k + 0.25), 1e-12);
  }
  config.groundtruth_in_body_frame = false;
  for (const SensorFrame& frame : read_all(*open(dir / "poses", config))) EXPECT_FALSE(frame.imu_state_gt.has_value());

  frames[7].imu_state_gt.reset();
  write_sequence(dir / "one_missing", frames);
  for (const auto& f : csv_rows(dir / "one_missing" / "mav0" / "state_groundtruth_estimate0" / "data.csv")) {
    EXPECT_EQ(f.size(), 8u);
  }
  frames[7].imu_state_gt = ImuStateGt{};
  SensorRig no_imu = stereo_rig();
  no_imu.imu.reset();
  no_imu.mode = SensorMode::kStereo;
  write_sequence(dir / "no_imu", frames, no_imu);
  for (const auto& f : csv_rows(dir / "no_imu" / "mav0" / "state_groundtruth_estimate0" / "data.csv")) {
    EXPECT_EQ(f.size(), 8u);
  }
}

// The truth at each IMU sample, with the frames' states.
std::vector<SensorFrame> frames_with_imu_truth(std::uint64_t seed) {
  std::vector<SensorFrame> frames = make_frames(seed);
  const Eigen::Isometry3d T_cam_body = stereo_rig().T_body_cam0->inverse();
  std::mt19937 rng(static_cast<std::mt19937::result_type>(seed + 1));
  std::normal_distribution<double> value(0.0, 1.0);
  const auto random_state = [&] {
    return ImuStateGt{{value(rng), value(rng), value(rng)},
                      {1e-3 * value(rng), 1e-3 * value(rng), 1e-3 * value(rng)},
                      {1e-2 * value(rng), 1e-2 * value(rng), 1e-2 * value(rng)}};
  };
  for (SensorFrame& frame : frames) {
    if (frame.T_world_cam_gt) frame.imu_state_gt = random_state();
    for (const ImuSample& sample : frame.imu) {
      ImuTruth truth{sample.t_ns, test::random_pose(rng), random_state()};
      // At the frame's instant the truth is the frame's.
      if (sample.t_ns == frame.t_ns && frame.T_world_cam_gt) truth = {sample.t_ns, *frame.T_world_cam_gt * T_cam_body, *frame.imu_state_gt};
      frame.imu_truth.push_back(truth);
    }
  }
  return frames;
}

Eigen::Isometry3d pose_of_row(const std::vector<std::string>& f) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(std::stod(f[1]), std::stod(f[2]), std::stod(f[3]));
  T.linear() = Eigen::Quaterniond(std::stod(f[4]), std::stod(f[5]), std::stod(f[6]), std::stod(f[7])).toRotationMatrix();
  return T;
}

// Frames that carry the truth at their IMU samples (as the simulator's do) get a ground-truth row at every
// sample as well as at every frame (EuRoC's runs at the IMU's rate), each exact; the frame without a pose
// is then posed by the reader from the truth at its instant.
TEST(Euroc, TheTruthAtTheImuSamplesIsWrittenAtTheImuRate) {
  TempDir dir;
  const std::vector<SensorFrame> frames = frames_with_imu_truth(21);
  write_sequence(dir / "imu_rate", frames);
  const std::vector<std::vector<std::string>> rows =
      csv_rows(dir / "imu_rate" / "mav0" / "state_groundtruth_estimate0" / "data.csv");
  std::vector<ImuTruth> truth;
  for (const SensorFrame& frame : frames) truth.insert(truth.end(), frame.imu_truth.begin(), frame.imu_truth.end());
  ASSERT_EQ(truth.size(), static_cast<std::size_t>(kFrames) * 10);
  ASSERT_EQ(rows.size(), truth.size());  // every frame's instant is a sample's
  for (std::size_t k = 0; k < rows.size(); ++k) {
    SCOPED_TRACE(k);
    const std::vector<std::string>& f = rows[k];
    ASSERT_EQ(f.size(), 17u);
    EXPECT_EQ(std::stoll(f[0]), truth[k].t_ns);
    EXPECT_TRUE(pose_of_row(f).isApprox(truth[k].T_world_body, 1e-12));
    ASSERT_TRUE(truth[k].state.has_value());
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(std::stod(f[8 + static_cast<std::size_t>(c)]), truth[k].state->v_world_mps(c));
      EXPECT_EQ(std::stod(f[11 + static_cast<std::size_t>(c)]), truth[k].state->gyro_bias_radps(c));
      EXPECT_EQ(std::stod(f[14 + static_cast<std::size_t>(c)]), truth[k].state->accel_bias_mps2(c));
    }
  }
  EXPECT_EQ(open(dir / "imu_rate")->info().imu_samples_with_groundtruth, truth.size());
  const std::vector<SensorFrame> read = read_all(*open(dir / "imu_rate"));
  ASSERT_EQ(read.size(), frames.size());
  const Eigen::Isometry3d T_body_cam0 = *stereo_rig().T_body_cam0;
  for (std::size_t i = 0; i < read.size(); ++i) {
    SCOPED_TRACE(i);
    ASSERT_TRUE(read[i].T_world_cam_gt.has_value());
    const Eigen::Isometry3d expected =
        frames[i].T_world_cam_gt ? *frames[i].T_world_cam_gt : frames[i].imu_truth.back().T_world_body * T_body_cam0;
    EXPECT_LT((read[i].T_world_cam_gt->matrix() - expected.matrix()).cwiseAbs().maxCoeff(), 1e-9);
    // The reader gives the frames the truth at their samples back, state included.
    ASSERT_EQ(read[i].imu_truth.size(), frames[i].imu_truth.size());
    for (std::size_t k = 0; k < read[i].imu_truth.size(); ++k) {
      const ImuTruth& got = read[i].imu_truth[k];
      const ImuTruth& want = frames[i].imu_truth[k];
      EXPECT_EQ(got.t_ns, want.t_ns);
      EXPECT_LT((got.T_world_body.matrix() - want.T_world_body.matrix()).cwiseAbs().maxCoeff(), 1e-9);
      ASSERT_TRUE(got.state.has_value());
      EXPECT_EQ(got.state->v_world_mps, want.state->v_world_mps);
      EXPECT_EQ(got.state->gyro_bias_radps, want.state->gyro_bias_radps);
      EXPECT_EQ(got.state->accel_bias_mps2, want.state->accel_bias_mps2);
    }
  }
  // So a copy of the sequence keeps its ground truth at the IMU's rate (dataset convert).
  write_sequence(dir / "copy", read);
  const auto copied = csv_rows(dir / "copy" / "mav0" / "state_groundtruth_estimate0" / "data.csv");
  ASSERT_EQ(copied.size(), rows.size());
  for (std::size_t k = 0; k < copied.size(); ++k) {
    SCOPED_TRACE(k);
    ASSERT_EQ(copied[k].size(), rows[k].size());
    EXPECT_EQ(copied[k][0], rows[k][0]);
    EXPECT_TRUE(pose_of_row(copied[k]).isApprox(pose_of_row(rows[k]), 1e-12));
    for (std::size_t c = 8; c < rows[k].size(); ++c) EXPECT_EQ(std::stod(copied[k][c]), std::stod(rows[k][c]));
  }

  // Frames without their states: the pose columns alone, still at the IMU's rate.
  std::vector<SensorFrame> stateless = frames;
  for (SensorFrame& frame : stateless) frame.imu_state_gt.reset();
  write_sequence(dir / "poses_only", stateless);
  const auto pose_rows = csv_rows(dir / "poses_only" / "mav0" / "state_groundtruth_estimate0" / "data.csv");
  ASSERT_EQ(pose_rows.size(), truth.size());
  for (const auto& f : pose_rows) EXPECT_EQ(f.size(), 8u);

  // One frame with samples and no truth for them: no rows at its samples, its own row stays.
  std::vector<SensorFrame> gap = frames;
  gap[6].imu_truth.clear();
  ASSERT_TRUE(gap[6].T_world_cam_gt.has_value());
  write_sequence(dir / "gap", gap);
  const auto gap_rows = csv_rows(dir / "gap" / "mav0" / "state_groundtruth_estimate0" / "data.csv");
  EXPECT_EQ(gap_rows.size(), truth.size() - gap[6].imu.size() + 1);
  for (const auto& f : gap_rows) {
    const TimeNs t_ns = std::stoll(f[0]);
    EXPECT_FALSE(t_ns > gap[5].t_ns && t_ns < gap[6].t_ns) << t_ns;
    EXPECT_EQ(f.size(), 17u);  // the states stay: every row left has one
  }

  // Truth at the samples without the IMU's state (motion capture): the pose columns alone.
  std::vector<SensorFrame> no_state = frames;
  no_state[4].imu_truth[1].state.reset();
  write_sequence(dir / "no_state", no_state);
  const auto no_state_rows = csv_rows(dir / "no_state" / "mav0" / "state_groundtruth_estimate0" / "data.csv");
  ASSERT_EQ(no_state_rows.size(), truth.size());
  for (const auto& f : no_state_rows) EXPECT_EQ(f.size(), 8u);

  // Truth at some of a frame's samples only (a drop-out): rows at those, none at the others.
  std::vector<SensorFrame> part = frames;
  part[3].imu_truth.erase(part[3].imu_truth.begin() + 2, part[3].imu_truth.begin() + 5);
  write_sequence(dir / "part", part);
  const auto part_rows = csv_rows(dir / "part" / "mav0" / "state_groundtruth_estimate0" / "data.csv");
  ASSERT_EQ(part_rows.size(), truth.size() - 3);
  for (const auto& f : part_rows) {
    const TimeNs t_ns = std::stoll(f[0]);
    EXPECT_FALSE(t_ns >= frames[3].imu[2].t_ns && t_ns <= frames[3].imu[4].t_ns) << t_ns;
  }

  // Truth that is not at the frame's samples, in their order, is refused, naming the frame, and the frame
  // is not written: off a sample's stamp, out of order, twice at one sample.
  for (const int fault : {0, 1, 2}) {
    SCOPED_TRACE(fault);
    std::vector<SensorFrame> bad = frames;
    if (fault == 0) bad[3].imu_truth[2].t_ns += 1;
    if (fault == 1) std::swap(bad[3].imu_truth[2], bad[3].imu_truth[3]);
    if (fault == 2) bad[3].imu_truth[3] = bad[3].imu_truth[2];
    EurocWriter writer(dir / ("bad" + std::to_string(fault)), stereo_rig(), null_logger());
    for (int i = 0; i < 3; ++i) writer.write(bad[static_cast<std::size_t>(i)]);
    expect_input_error([&] { writer.write(bad[3]); }, {"frame 3", "IMU truth"});
    EXPECT_EQ(writer.frames_written(), 3u);
  }
}

// EuRoC's body frame B need not be the IMU: imu0/sensor.yaml's T_BS places the IMU in B. The body poses
// of the ground truth are B's; the rig's body is the IMU. The frames' camera poses go through cam0's T_BS,
// the truth at the IMU samples is the IMU's pose, and both agree through the rig at a frame's instant.
TEST(Euroc, TheTruthAtTheImuSamplesIsTheImusPoseWhenTheBodyFrameIsNotTheImu) {
  TempDir dir;
  const std::vector<SensorFrame> frames = frames_with_imu_truth(24);
  write_sequence(dir.path(), frames);
  // The written body poses are now B's, with the IMU 0.2 m above B and turned about z.
  Eigen::Isometry3d T_B_imu = Eigen::Isometry3d::Identity();
  T_B_imu.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T_B_imu.translation() = Eigen::Vector3d(0.01, -0.02, 0.2);
  const auto imu_yaml = dir / "mav0" / "imu0" / "sensor.yaml";
  std::string yaml = test::read_file(imu_yaml);
  const std::size_t from = yaml.find("  data: [");
  ASSERT_NE(from, std::string::npos);
  const std::size_t to = yaml.find(']', from);
  std::ostringstream data;
  data.precision(17);
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) data << (r + c == 0 ? "" : ", ") << T_B_imu.matrix()(r, c);
  }
  yaml.replace(from, to - from, "  data: [" + data.str());
  test::write_file(imu_yaml, yaml);

  const std::unique_ptr<FrameSource> source = open(dir.path());
  const Eigen::Isometry3d T_B_cam0 = *stereo_rig().T_body_cam0;  // cam0's T_BS as written
  ASSERT_TRUE(source->rig().T_body_cam0.has_value());
  const Eigen::Isometry3d T_imu_cam0 = *source->rig().T_body_cam0;
  EXPECT_LT((T_imu_cam0.matrix() - (T_B_imu.inverse() * T_B_cam0).matrix()).cwiseAbs().maxCoeff(), 1e-12);
  const std::vector<SensorFrame> read = read_all(*source);
  ASSERT_EQ(read.size(), frames.size());
  for (std::size_t i = 0; i < read.size(); ++i) {
    SCOPED_TRACE(i);
    ASSERT_EQ(read[i].imu_truth.size(), frames[i].imu_truth.size());
    for (std::size_t k = 0; k < read[i].imu_truth.size(); ++k) {
      const Eigen::Isometry3d want = frames[i].imu_truth[k].T_world_body * T_B_imu;  // T_world_B * T_B_imu
      EXPECT_LT((read[i].imu_truth[k].T_world_body.matrix() - want.matrix()).cwiseAbs().maxCoeff(), 1e-9);
    }
    ASSERT_TRUE(read[i].T_world_cam_gt.has_value());
    const ImuTruth& at_frame = read[i].imu_truth.back();
    ASSERT_EQ(at_frame.t_ns, read[i].t_ns);
    EXPECT_LT((read[i].T_world_cam_gt->matrix() - (at_frame.T_world_body * T_imu_cam0).matrix()).cwiseAbs().maxCoeff(),
              1e-9);
  }
}

// Ground truth that starts among a frame's IMU samples: that frame gets the truth at its samples from
// there on, the frames before it none, the frames after it all of theirs.
TEST(Euroc, SamplesBeforeTheGroundTruthGetNoTruth) {
  TempDir dir;
  const std::vector<SensorFrame> frames = frames_with_imu_truth(23);
  write_sequence(dir.path(), frames);
  const auto file = dir / "mav0" / "state_groundtruth_estimate0" / "data.csv";
  std::vector<std::string> lines;
  {
    std::ifstream in(file);
    for (std::string line; std::getline(in, line);) lines.push_back(line);
  }
  ASSERT_EQ(lines.size(), frames.size() * 10 + 1);  // the header, then a row per sample
  {
    std::ofstream out(file, std::ios::trunc);
    out << lines[0] << '\n';
    for (std::size_t k = 1 + 13; k < lines.size(); ++k) out << lines[k] << '\n';  // from frame 1's 4th sample
  }
  EXPECT_EQ(open(dir.path())->info().imu_samples_with_groundtruth, frames.size() * 10 - 13);
  const std::vector<SensorFrame> read = read_all(*open(dir.path()));
  ASSERT_EQ(read.size(), frames.size());
  EXPECT_TRUE(read[0].imu_truth.empty());
  ASSERT_EQ(read[1].imu_truth.size(), read[1].imu.size() - 3);
  for (std::size_t k = 0; k < read[1].imu_truth.size(); ++k) {
    EXPECT_EQ(read[1].imu_truth[k].t_ns, read[1].imu[k + 3].t_ns);
    EXPECT_LT((read[1].imu_truth[k].T_world_body.matrix() - frames[1].imu_truth[k + 3].T_world_body.matrix())
                  .cwiseAbs()
                  .maxCoeff(),
              1e-9);
  }
  EXPECT_TRUE(read[1].T_world_cam_gt.has_value());  // its own instant is within the ground truth
  for (std::size_t i = 2; i < read.size(); ++i) {
    SCOPED_TRACE(i);
    ASSERT_EQ(read[i].imu_truth.size(), read[i].imu.size());
    EXPECT_EQ(read[i].imu_truth.front().t_ns, read[i].imu.front().t_ns);
  }
}

// A drop-out in the ground truth (45 ms without poses, more than max_groundtruth_gap_s) within one frame's
// samples: that frame keeps the truth at its samples on either side, the samples in it get none, and a
// copy of the sequence keeps every row that was read.
TEST(Euroc, ADropOutInTheGroundTruthLeavesOutOnlyTheSamplesInIt) {
  TempDir dir;
  const std::vector<SensorFrame> frames = frames_with_imu_truth(25);
  write_sequence(dir / "source", frames);
  const auto file = dir / "source" / "mav0" / "state_groundtruth_estimate0" / "data.csv";
  std::vector<std::string> lines;
  {
    std::ifstream in(file);
    for (std::string line; std::getline(in, line);) lines.push_back(line);
  }
  ASSERT_EQ(lines.size(), frames.size() * 10 + 1);
  {
    std::ofstream out(file, std::ios::trunc);
    for (std::size_t k = 0; k < lines.size(); ++k) {
      if (k < 1 + 70 + 1 || k > 1 + 70 + 8) out << lines[k] << '\n';  // frame 7's samples 1 .. 8 left out
    }
  }
  EXPECT_EQ(open(dir / "source")->info().imu_samples_with_groundtruth, frames.size() * 10 - 8);
  const std::vector<SensorFrame> read = read_all(*open(dir / "source"));
  ASSERT_EQ(read.size(), frames.size());
  for (std::size_t i = 0; i < read.size(); ++i) {
    SCOPED_TRACE(i);
    std::vector<ImuTruth> want = frames[i].imu_truth;
    if (i == 7) want = {want[0], want[9]};
    ASSERT_EQ(read[i].imu_truth.size(), want.size());
    for (std::size_t k = 0; k < want.size(); ++k) {
      EXPECT_EQ(read[i].imu_truth[k].t_ns, want[k].t_ns);
      EXPECT_LT((read[i].imu_truth[k].T_world_body.matrix() - want[k].T_world_body.matrix()).cwiseAbs().maxCoeff(),
                1e-9);
    }
  }
  write_sequence(dir / "copy", read);
  EXPECT_EQ(csv_rows(dir / "copy" / "mav0" / "state_groundtruth_estimate0" / "data.csv").size(), lines.size() - 1 - 8);
}

// One line of the state ground truth without its last column (past the frames' span, so no frame would
// notice): an error at that line, not the states dropped from the whole sequence.
TEST(Euroc, AStateGroundTruthLineWithoutAColumnIsAnErrorAtThatLine) {
  TempDir dir;
  write_sequence(dir.path(), frames_with_imu_truth(26));
  const auto file = dir / "mav0" / "state_groundtruth_estimate0" / "data.csv";
  const std::size_t lines = static_cast<std::size_t>(kFrames) * 10 + 1;
  std::string last = test::read_file(file);
  last.pop_back();  // the newline
  last = last.substr(last.rfind('\n') + 1);
  test::replace_line(file, lines, last.substr(0, last.rfind(',')));
  expect_input_error([&] { open(dir.path()); },
                     {"state_groundtruth_estimate0/data.csv:" + std::to_string(lines), "16 columns", "17"});
}

// TUM-VI: the same mav0 layout with the body poses in mocap0/data.csv (pose columns only, at the IMU's
// rate from the truth at the samples); read back as TUM-VI with the same ground truth.
TEST(Euroc, TheTumViLayoutHoldsTheGroundTruthInMocap0) {
  TempDir dir;
  const std::vector<SensorFrame> frames = frames_with_imu_truth(22);
  {
    const auto writer = make_dataset_writer(dir / "vi", DatasetFormat::kTumVi, stereo_rig(), null_logger());
    for (const SensorFrame& frame : frames) writer->write(frame);
    writer->close();
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "vi" / "mav0" / "state_groundtruth_estimate0"));
  const auto rows = csv_rows(dir / "vi" / "mav0" / "mocap0" / "data.csv");
  ASSERT_EQ(rows.size(), static_cast<std::size_t>(kFrames) * 10);
  for (const auto& f : rows) EXPECT_EQ(f.size(), 8u);
  EXPECT_EQ(detect_dataset_format(dir / "vi"), DatasetFormat::kTumVi);
  write_sequence(dir / "euroc", frames);
  const auto vi = open(dir / "vi");
  EXPECT_EQ(vi->info().format, DatasetFormat::kTumVi);
  const std::vector<SensorFrame> from_vi = read_all(*vi);
  const std::vector<SensorFrame> from_euroc = read_all(*open(dir / "euroc"));
  ASSERT_EQ(from_vi.size(), from_euroc.size());
  for (std::size_t i = 0; i < from_vi.size(); ++i) {
    SCOPED_TRACE(i);
    ASSERT_TRUE(from_vi[i].T_world_cam_gt && from_euroc[i].T_world_cam_gt);
    EXPECT_TRUE(from_vi[i].T_world_cam_gt->isApprox(*from_euroc[i].T_world_cam_gt, 1e-15));
    EXPECT_FALSE(from_vi[i].imu_state_gt.has_value());  // TUM-VI has no state columns
    EXPECT_EQ(cv::norm(from_vi[i].image, from_euroc[i].image, cv::NORM_INF), 0.0);
    ASSERT_EQ(from_vi[i].imu.size(), from_euroc[i].imu.size());
    // The truth at the samples comes back from both, the state from EuRoC's columns only.
    ASSERT_EQ(from_vi[i].imu_truth.size(), from_vi[i].imu.size());
    ASSERT_EQ(from_euroc[i].imu_truth.size(), from_euroc[i].imu.size());
    for (std::size_t k = 0; k < from_vi[i].imu_truth.size(); ++k) {
      EXPECT_TRUE(from_vi[i].imu_truth[k].T_world_body.isApprox(from_euroc[i].imu_truth[k].T_world_body, 1e-15));
      EXPECT_FALSE(from_vi[i].imu_truth[k].state.has_value());
      EXPECT_TRUE(from_euroc[i].imu_truth[k].state.has_value());
    }
  }
  // A copy of the TUM-VI sequence as EuRoC keeps the IMU-rate poses, without state columns.
  write_sequence(dir / "vi_as_euroc", from_vi);
  const auto converted = csv_rows(dir / "vi_as_euroc" / "mav0" / "state_groundtruth_estimate0" / "data.csv");
  ASSERT_EQ(converted.size(), rows.size());
  for (const auto& f : converted) EXPECT_EQ(f.size(), 8u);
  // No other layout is written by this writer; nothing is created for it.
  EXPECT_THROW(EurocWriter(dir / "tum", stereo_rig(), null_logger(), DatasetFormat::kTumRgbd), InvariantError);
  EXPECT_FALSE(std::filesystem::exists(dir / "tum"));
  EXPECT_FALSE(std::filesystem::exists(dir / "tum.partial"));
}

TEST(Euroc, CamOneRowsPastTheEndAndUnpairedRowsAreSkipped) {
  TempDir dir;
  write_sequence(dir.path(), make_frames(6));
  const auto cam1_csv = dir / "mav0" / "cam1" / "data.csv";
  {
    std::ofstream out(cam1_csv, std::ios::app);
    for (int i = kFrames; i < kFrames + 4; ++i) out << kT0 + i * kPeriod << ',' << kT0 + i * kPeriod << ".png\n";
  }
  auto source = open(dir.path());
  EXPECT_EQ(source->size(), static_cast<std::size_t>(kFrames));
  ASSERT_EQ(source->info().skipped.size(), 4u);
  EXPECT_NE(source->info().skipped[0].where.find("cam1/data.csv:" + std::to_string(kFrames + 2)), std::string::npos);
  EXPECT_NE(source->info().skipped[0].why.find("after the last image present"), std::string::npos);
  EXPECT_EQ(read_all(*source).size(), static_cast<std::size_t>(kFrames));

  // A cam0 row whose partner is not listed: the frame is skipped, its IMU samples go to the next one.
  test::replace_line(cam1_csv, 2 + 5, "# removed");
  source = open(dir.path());
  EXPECT_EQ(source->size(), static_cast<std::size_t>(kFrames - 1));
  EXPECT_NE(source->info().skipped.back().where.find("cam0/data.csv:7"), std::string::npos);
  const auto frames = read_all(*source);
  EXPECT_EQ(frames[5].imu.size(), 20u);
}

TEST(Euroc, GroundTruthFromAGivenFileOfCameraOrBodyPoses) {
  TempDir dir;
  const std::vector<SensorFrame> written = make_frames(7);
  write_sequence(dir / "seq", written);
  Trajectory camera_poses;
  for (const SensorFrame& frame : written) {
    if (frame.T_world_cam_gt) camera_poses.push_back({frame.t_ns, *frame.T_world_cam_gt});
  }
  write_trajectory(dir / "cam_gt.csv", camera_poses, TrajectoryFormat::kEuroc);
  DatasetConfig config;
  config.groundtruth_file = (dir / "cam_gt.csv").string();
  config.load_images = false;
  auto frames = read_all(*open(dir / "seq", config));
  ASSERT_TRUE(frames[0].T_world_cam_gt.has_value());
  EXPECT_TRUE(frames[0].T_world_cam_gt->isApprox(*written[0].T_world_cam_gt, 1e-12));
  // The dataset's own body poses through the explicit option give the same camera poses.
  config.groundtruth_file = (dir / "seq" / "mav0" / "state_groundtruth_estimate0" / "data.csv").string();
  config.groundtruth_in_body_frame = true;
  frames = read_all(*open(dir / "seq", config));
  EXPECT_TRUE(frames[1].T_world_cam_gt->isApprox(*written[1].T_world_cam_gt, 1e-10));
  config.groundtruth_file = (dir / "absent.txt").string();
  expect_input_error([&] { open(dir / "seq", config); }, {"absent.txt", "missing ground-truth file"});
}

// A rig from an ORB-SLAM settings file without IMU keys has no T_body_cam0: the dataset's body poses
// become camera poses through cam0/sensor.yaml's T_BS, and without that file they are left out, never
// taken for camera poses.
TEST(Euroc, BodyPosesNeedABodyToCameraTransformWhenTheRigHasNone) {
  TempDir dir;
  const std::vector<SensorFrame> written = make_frames(21);
  write_sequence(dir.path(), written);
  DatasetConfig config;
  config.rig = mono_rig();
  config.rig->T_body_cam0.reset();
  config.load_images = false;
  auto source = open(dir.path(), config);
  EXPECT_EQ(source->info().frames_with_groundtruth, written.size() - 1);
  auto frames = read_all(*source);
  ASSERT_EQ(frames.size(), written.size());
  for (std::size_t i = 0; i < frames.size(); ++i) {
    SCOPED_TRACE(i);
    ASSERT_EQ(frames[i].T_world_cam_gt.has_value(), written[i].T_world_cam_gt.has_value());
    if (frames[i].T_world_cam_gt) {
      EXPECT_TRUE(frames[i].T_world_cam_gt->isApprox(*written[i].T_world_cam_gt, 1e-10));
    }
  }

  std::filesystem::remove(dir / "mav0" / "cam0" / "sensor.yaml");
  source = open(dir.path(), config);
  EXPECT_EQ(source->info().frames_with_groundtruth, 0u);
  frames = read_all(*source);
  ASSERT_EQ(frames.size(), written.size());
  for (const SensorFrame& frame : frames) EXPECT_FALSE(frame.T_world_cam_gt.has_value());

  // Asked to read a file of body poses, it cannot: an error naming the file.
  config.groundtruth_file = (dir / "mav0" / "state_groundtruth_estimate0" / "data.csv").string();
  config.groundtruth_in_body_frame = true;
  expect_input_error([&] { open(dir.path(), config); },
                     {"state_groundtruth_estimate0/data.csv", "body-to-camera transform is unknown"});
  // Camera poses need no transform.
  config.groundtruth_in_body_frame = false;
  EXPECT_EQ(open(dir.path(), config)->info().frames_with_groundtruth, written.size() - 1);
}

TEST(Euroc, TumViLayoutWithEquidistantCameras) {
  TempDir dir;
  const std::vector<SensorFrame> written = make_frames(8);
  write_sequence(dir.path(), written);
  const auto mav0 = dir / "mav0";
  std::filesystem::create_directories(mav0 / "mocap0");
  std::filesystem::rename(mav0 / "state_groundtruth_estimate0" / "data.csv", mav0 / "mocap0" / "data.csv");
  EXPECT_EQ(detect_dataset_format(dir.path()), DatasetFormat::kTumVi);
  auto source = open(dir.path());
  EXPECT_EQ(source->info().format, DatasetFormat::kTumVi);
  EXPECT_NE(source->info().groundtruth_file.find("mocap0"), std::string::npos);
  EXPECT_EQ(source->info().frames_with_groundtruth, written.size() - 1);

  // TUM-VI's sensor.yaml: distortion_model equidistant, four coefficients k1..k4.
  const std::string yaml = test::read_file(mav0 / "cam0" / "sensor.yaml");
  const std::string equidistant = std::string(yaml).replace(yaml.find("radial-tangential"), 17, "equidistant");
  test::write_file(mav0 / "cam0" / "sensor.yaml", equidistant);
  const Distortion written_d = stereo_rig().cam0.distortion();
  const Distortion read_d = open(dir.path())->rig().cam0.distortion();
  EXPECT_TRUE(read_d.is_equidistant());
  EXPECT_EQ(read_d.k1, written_d.k1);
  EXPECT_EQ(read_d.k3, written_d.p1);  // the file's four numbers, read as k1 k2 k3 k4
  EXPECT_EQ(read_d.k4, written_d.p2);
  const std::string five = std::string(equidistant).replace(equidistant.find("distortion_coefficients: ["), 27,
                                                            "distortion_coefficients: [0.5, ");
  test::write_file(mav0 / "cam0" / "sensor.yaml", five);
  expect_input_error([&] { open(dir.path()); }, {"cam0/sensor.yaml:distortion_coefficients"});
  test::write_file(mav0 / "cam0" / "sensor.yaml",
                   std::string(yaml).replace(yaml.find("radial-tangential"), 17, "fov"));
  expect_input_error([&] { open(dir.path()); }, {"cam0/sensor.yaml:distortion_model", "fov", "rig"});
  DatasetConfig config;
  config.rig = stereo_rig();
  source = open(dir.path(), config);
  EXPECT_EQ(read_all(*source).size(), written.size());
  std::filesystem::remove(mav0 / "cam0" / "sensor.yaml");
  expect_input_error([&] { open(dir.path()); }, {"cam0/sensor.yaml", "missing camera calibration", "rig"});
}

// A fisheye rig written and read back: sensor.yaml says equidistant, with k1..k4.
TEST(Euroc, EquidistantRigRoundTrip) {
  TempDir dir;
  SensorRig rig = stereo_rig();
  rig.cam0 = PinholeCamera(kWidth, kHeight, 19.1, 19.0, 23.5, 15.5, Distortion::equidistant(0.0035, 0.0007, -0.002, 0.0002));
  rig.cam1 = PinholeCamera(kWidth, kHeight, 19.0, 19.2, 24.0, 16.0, Distortion::equidistant(0.0034, 0.0017, -0.0026, 0.0003));
  write_sequence(dir.path(), make_frames(10), rig);
  EXPECT_NE(test::read_file(dir / "mav0" / "cam0" / "sensor.yaml").find("distortion_model: equidistant"),
            std::string::npos);
  const auto source = open(dir.path());
  for (const auto& [read, written] : {std::make_pair(source->rig().cam0, rig.cam0),
                                      std::make_pair(*source->rig().cam1, *rig.cam1)}) {
    EXPECT_TRUE(read.distortion().is_equidistant());
    EXPECT_EQ(read.distortion().k1, written.distortion().k1);
    EXPECT_EQ(read.distortion().k2, written.distortion().k2);
    EXPECT_EQ(read.distortion().k3, written.distortion().k3);
    EXPECT_EQ(read.distortion().k4, written.distortion().k4);
  }
}

TEST(Euroc, SixteenBitImagesOfTumViReadAsEightBitGray) {
  TempDir dir;
  write_sequence(dir.path(), make_frames(9, false, false), mono_rig());
  const auto png = dir / "mav0" / "cam0" / "data" / (std::to_string(kT0) + ".png");
  cv::Mat wide(kHeight, kWidth, CV_16UC1, cv::Scalar(0x1234));
  ASSERT_TRUE(cv::imwrite(png.string(), wide));
  const auto frame = open(dir.path())->next();
  ASSERT_TRUE(frame.has_value());
  ASSERT_EQ(frame->image.type(), CV_8UC1);
  EXPECT_EQ(frame->image.at<std::uint8_t>(0, 0), 0x12);
}

// ---- bad input --------------------------------------------------------------------------------------

// cam1 stamps all 1 us off cam0's: no stereo pair, an error naming cam1/data.csv (it was an empty stream).
TEST(Euroc, StereoWithoutOnePairIsAnInputError) {
  TempDir dir;
  write_sequence(dir.path(), make_frames(6));
  const auto cam1_csv = dir / "mav0" / "cam1" / "data.csv";
  std::string shifted = "#timestamp [ns],filename\n";
  for (int i = 0; i < kFrames; ++i) shifted += std::to_string(kT0 + i * kPeriod + 1000) + "," + std::to_string(kT0 + i * kPeriod) + ".png\n";
  test::write_file(cam1_csv, shifted);
  expect_input_error([&] { open(dir.path()); }, {"cam1/data.csv", "no image shares its timestamp"});
}

class EurocBadInput : public ::testing::Test {
 protected:
  void SetUp() override { write_sequence(dir.path(), make_frames(13)); }
  std::filesystem::path mav0() const { return dir / "mav0"; }
  std::filesystem::path cam0_csv() const { return mav0() / "cam0" / "data.csv"; }
  std::filesystem::path cam0_png(int i) const {
    return mav0() / "cam0" / "data" / (std::to_string(kT0 + i * kPeriod) + ".png");
  }
  std::string cam0_line(int i) const { return "cam0/data.csv:" + std::to_string(2 + i); }
  std::filesystem::path cam0_yaml() const { return mav0() / "cam0" / "sensor.yaml"; }
  void edit_yaml(const std::string& from, const std::string& to) const {
    std::string yaml = test::read_file(cam0_yaml());
    ASSERT_NE(yaml.find(from), std::string::npos);
    test::write_file(cam0_yaml(), yaml.replace(yaml.find(from), from.size(), to));
  }
  TempDir dir;
};

TEST_F(EurocBadInput, MissingFoldersAndFiles) {
  expect_input_error([&] { open(dir / "nowhere"); }, {"nowhere", "no such folder"});
  expect_input_error([&] { open_euroc(dir / "mav0" / "cam0", DatasetFormat::kEuroc, {}, null_logger()); },
                     {"not a EuRoC/TUM-VI sequence"});
  std::filesystem::remove_all(mav0() / "cam1" / "data");
  expect_input_error([&] { open(dir.path()); }, {"cam1/data.csv:2", "none of the listed images is present"});
  std::filesystem::remove(cam0_csv());
  expect_input_error([&] { open(dir.path()); }, {"cam0/data.csv", "missing file"});
}

TEST_F(EurocBadInput, MalformedTruncatedAndNonMonotonicRows) {
  const std::string row = std::to_string(kT0 + 3 * kPeriod);
  test::replace_line(cam0_csv(), 2 + 3, row + "," + row + ".png,extra");
  expect_input_error([&] { open(dir.path()); }, {cam0_line(3), "expected 2 fields"});
  test::replace_line(cam0_csv(), 2 + 3, row);
  expect_input_error([&] { open(dir.path()); }, {cam0_line(3), "expected 2 fields"});
  test::replace_line(cam0_csv(), 2 + 3, "14037152732.5," + row + ".png");
  expect_input_error([&] { open(dir.path()); }, {cam0_line(3)});
  test::replace_line(cam0_csv(), 2 + 3, std::to_string(kT0) + "," + row + ".png");
  expect_input_error([&] { open(dir.path()); }, {cam0_line(3), "does not increase"});
}

TEST_F(EurocBadInput, AbsentImageInTheMiddleIsAnErrorOrASkip) {
  std::filesystem::remove(cam0_png(6));
  expect_input_error([&] { open(dir.path()); }, {cam0_line(6), "is absent", cam0_png(6).filename().string()});
  DatasetConfig config;
  config.skip_unreadable_frames = true;
  const auto source = open(dir.path(), config);
  EXPECT_EQ(source->size(), static_cast<std::size_t>(kFrames - 1));
  // The right image of the dropped frame has no partner left: also listed as skipped.
  EXPECT_EQ(source->info().skipped.size(), 2u);
}

TEST_F(EurocBadInput, CorruptPngIsAnErrorByDefaultAndASkipOnRequest) {
  test::write_file(cam0_png(2), "not a png at all");
  const auto strict = open(dir.path());
  strict->next();
  strict->next();
  expect_input_error([&] { strict->next(); }, {cam0_line(2), "cannot decode", cam0_png(2).filename().string()});
  DatasetConfig config;
  config.skip_unreadable_frames = true;
  const auto frames = read_all(*open(dir.path(), config));
  ASSERT_EQ(frames.size(), static_cast<std::size_t>(kFrames - 1));
  EXPECT_EQ(frames[2].imu.size(), 20u);
}

TEST_F(EurocBadInput, BadImuRows) {
  const auto imu_csv = mav0() / "imu0" / "data.csv";
  test::replace_line(imu_csv, 5, std::to_string(kT0 - 30000000) + ",0.1,0.2,nan,0,0,9.8");
  expect_input_error([&] { open(dir.path()); }, {"imu0/data.csv:5", "w_z", "finite"});
  test::replace_line(imu_csv, 5, std::to_string(kT0 - 30000000) + ",0.1,0.2");
  expect_input_error([&] { open(dir.path()); }, {"imu0/data.csv:5", "expected 7 fields"});
  test::replace_line(imu_csv, 5, std::to_string(kT0 - 30000000) + ",0.1,0.2,abc,0,0,9.8");
  expect_input_error([&] { open(dir.path()); }, {"imu0/data.csv:5", "not a number"});
  test::replace_line(imu_csv, 5, std::to_string(kT0 - 60000000) + ",0.1,0.2,0.3,0,0,9.8");
  expect_input_error([&] { open(dir.path()); }, {"imu0/data.csv:5", "does not increase"});
  // A stamp in seconds is refused, not rounded to whole nanoseconds.
  test::replace_line(imu_csv, 5, "1403715273.247142976,0.1,0.2,0.3,0,0,9.8");
  expect_input_error([&] { open(dir.path()); }, {"imu0/data.csv:5", "not integer nanoseconds", "seconds"});
}

TEST_F(EurocBadInput, ImageStampsInSeconds) {
  const auto cam0_csv = mav0() / "cam0" / "data.csv";
  test::replace_line(cam0_csv, 2, "1403715273.262142976,1403715273262142976.png");
  expect_input_error([&] { open(dir.path()); }, {"cam0/data.csv:2", "not integer nanoseconds", "seconds"});
}

TEST_F(EurocBadInput, BadCalibration) {
  edit_yaml("intrinsics:", "intrinsics_typo:");
  expect_input_error([&] { open(dir.path()); }, {"cam0/sensor.yaml:intrinsics", "missing"});
  edit_yaml("intrinsics_typo:", "intrinsics: [1, 2]\nx:");
  expect_input_error([&] { open(dir.path()); }, {"cam0/sensor.yaml:intrinsics", "has 2 numbers"});
  test::write_file(cam0_yaml(), "%YAML:1.0\nT_BS: [1, 2\n");
  expect_input_error([&] { open(dir.path()); }, {"cam0/sensor.yaml", "malformed"});
}

TEST_F(EurocBadInput, UnsupportedModelAndNonRigidExtrinsics) {
  edit_yaml("camera_model: pinhole", "camera_model: omni");
  expect_input_error([&] { open(dir.path()); }, {"cam0/sensor.yaml:camera_model", "omni", "rig"});
  edit_yaml("camera_model: omni", "camera_model: pinhole");
  edit_yaml("data: [", "data: [7, ");
  expect_input_error([&] { open(dir.path()); }, {"cam0/sensor.yaml:T_BS"});
}

TEST_F(EurocBadInput, ImageSizeDiffersFromCalibration) {
  edit_yaml("resolution: [48, 32]", "resolution: [752, 480]");
  const auto source = open(dir.path());
  expect_input_error([&] { source->next(); }, {cam0_line(0), "48x32", "752x480"});
}

}  // namespace
}  // namespace fleetslam::core
