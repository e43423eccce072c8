// TUM RGB-D reader and writer on synthetic sequences written by the writer (seeded content), and every
// kind of bad input the reader must name by file and line.

#include <gtest/gtest.h>

#include <random>

#include <opencv2/imgcodecs.hpp>

#include "dataset_test_util.hpp"
#include "fleetslam/core/config.hpp"
#include "fleetslam/core/dataset.hpp"
#include "fleetslam/core/trajectory.hpp"
#include "fleetslam/core/tum_rgbd.hpp"

namespace fleetslam::core {
namespace {

using test::expect_input_error;
using test::TempDir;

constexpr TimeNs kT0 = 1305031229528748000;
constexpr TimeNs kPeriod = 33333000;  // 30 Hz
constexpr int kFrames = 8;
constexpr std::size_t kHeaderLines = 3;  // comment lines before the first row of rgb.txt / depth.txt

SensorRig small_rig() {
  SensorRig rig;
  rig.mode = SensorMode::kRgbd;
  rig.cam0 = PinholeCamera(64, 48, 50.0, 51.0, 31.5, 23.5, Distortion{0.1, -0.05, 0.001, -0.002, 0.01});
  rig.depth_scale = 5000.0;
  rig.bf = 40.0;
  rig.fps = 30.0;
  return rig;
}

TimeNs stamp(int i) { return kT0 + i * kPeriod + (i == 3 ? 123 : 0); }  // frame 3: sub-microsecond stamp

// Frames with colour, depth, accelerometer samples in (previous frame, frame] and poses (none on frame 2).
std::vector<SensorFrame> make_frames(std::uint64_t seed) {
  std::mt19937 rng(static_cast<std::mt19937::result_type>(seed));
  std::normal_distribution<double> accel(0.0, 3.0);
  std::vector<SensorFrame> frames;
  for (int i = 0; i < kFrames; ++i) {
    SensorFrame frame;
    frame.sequence = i;
    frame.t_ns = stamp(i);
    frame.image = test::random_image(64, 48, CV_8UC3, seed * 100 + static_cast<std::uint64_t>(i));
    frame.depth_m = test::random_depth(64, 48, seed * 100 + 50 + static_cast<std::uint64_t>(i));
    for (TimeNs dt : {20000000, 10000000, 0}) {
      ImuSample sample;
      sample.t_ns = frame.t_ns - dt;
      sample.accel_mps2 = {accel(rng), accel(rng), accel(rng)};
      frame.imu.push_back(sample);
    }
    if (i != 2) frame.T_world_cam_gt = test::random_pose(rng);
    frames.push_back(frame);
  }
  return frames;
}

void write_sequence(const std::filesystem::path& root, const std::vector<SensorFrame>& frames,
                    const SensorRig& rig = small_rig()) {
  TumRgbdWriter writer(root, rig, null_logger());
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

void expect_depth_close(const cv::Mat& written, const cv::Mat& read) {
  ASSERT_EQ(read.type(), CV_32FC1);
  ASSERT_EQ(read.size(), written.size());
  for (int r = 0; r < read.rows; ++r) {
    for (int c = 0; c < read.cols; ++c) {
      const float w = written.at<float>(r, c);
      const float d = read.at<float>(r, c);
      if (w == 0.0f) {
        ASSERT_EQ(d, 0.0f);
      } else {
        ASSERT_LE(std::abs(static_cast<double>(d - w)), 1.0 / 5000.0) << r << "," << c;
      }
    }
  }
}

TEST(TumRgbd, RoundTripKeepsImagesStampsDepthPosesAndImu) {
  TempDir dir;
  const std::vector<SensorFrame> written = make_frames(7);
  write_sequence(dir.path(), written);
  EXPECT_EQ(detect_dataset_format(dir.path()), DatasetFormat::kTumRgbd);
  DatasetConfig config;
  config.robot_id = 3;
  const auto source = open(dir.path(), config);
  ASSERT_EQ(source->size(), written.size());
  EXPECT_EQ(source->rig().mode, SensorMode::kRgbd);
  EXPECT_DOUBLE_EQ(source->rig().cam0.fy(), 51.0);
  EXPECT_DOUBLE_EQ(source->rig().cam0.distortion().k3, 0.01);
  EXPECT_EQ(source->info().frames_with_groundtruth, written.size() - 1);
  EXPECT_TRUE(source->info().accelerometer_only);
  const std::vector<SensorFrame> read = read_all(*source);
  ASSERT_EQ(read.size(), written.size());
  for (std::size_t i = 0; i < read.size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(read[i].robot_id, 3);
    EXPECT_EQ(read[i].sequence, static_cast<std::int64_t>(i));
    EXPECT_EQ(read[i].t_ns, written[i].t_ns);
    EXPECT_TRUE(test::same_image(read[i].image, written[i].image));
    expect_depth_close(written[i].depth_m, read[i].depth_m);
    ASSERT_EQ(read[i].T_world_cam_gt.has_value(), written[i].T_world_cam_gt.has_value());
    if (read[i].T_world_cam_gt) {
      EXPECT_TRUE(read[i].T_world_cam_gt->isApprox(*written[i].T_world_cam_gt, 1e-12));
    }
    ASSERT_EQ(read[i].imu.size(), written[i].imu.size());
    for (std::size_t k = 0; k < read[i].imu.size(); ++k) {
      EXPECT_EQ(read[i].imu[k].t_ns, written[i].imu[k].t_ns);
      EXPECT_EQ(read[i].imu[k].accel_mps2, written[i].imu[k].accel_mps2);  // exact decimal round trip
      EXPECT_EQ(read[i].imu[k].gyro_radps, Eigen::Vector3d::Zero());
    }
  }
}

TEST(TumRgbd, AssociationIsGreedyOnSortedDifferencesLikeAssociatePy) {
  // b[0] is closer to a[1] than to a[0]: the closest pair wins, a[0] stays alone.
  auto matches = associate_stamps({0, 10}, {6}, 20);
  ASSERT_EQ(matches.size(), 1u);
  EXPECT_EQ(matches[0], std::make_pair(std::size_t{1}, std::size_t{0}));
  // The limit is strict, as in associate.py (abs(a - b) < max_difference).
  EXPECT_TRUE(associate_stamps({0}, {20}, 20).empty());
  EXPECT_EQ(associate_stamps({0}, {19}, 20).size(), 1u);
  // Equal differences: the earlier stamps pair first (tuple order), and each stamp is used once.
  matches = associate_stamps({10, 30}, {20}, 15);
  ASSERT_EQ(matches.size(), 1u);
  EXPECT_EQ(matches[0].first, 0u);
  // Results come sorted by the first list.
  matches = associate_stamps({0, 100, 200}, {1, 99, 201}, 5);
  ASSERT_EQ(matches.size(), 3u);
  EXPECT_EQ(matches[2], std::make_pair(std::size_t{2}, std::size_t{2}));
}

TEST(TumRgbd, RgbWithoutDepthWithinLimitIsSkippedAndListed) {
  TempDir dir;
  write_sequence(dir.path(), make_frames(1));
  const std::size_t line = kHeaderLines + 6;  // depth row of frame 5: 30 ms late, frame 6 keeps its own
  test::replace_line(dir / "depth.txt", line,
                     format_seconds(stamp(5) + 30000000, 6) + " depth/" + format_seconds(stamp(5), 6) + ".png");
  const auto source = open(dir.path());
  EXPECT_EQ(source->size(), static_cast<std::size_t>(kFrames - 1));
  ASSERT_EQ(source->info().skipped.size(), 1u);
  EXPECT_NE(source->info().skipped[0].where.find("rgb.txt:" + std::to_string(line)), std::string::npos);
  const auto frames = read_all(*source);
  EXPECT_EQ(frames[5].t_ns, stamp(6));
  // The IMU samples of the unpaired frame's interval stay in the stream, with the next frame.
  EXPECT_EQ(frames[5].imu.size(), 6u);
}

TEST(TumRgbd, ListsWithoutASinglePairAreAnError) {
  TempDir dir;
  write_sequence(dir.path(), make_frames(3));
  // Every depth stamp half a second late: no RGB image pairs, which is not an empty sequence.
  for (int i = 0; i < kFrames; ++i) {
    test::replace_line(dir / "depth.txt", kHeaderLines + 1 + static_cast<std::size_t>(i),
                       format_seconds(stamp(i) + 500000000, 6) + " depth/" + format_seconds(stamp(i), i == 3 ? 9 : 6) +
                           ".png");
  }
  expect_input_error([&] { open(dir.path()); }, {"rgb.txt", "depth.txt", "no RGB image has a depth image", "0.02"});
  DatasetConfig config;
  config.max_association_difference_s = 0.6;
  EXPECT_GT(open(dir.path(), config)->size(), 0u);  // a tolerance that reaches them pairs them again
  // A tolerance of 0 would pair nothing (the limit is strict, as in associate.py).
  expect_input_error(
      [] { load_config<DatasetConfig>(ConfigReader::from_string("max_association_difference_s: 0\n", "run.yaml")); },
      {"run.yaml", "max_association_difference_s"});
}

// Ground truth of body poses needs the calibration's body-to-camera transform.
TEST(TumRgbd, BodyFrameGroundTruthWithoutABodyToCameraTransformIsAnError) {
  TempDir dir;
  const std::vector<SensorFrame> written = make_frames(4);
  write_sequence(dir.path(), written);
  DatasetConfig config;
  config.groundtruth_in_body_frame = true;
  config.load_images = false;
  expect_input_error([&] { open(dir.path(), config); }, {"groundtruth.txt", "body-to-camera"});
  SensorRig rig = small_rig();
  std::mt19937 rng(5);
  rig.T_body_cam0 = test::random_pose(rng);
  config.rig = rig;
  const auto frames = read_all(*open(dir.path(), config));
  ASSERT_TRUE(frames[0].T_world_cam_gt.has_value());
  EXPECT_TRUE(frames[0].T_world_cam_gt->isApprox(*written[0].T_world_cam_gt * *rig.T_body_cam0, 1e-9));
}

TEST(TumRgbd, SelectionByIndexTimeAndStride) {
  TempDir dir;
  write_sequence(dir.path(), make_frames(2));
  DatasetConfig config;
  config.start_index = 1;
  config.stop_index = 7;
  config.stride = 2;
  auto frames = read_all(*open(dir.path(), config));
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[0].t_ns, stamp(1));
  EXPECT_EQ(frames[2].t_ns, stamp(5));
  EXPECT_EQ(frames[1].sequence, 1);
  EXPECT_EQ(frames[1].imu.size(), 6u);  // everything since the previous frame handed out
  config = {};
  config.start_offset_s = 0.05;
  config.stop_offset_s = 0.15;
  frames = read_all(*open(dir.path(), config));
  ASSERT_EQ(frames.size(), 3u);  // 66.7, 100, 133 ms
  EXPECT_EQ(frames[0].t_ns, stamp(2));
}

// A frame exactly at the stop offset is kept: 150000000 ns is 0.15000000000000002 s in doubles, and the
// comparison in seconds dropped it.
TEST(TumRgbd, AFrameExactlyAtTheStopOffsetIsKept) {
  TempDir dir;
  std::vector<SensorFrame> frames = make_frames(6);
  for (std::size_t i = 0; i < frames.size(); ++i) frames[i].t_ns = 1'000'000'000 + static_cast<TimeNs>(i) * 50'000'000;
  write_sequence(dir.path(), frames);
  DatasetConfig config;
  config.stop_offset_s = 0.15;
  config.load_imu = false;
  const std::vector<SensorFrame> read = read_all(*open(dir.path(), config));
  ASSERT_EQ(read.size(), 4u);  // 0, 50, 100 and 150 ms
  EXPECT_EQ(read.back().t_ns, 1'150'000'000);
}

TEST(TumRgbd, WithoutImagesFramesCarryStampsPosesAndImu) {
  TempDir dir;
  write_sequence(dir.path(), make_frames(3));
  DatasetConfig config;
  config.load_images = false;
  const auto frames = read_all(*open(dir.path(), config));
  ASSERT_EQ(frames.size(), static_cast<std::size_t>(kFrames));
  EXPECT_TRUE(frames[0].image.empty());
  EXPECT_FALSE(frames[0].has_depth());
  EXPECT_TRUE(frames[0].T_world_cam_gt.has_value());
  EXPECT_EQ(frames[4].imu.size(), 3u);
}

TEST(TumRgbd, GroundTruthIsInterpolatedOnlyBetweenCloseNeighbours) {
  TempDir dir;
  std::vector<SensorFrame> frames = make_frames(4);
  write_sequence(dir.path(), frames);
  // Ground truth at 10 ms around frame 4 only, translated along x and turned 40 degrees about z.
  Eigen::Isometry3d T_a = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_b = Eigen::Isometry3d::Identity();
  T_b.translation().x() = 1.0;
  T_b.linear() = Eigen::AngleAxisd(40.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  write_trajectory(dir / "gt.txt", {{stamp(4) - 10000000, T_a}, {stamp(4) + 30000000, T_b}}, TrajectoryFormat::kTum);
  DatasetConfig config;
  config.groundtruth_file = (dir / "gt.txt").string();
  config.max_groundtruth_gap_s = 0.03;
  config.load_images = false;
  auto read = read_all(*open(dir.path(), config));
  ASSERT_TRUE(read[4].T_world_cam_gt.has_value());
  EXPECT_NEAR(read[4].T_world_cam_gt->translation().x(), 0.25, 1e-12);
  // A quarter of the way: a quarter of the turn, about the same axis (slerp).
  const Eigen::AngleAxisd turned(read[4].T_world_cam_gt->linear());
  EXPECT_NEAR(turned.angle(), 10.0 * M_PI / 180.0, 1e-9);
  EXPECT_NEAR(turned.axis().z(), 1.0, 1e-9);
  EXPECT_FALSE(read[3].T_world_cam_gt.has_value());  // outside the poses
  config.max_groundtruth_gap_s = 0.02;  // 30 ms to the later pose is too far now: no frame has a pose
  expect_input_error([&] { open(dir.path(), config); }, {"gt.txt", "gives none of the", "frames a pose"});
}

TEST(TumRgbd, FreiburgDefaultsComeFromTheFolderName) {
  TempDir dir;
  const auto root = dir / "rgbd_dataset_freiburg2_xyz";
  write_sequence(root, make_frames(5));
  std::filesystem::remove(root / kTumCameraFile);
  const auto source = open(root);
  EXPECT_DOUBLE_EQ(source->rig().cam0.fx(), 520.9);
  EXPECT_DOUBLE_EQ(source->rig().cam0.cy(), 249.7);
  EXPECT_DOUBLE_EQ(source->rig().cam0.distortion().k3, 0.9172);
  EXPECT_EQ(source->rig().cam0.width(), 640);
  EXPECT_EQ(freiburg_from_name("rgbd_dataset_freiburg1_rpy_200"), 1);
  EXPECT_EQ(freiburg_from_name("fr3_office"), 3);
  EXPECT_FALSE(freiburg_from_name("my_sequence").has_value());
  EXPECT_DOUBLE_EQ(tum_freiburg_rig(1).cam0.distortion().k1, 0.2624);
  EXPECT_TRUE(tum_freiburg_rig(3).cam0.distortion().is_zero());
  // Wrong image size vs calibration: 64x48 images against the 640x480 Kinect.
  expect_input_error([&] { source->next(); },
                     {"rgb.txt:" + std::to_string(kHeaderLines + 1), "64x48", "640x480", ".png"});
}

TEST(TumRgbd, GivenRigAndDepthScaleWin) {
  TempDir dir;
  write_sequence(dir.path(), make_frames(6));
  DatasetConfig config;
  SensorRig rig = small_rig();
  rig.cam0 = PinholeCamera(64, 48, 60.0, 60.0, 32.0, 24.0);
  config.rig = rig;
  config.depth_scale = 2500.0;  // raw / 2500: every depth reads twice as deep
  const std::vector<SensorFrame> written = make_frames(6);
  const auto source = open(dir.path(), config);
  EXPECT_DOUBLE_EQ(source->rig().cam0.fx(), 60.0);
  const auto frame = source->next();
  ASSERT_TRUE(frame.has_value());
  const float w = written[0].depth_m.at<float>(0, 1);
  EXPECT_NEAR(static_cast<double>(frame->depth_m.at<float>(0, 1)), 2.0 * static_cast<double>(w), 2.0 / 5000.0);
  // A given rig's IMU is dropped: the sequence has an accelerometer only, no gyroscope.
  rig.imu = ImuNoise{};
  rig.T_body_cam0 = Eigen::Isometry3d::Identity();
  config.rig = rig;
  EXPECT_FALSE(open(dir.path(), config)->rig().imu.has_value());
}

TEST(DatasetConfig, ReadsFromYamlWithLimits) {
  const auto config = load_config<DatasetConfig>(
      ConfigReader::from_string("dataset:\n  stride: 2\n  robot_id: 1\n  skip_unreadable_frames: true\n", "run.yaml"),
      "dataset");
  EXPECT_EQ(config.stride, 2);
  EXPECT_EQ(config.robot_id, 1);
  EXPECT_TRUE(config.skip_unreadable_frames);
  EXPECT_DOUBLE_EQ(config.max_association_difference_s, 0.02);
  expect_input_error(
      [] { load_config<DatasetConfig>(ConfigReader::from_string("stride: 0\n", "run.yaml")); },
      {"run.yaml", "stride"});
}

// ---- bad input --------------------------------------------------------------------------------------

class TumRgbdBadInput : public ::testing::Test {
 protected:
  void SetUp() override { write_sequence(dir.path(), make_frames(11)); }
  std::filesystem::path rgb_txt() const { return dir / "rgb.txt"; }
  std::string rgb_line(int frame) const { return "rgb.txt:" + std::to_string(kHeaderLines + 1 + frame); }
  std::filesystem::path rgb_png(int frame) const { return dir / "rgb" / (format_seconds(stamp(frame), frame == 3 ? 9 : 6) + ".png"); }
  TempDir dir;
};

TEST_F(TumRgbdBadInput, MissingFolder) {
  expect_input_error([&] { open(dir / "nowhere"); }, {"nowhere", "no such folder"});
  expect_input_error([&] { open_tum_rgbd(dir / "nowhere", {}, null_logger()); }, {"nowhere", "no such folder"});
}

TEST_F(TumRgbdBadInput, MissingLists) {
  std::filesystem::remove(dir / "depth.txt");
  expect_input_error([&] { open(dir.path()); }, {"depth.txt", "missing file"});
  std::filesystem::remove(rgb_txt());
  expect_input_error([&] { detect_dataset_format(dir.path()); }, {"unknown dataset layout"});
  expect_input_error([&] { open_dataset(dir.path(), DatasetFormat::kTumRgbd, {}, null_logger()); },
                     {"rgb.txt", "missing file"});
}

TEST_F(TumRgbdBadInput, MalformedAndTruncatedLines) {
  test::replace_line(rgb_txt(), kHeaderLines + 3, format_seconds(stamp(2), 6));  // truncated: no file name
  expect_input_error([&] { open(dir.path()); }, {rgb_line(2), "expected 2 fields"});
  test::replace_line(rgb_txt(), kHeaderLines + 3, "13050x1229.5 rgb/x.png");
  expect_input_error([&] { open(dir.path()); }, {rgb_line(2), "not a valid time"});
  test::replace_line(rgb_txt(), kHeaderLines + 3, "nan rgb/x.png");
  expect_input_error([&] { open(dir.path()); }, {rgb_line(2), "not a valid time"});
  test::write_file(rgb_txt(), "# color images\n# timestamp filename\n");
  expect_input_error([&] { open(dir.path()); }, {"rgb.txt", "lists no images"});
}

// Ground truth on another clock (here 100 s later) gives no frame a pose: an error when the user gave the
// file, a warning (and no ground truth) when it is the sequence's own groundtruth.txt.
TEST_F(TumRgbdBadInput, GroundTruthThatGivesNoFrameAPose) {
  Trajectory shifted;
  for (int i = 0; i < 11; ++i) shifted.push_back({stamp(i) + 100'000'000'000, Eigen::Isometry3d::Identity()});
  write_trajectory(dir / "other.txt", shifted, TrajectoryFormat::kTum);
  DatasetConfig config;
  config.groundtruth_file = (dir / "other.txt").string();
  config.load_images = false;
  expect_input_error([&] { open(dir.path(), config); },
                     {"other.txt", "gives none of the", "frames a pose", "another clock"});
  std::filesystem::copy_file(dir / "other.txt", dir / "groundtruth.txt",
                             std::filesystem::copy_options::overwrite_existing);
  config.groundtruth_file.clear();
  const auto source = open(dir.path(), config);
  EXPECT_EQ(source->info().frames_with_groundtruth, 0u);
}

TEST_F(TumRgbdBadInput, NonMonotonicStamps) {
  test::replace_line(rgb_txt(), kHeaderLines + 5, format_seconds(stamp(1), 6) + " rgb/x.png");
  expect_input_error([&] { open(dir.path()); }, {rgb_line(4), "does not increase"});
}

TEST_F(TumRgbdBadInput, AbsentImageInTheMiddleIsAnErrorOrASkip) {
  std::filesystem::remove(rgb_png(4));
  expect_input_error([&] { open(dir.path()); }, {rgb_line(4), "is absent", rgb_png(4).filename().string()});
  DatasetConfig config;
  config.skip_unreadable_frames = true;
  const auto source = open(dir.path(), config);
  EXPECT_EQ(source->size(), static_cast<std::size_t>(kFrames - 1));
  ASSERT_EQ(source->info().skipped.size(), 1u);
  EXPECT_NE(source->info().skipped[0].where.find(rgb_line(4)), std::string::npos);
}

TEST_F(TumRgbdBadInput, AbsentImagesListedPastTheEndAreSkipped) {
  std::filesystem::remove(rgb_png(kFrames - 1));
  std::filesystem::remove(rgb_png(kFrames - 2));
  const auto source = open(dir.path());
  EXPECT_EQ(source->size(), static_cast<std::size_t>(kFrames - 2));
  ASSERT_EQ(source->info().skipped.size(), 2u);
  EXPECT_NE(source->info().skipped[1].why.find("after the last image present"), std::string::npos);
  EXPECT_EQ(read_all(*source).size(), static_cast<std::size_t>(kFrames - 2));
}

TEST_F(TumRgbdBadInput, CorruptPngIsAnErrorByDefaultAndASkipOnRequest) {
  test::write_file(rgb_png(3), "\x89PNG\r\n\x1a\n this is not a PNG body");
  const auto strict = open(dir.path());
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(strict->next().has_value());
  expect_input_error([&] { strict->next(); }, {rgb_line(3), "cannot decode", rgb_png(3).filename().string()});
  EXPECT_TRUE(strict->unreadable_frames().empty());  // stopping is not skipping
  DatasetConfig config;
  config.skip_unreadable_frames = true;
  const auto skipping = open(dir.path(), config);
  const auto frames = read_all(*skipping);
  ASSERT_EQ(frames.size(), static_cast<std::size_t>(kFrames - 1));
  EXPECT_EQ(frames[3].t_ns, stamp(4));
  EXPECT_EQ(frames[3].imu.size(), 6u);  // the skipped frame's samples are not lost
  EXPECT_EQ(frames[3].sequence, 3);
  ASSERT_EQ(skipping->unreadable_frames().size(), 1u);  // what was skipped, and where
  EXPECT_NE(skipping->unreadable_frames()[0].where.find(rgb_line(3)), std::string::npos);
  EXPECT_NE(skipping->unreadable_frames()[0].why.find("cannot decode"), std::string::npos);
}

TEST_F(TumRgbdBadInput, TruncatedPngAndEightBitDepth) {
  const std::string png = test::read_file(rgb_png(1));
  test::write_file(rgb_png(1), png.substr(0, png.size() / 2));
  const auto source = open(dir.path());
  source->next();
  expect_input_error([&] { source->next(); }, {rgb_line(1), "cannot decode"});
  const std::filesystem::path depth_png = dir / "depth" / (format_seconds(stamp(0), 6) + ".png");
  cv::imwrite(depth_png.string(), cv::Mat(48, 64, CV_8UC1, cv::Scalar(7)));
  expect_input_error([&] { open(dir.path())->next(); }, {"depth.txt:" + std::to_string(kHeaderLines + 1), "16-bit"});
}

TEST_F(TumRgbdBadInput, NanValues) {
  test::replace_line(dir / "accelerometer.txt", kHeaderLines + 2, format_seconds(stamp(0) - 10000000, 6) + " 0.1 nan 9.8");
  expect_input_error([&] { open(dir.path()); }, {"accelerometer.txt:" + std::to_string(kHeaderLines + 2), "ay"});
  test::replace_line(dir / "accelerometer.txt", kHeaderLines + 2, format_seconds(stamp(0) - 10000000, 6) + " 0.1 0.2");
  expect_input_error([&] { open(dir.path()); }, {"accelerometer.txt:" + std::to_string(kHeaderLines + 2), "4 fields"});
  std::filesystem::remove(dir / "accelerometer.txt");
  const std::size_t gt_line = test::line_of(dir / "groundtruth.txt", format_seconds(stamp(1), 9));
  ASSERT_GT(gt_line, 0u);
  test::replace_line(dir / "groundtruth.txt", gt_line, format_seconds(stamp(1), 9) + " 0 0 nan 0 0 0 1");
  expect_input_error([&] { open(dir.path()); }, {"groundtruth.txt:" + std::to_string(gt_line)});
}

TEST_F(TumRgbdBadInput, UnknownCameraAndBadCalibrationFile) {
  std::filesystem::remove(dir / kTumCameraFile);
  expect_input_error([&] { open(dir.path()); }, {"cannot tell the camera", "freiburg"});
  test::write_file(dir / kTumCameraFile, "%YAML:1.0\nCamera.fx: 500\nCamera.fy: 500\nCamera.cx: 320\n"
                                         "Camera.width: 64\nCamera.height: 48\n");
  expect_input_error([&] { open(dir.path()); }, {std::string(kTumCameraFile) + ":Camera.cy", "missing"});
  test::write_file(dir / kTumCameraFile, "%YAML:1.0\nCamera.fx: [500\n");
  expect_input_error([&] { open(dir.path()); }, {kTumCameraFile});
  test::write_file(dir / kTumCameraFile, "%YAML:1.0\nCamera.fx: -5\nCamera.fy: 5\nCamera.cx: 3\nCamera.cy: 3\n"
                                         "Camera.width: 64\nCamera.height: 48\n");
  expect_input_error([&] { open(dir.path()); },
                     {std::string(kTumCameraFile) + ":Camera.fx", "focal length must be positive"});
}

TEST(TumRgbdWriter, RefusesFramesWithoutDepthAndNonEmptyFolders) {
  TempDir dir;
  std::vector<SensorFrame> frames = make_frames(8);
  frames[1].depth_m = cv::Mat();
  expect_input_error([&] { write_sequence(dir / "a", frames); }, {"frame 1", "no depth map"});
  // The failed write is left beside the folder it was for, never in it: nothing looks finished.
  EXPECT_FALSE(std::filesystem::exists(dir / "a"));
  EXPECT_TRUE(std::filesystem::exists(dir / "a.partial" / "rgb.txt"));
  write_sequence(dir / "a", make_frames(8));  // a new write replaces the stale one
  EXPECT_FALSE(std::filesystem::exists(dir / "a.partial"));
  EXPECT_FALSE(std::filesystem::exists(dir / "a" / ".fleetslam_partial"));  // the mark stays behind
  // A folder of the staging folder's name that fleetslam did not write is refused, not removed.
  std::filesystem::create_directories(dir / "user.partial");
  test::write_file(dir / "user.partial" / "notes.txt", "mine");
  expect_input_error([&] { write_sequence(dir / "user", make_frames(8)); }, {"user.partial", "move it away"});
  EXPECT_EQ(test::read_file(dir / "user.partial" / "notes.txt"), "mine");
  EXPECT_EQ(open(dir / "a")->size(), 8u);
  expect_input_error([&] { write_sequence(dir / "a", make_frames(8)); }, {"not empty"});
  std::filesystem::create_directories(dir / "empty");  // an empty folder is taken
  write_sequence(dir / "empty/", make_frames(8));
  EXPECT_EQ(open(dir / "empty")->size(), 8u);
  frames = make_frames(8);
  std::swap(frames[2].t_ns, frames[3].t_ns);
  expect_input_error([&] { write_sequence(dir / "b", frames); }, {"does not increase"});
  // What the reader would refuse: an image of another size than the rig's camera, accelerometer stamps
  // that go back.
  frames = make_frames(8);
  frames[3].image = test::random_image(32, 24, CV_8UC3, 1);
  frames[3].depth_m = test::random_depth(32, 24, 2);
  expect_input_error([&] { write_sequence(dir / "c", frames); }, {"frame 3", "image is 32x24 but the rig's camera is 64x48"});
  frames = make_frames(8);
  frames[4].imu.front().t_ns = frames[3].t_ns - 1;
  expect_input_error([&] { write_sequence(dir / "d", frames); }, {"frame 4", "accelerometer stamps do not increase"});
}

// Frames that carry the truth at their IMU samples (as the simulator's do): groundtruth.txt has the
// camera's pose at every sample as well as at every frame (TUM's motion capture runs faster than the
// camera), each exact, so the frame without a pose is posed by the reader from the truth at its instant.
// Without the body-to-camera transform the frames' own rows only; a frame whose samples came without truth
// loses the rows at its samples (its own row stays); truth that does not pair with the samples is refused.
TEST(TumRgbdWriter, TheTruthAtTheImuSamplesAddsGroundTruthRows) {
  TempDir dir;
  SensorRig rig = small_rig();
  std::mt19937 rng(31);
  rig.T_body_cam0 = test::random_pose(rng);
  std::vector<SensorFrame> frames = make_frames(12);
  Trajectory expected;
  for (SensorFrame& frame : frames) {
    for (const ImuSample& sample : frame.imu) {
      ImuTruth truth{sample.t_ns, test::random_pose(rng), ImuStateGt{}};
      if (sample.t_ns == frame.t_ns && frame.T_world_cam_gt) truth.T_world_body = *frame.T_world_cam_gt * rig.T_body_cam0->inverse();
      frame.imu_truth.push_back(truth);
      expected.push_back({truth.t_ns, truth.T_world_body * *rig.T_body_cam0});
    }
  }
  write_sequence(dir / "fast", frames, rig);
  const Trajectory rows = read_trajectory(dir / "fast" / "groundtruth.txt", TrajectoryFormat::kTum);
  ASSERT_EQ(rows.size(), expected.size());  // every frame's instant is a sample's
  for (std::size_t k = 0; k < rows.size(); ++k) {
    SCOPED_TRACE(k);
    EXPECT_EQ(rows[k].t_ns, expected[k].t_ns);
    EXPECT_LT((rows[k].T_world_body.matrix() - expected[k].T_world_body.matrix()).cwiseAbs().maxCoeff(), 1e-9);
  }
  const std::vector<SensorFrame> read = read_all(*open(dir / "fast"));
  ASSERT_EQ(read.size(), frames.size());
  for (std::size_t i = 0; i < read.size(); ++i) {
    SCOPED_TRACE(i);
    ASSERT_TRUE(read[i].T_world_cam_gt.has_value());  // frame 2 too
    const Eigen::Isometry3d truth = frames[i].T_world_cam_gt ? *frames[i].T_world_cam_gt
                                                             : frames[i].imu_truth.back().T_world_body * *rig.T_body_cam0;
    EXPECT_LT((read[i].T_world_cam_gt->matrix() - truth.matrix()).cwiseAbs().maxCoeff(), 1e-9);
    // camera.yaml describes no IMU, so nothing says where the body is: no truth at the samples.
    EXPECT_TRUE(read[i].imu_truth.empty());
  }
  // With a calibration that has the rig's T_body_cam0, the camera's poses at the samples come back as the
  // body's, without a state (TUM's ground truth has none).
  DatasetConfig with_rig;
  with_rig.rig = rig;
  const std::vector<SensorFrame> read_with_rig = read_all(*open(dir / "fast", with_rig));
  ASSERT_EQ(read_with_rig.size(), frames.size());
  for (std::size_t i = 0; i < read_with_rig.size(); ++i) {
    SCOPED_TRACE(i);
    ASSERT_EQ(read_with_rig[i].imu_truth.size(), frames[i].imu_truth.size());
    for (std::size_t k = 0; k < frames[i].imu_truth.size(); ++k) {
      const ImuTruth& got = read_with_rig[i].imu_truth[k];
      EXPECT_EQ(got.t_ns, frames[i].imu_truth[k].t_ns);
      EXPECT_LT((got.T_world_body.matrix() - frames[i].imu_truth[k].T_world_body.matrix()).cwiseAbs().maxCoeff(), 1e-9);
      EXPECT_FALSE(got.state.has_value());
    }
  }

  write_sequence(dir / "no_extrinsics", frames);
  EXPECT_EQ(read_trajectory(dir / "no_extrinsics" / "groundtruth.txt", TrajectoryFormat::kTum).size(),
            frames.size() - 1);
  std::vector<SensorFrame> gap = frames;
  gap[5].imu_truth.clear();
  ASSERT_TRUE(gap[5].T_world_cam_gt.has_value());
  ASSERT_GT(gap[5].imu.size(), 1u);
  write_sequence(dir / "gap", gap, rig);
  const Trajectory gap_rows = read_trajectory(dir / "gap" / "groundtruth.txt", TrajectoryFormat::kTum);
  EXPECT_EQ(gap_rows.size(), expected.size() - gap[5].imu.size() + 1);
  for (const StampedPose& row : gap_rows) {  // nothing between frame 4 and frame 5 but frame 5's own row
    EXPECT_FALSE(row.t_ns > gap[4].t_ns && row.t_ns < gap[5].t_ns) << row.t_ns;
  }
  std::vector<SensorFrame> bad = frames;
  bad[4].imu_truth.front().t_ns -= 1;
  expect_input_error([&] { write_sequence(dir / "bad", bad, rig); }, {"frame 4", "IMU truth"});
}

TEST(TumRgbdWriter, DepthBeyondSixteenBitsBecomesNoMeasurement) {
  TempDir dir;
  std::vector<SensorFrame> frames = make_frames(9);
  frames[0].depth_m.at<float>(0, 0) = 20.0f;  // 100000 raw units
  frames[0].depth_m.at<float>(0, 1) = std::numeric_limits<float>::quiet_NaN();
  frames[0].depth_m.at<float>(0, 2) = -1.0f;
  write_sequence(dir.path(), frames);
  const auto frame = open(dir.path())->next();
  ASSERT_TRUE(frame.has_value());
  EXPECT_EQ(frame->depth_m.at<float>(0, 0), 0.0f);
  EXPECT_EQ(frame->depth_m.at<float>(0, 1), 0.0f);
  EXPECT_EQ(frame->depth_m.at<float>(0, 2), 0.0f);
}

}  // namespace
}  // namespace fleetslam::core
