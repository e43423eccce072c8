#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <thread>

#include <sys/stat.h>

#include "fleetslam/core/error.hpp"
#include "fleetslam/core/trajectory.hpp"

namespace fleetslam::core {
namespace {

namespace fs = std::filesystem;

// A fresh folder per test so that tests may run in parallel.
fs::path test_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const fs::path dir = fs::temp_directory_path() / "fleetslam_test_trajectory_io" /
                       (std::string(info->test_suite_name()) + "." + info->name());
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

fs::path write_file(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

Trajectory random_trajectory(std::size_t n, std::uint32_t seed, bool index_stamps) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-10.0, 10.0);
  std::uniform_int_distribution<TimeNs> step(1, 50'000'000);
  Trajectory trajectory;
  TimeNs t_ns = 1'403'715'274'312'143'104;
  for (std::size_t i = 0; i < n; ++i) {
    StampedPose pose;
    t_ns += step(rng);
    pose.t_ns = index_stamps ? static_cast<TimeNs>(i) : t_ns;
    Eigen::Quaterniond q(u(rng), u(rng), u(rng), u(rng));
    pose.T_world_body.linear() = q.normalized().toRotationMatrix();
    pose.T_world_body.translation() = Eigen::Vector3d(u(rng), u(rng), u(rng)) * 1e3;
    trajectory.push_back(pose);
  }
  return trajectory;
}

void expect_same(const Trajectory& a, const Trajectory& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].t_ns, b[i].t_ns) << i;
    EXPECT_EQ(a[i].T_world_body.translation(), b[i].T_world_body.translation()) << i;  // bit for bit
    EXPECT_LT((a[i].T_world_body.linear() - b[i].T_world_body.linear()).cwiseAbs().maxCoeff(), 1e-15) << i;
  }
}

class TrajectoryRoundTrip : public ::testing::TestWithParam<TrajectoryFormat> {};

TEST_P(TrajectoryRoundTrip, StampsExactPosesToRoundOff) {
  const TrajectoryFormat format = GetParam();
  const Trajectory original = random_trajectory(200, 7, format == TrajectoryFormat::kKitti);
  const fs::path path = test_dir() / "sub" / ("traj_" + to_string(format) + ".txt");
  write_trajectory(path, original, format);
  EXPECT_EQ(detect_trajectory_format(path), format);
  expect_same(original, read_trajectory(path));
  expect_same(original, read_trajectory(path, format));
}

INSTANTIATE_TEST_SUITE_P(AllFormats, TrajectoryRoundTrip,
                         ::testing::Values(TrajectoryFormat::kTum, TrajectoryFormat::kEuroc,
                                           TrajectoryFormat::kKitti),
                         [](const auto& param_info) { return to_string(param_info.param); });

TEST(TrajectoryFormatNames, RoundTrip) {
  for (auto f : {TrajectoryFormat::kTum, TrajectoryFormat::kEuroc, TrajectoryFormat::kKitti}) {
    EXPECT_EQ(trajectory_format_from_string(to_string(f)), f);
  }
  EXPECT_EQ(trajectory_format_from_string("EuRoC"), TrajectoryFormat::kEuroc);
  EXPECT_FALSE(trajectory_format_from_string("bag").has_value());
}

TEST(TrajectoryRead, TumWithCommentsTabsCommasAndBlankLines) {
  const fs::path path = write_file(test_dir() / "tum.txt",
                                   "# ground truth trajectory\n\n"
                                   "1305031102.160407 1.0 2.0 3.0 0 0 0 1\n"
                                   "1305031102.194330\t1.5\t2\t3\t0\t0\t1\t0\r\n"
                                   "  # an indented comment\n"
                                   "1305031102.2, 0, 0, 0, 0, 0, 0, 2\n");
  EXPECT_EQ(detect_trajectory_format(path), TrajectoryFormat::kTum);
  const Trajectory t = read_trajectory(path);
  ASSERT_EQ(t.size(), 3u);
  EXPECT_EQ(t[0].t_ns, 1305031102160407000);
  EXPECT_EQ(t[1].t_ns, 1305031102194330000);
  EXPECT_EQ(t[2].t_ns, 1305031102200000000);
  EXPECT_EQ(t[0].T_world_body.translation(), Eigen::Vector3d(1, 2, 3));
  // qz = 1: a half turn about z.
  EXPECT_TRUE(t[1].T_world_body.linear().isApprox(Eigen::Vector3d(-1, -1, 1).asDiagonal().toDenseMatrix()));
  EXPECT_TRUE(t[2].T_world_body.linear().isIdentity());  // the quaternion is normalised
}

TEST(TrajectoryRead, EurocWithFractionalZerosAndExtraColumns) {
  const fs::path path = write_file(test_dir() / "data.csv",
                                   "#timestamp [ns],px,py,pz,qw,qx,qy,qz,vx,vy,vz\n"
                                   "1403715274312143104.0000000000,1,2,3,1,0,0,0,9,9,9\n"
                                   "1403715274362142976, 4, 5, 6, 0, 0, 0, 1, 9, 9, 9\n");
  EXPECT_EQ(detect_trajectory_format(path), TrajectoryFormat::kEuroc);
  const Trajectory t = read_trajectory(path);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[0].t_ns, 1403715274312143104);
  EXPECT_EQ(t[1].t_ns, 1403715274362142976);
  EXPECT_TRUE(t[0].T_world_body.linear().isIdentity());
  EXPECT_EQ(t[1].T_world_body.translation(), Eigen::Vector3d(4, 5, 6));
  EXPECT_TRUE(t[1].T_world_body.linear().isApprox(Eigen::Vector3d(-1, -1, 1).asDiagonal().toDenseMatrix()));
}

TEST(TrajectoryDetect, CommaSeparatedNanosecondFileWithWxyzIsEuroc) {
  // Like euroc/V1_01_easy_micro/groundtruth_leftcam_tum.txt: named TUM, but ns stamps and w,x,y,z order.
  const fs::path path = write_file(test_dir() / "groundtruth_leftcam_tum.txt",
                                   "#timestamp [ns],p_x,p_y,p_z,q_w,q_x,q_y,q_z\n"
                                   "1403715274312143104.0000000000,0.8,2.2,0.9,0.4259,0.6262,-0.5441,0.3610\n");
  EXPECT_EQ(detect_trajectory_format(path), TrajectoryFormat::kEuroc);
  const Trajectory t = read_trajectory(path);
  const Eigen::Quaterniond q(t[0].T_world_body.linear());
  EXPECT_NEAR(std::abs(q.w()), 0.4259 / Eigen::Vector4d(0.4259, 0.6262, -0.5441, 0.3610).norm(), 1e-12);
}

TEST(TrajectoryDetect, SpaceSeparatedNanosecondStampsAreTumInNanoseconds) {
  // ORB-SLAM3 writes EuRoC runs as "t_ns tx ty tz qx qy qz qw".
  const fs::path path = write_file(test_dir() / "f_orbslam3.txt",
                                   "1403715274312143104.000000 1 2 3 0 0 0 1\n");
  EXPECT_EQ(detect_trajectory_format(path), TrajectoryFormat::kTum);
  EXPECT_EQ(read_trajectory(path).at(0).t_ns, 1403715274312143104);
}

// A simulated sequence's clock starts at 0: ORB-SLAM3's EuRoC output of it has short nanosecond stamps.
// Whole numbers 50 ms apart in nanoseconds would be 1.6 years apart in seconds: the file counts in ns.
// A header naming the quaternion's columns decides their order: a "[ns]" in a TUM-ordered header made the
// file EuRoC and its quaternion read w first.
TEST(TrajectoryDetect, HeaderColumnNamesDecideTheQuaternionOrder) {
  const fs::path dir = test_dir();
  const std::string row = "1403715274312143104 1 2 3 0.1 0.2 0.3 0.9\n";
  const fs::path tum = write_file(dir / "tum_ns.txt", "# timestamp [ns] tx ty tz qx qy qz qw\n" + row);
  EXPECT_EQ(detect_trajectory_format(tum), TrajectoryFormat::kTum);
  const fs::path plain = write_file(dir / "plain.txt", row);
  EXPECT_TRUE(read_trajectory(tum).at(0).T_world_body.isApprox(read_trajectory(plain).at(0).T_world_body, 1e-15));
  const fs::path euroc = write_file(dir / "euroc_spaces.txt", "#timestamp p_RS_R_x p_RS_R_y p_RS_R_z q_RS_w q_RS_x q_RS_y q_RS_z\n" + row);
  EXPECT_EQ(detect_trajectory_format(euroc), TrajectoryFormat::kEuroc);
  const Eigen::Quaterniond q(read_trajectory(euroc).at(0).T_world_body.linear());
  EXPECT_NEAR(std::abs(q.w()), 0.1 / Eigen::Vector4d(0.1, 0.2, 0.3, 0.9).norm(), 1e-12);
  const fs::path seconds = write_file(dir / "w_first_seconds.txt", "# t x y z qw qx qy qz\n1.5 1 2 3 1 0 0 0\n");
  EXPECT_THROW(detect_trajectory_format(seconds), InputError);
}

TEST(TrajectoryDetect, ShortNanosecondStampsOfASimulatedClockAreNanoseconds) {
  const fs::path path = write_file(test_dir() / "f_sim.txt",
                                   "0.000000 0 0 0 0 0 0 1\n"
                                   "50000000.000000 1 0 0 0 0 0 1\n"
                                   "100000000.000000 2 0 0 0 0 0 1\n");
  EXPECT_EQ(detect_trajectory_format(path), TrajectoryFormat::kTum);
  const Trajectory t = read_trajectory(path);
  ASSERT_EQ(t.size(), 3u);
  EXPECT_EQ(t[0].t_ns, 0);
  EXPECT_EQ(t[1].t_ns, 50'000'000);
  EXPECT_EQ(t[2].t_ns, 100'000'000);
  // Whole seconds a second apart stay seconds, and so does a single pose (nothing to tell it by).
  const fs::path seconds = write_file(test_dir() / "whole_seconds.txt",
                                      "1.000000 0 0 0 0 0 0 1\n2.000000 0 0 0 0 0 0 1\n3 0 0 0 0 0 0 1\n");
  EXPECT_EQ(read_trajectory(seconds).at(1).t_ns, 2'000'000'000);
  const fs::path single = write_file(test_dir() / "single.txt", "50000000.000000 0 0 0 0 0 0 1\n");
  EXPECT_EQ(read_trajectory(single).at(0).t_ns, 50'000'000'000'000'000);
  // One stamp with a fraction makes them all seconds.
  const fs::path mixed = write_file(test_dir() / "mixed.txt",
                                    "0 0 0 0 0 0 0 1\n5000.5 0 0 0 0 0 0 1\n10000 0 0 0 0 0 0 1\n");
  EXPECT_EQ(read_trajectory(mixed).at(1).t_ns, 5'000'500'000'000);
}

// A named pipe (eval --est <(...)) can be read once: detection, the unit check and the parser share one
// read. It used to be opened three times, the parser then seeing what was left.
TEST(TrajectoryRead, ANamedPipeIsReadOnce) {
  const fs::path fifo = test_dir() / "pipe";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string text = "# timestamp tx ty tz qx qy qz qw\n1.0 0 0 0 0 0 0 1\n2.0 1 0 0 0 0 0 1\n3.0 2 0 0 0 0 0 1\n";
  std::thread writer([&] { std::ofstream(fifo, std::ios::binary) << text; });
  Trajectory t;
  try {
    t = read_trajectory(fifo);
  } catch (...) {
    writer.join();
    throw;
  }
  writer.join();
  ASSERT_EQ(t.size(), 3u);
  EXPECT_EQ(t[2].t_ns, 3'000'000'000);
  EXPECT_DOUBLE_EQ(t[2].T_world_body.translation().x(), 2.0);
}

TEST(TrajectoryDetect, CommaSeparatedSecondsWithZeroFractionAreTum) {
  const fs::path path = write_file(test_dir() / "tum_commas.txt", "1.000000,0,0,0,0,0,0,1\n2.5,0,0,0,0,0,0,1\n");
  EXPECT_EQ(detect_trajectory_format(path), TrajectoryFormat::kTum);
  EXPECT_EQ(read_trajectory(path).at(1).t_ns, 2'500'000'000);
}

TEST(TrajectoryDetect, KittiAndScientificTum) {
  const fs::path dir = test_dir();
  EXPECT_EQ(detect_trajectory_format(write_file(dir / "k.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n")),
            TrajectoryFormat::kKitti);
  const fs::path sci = write_file(dir / "s.txt", "1.403715529112143517e+09 0 0 0 0 0 0 1\n");
  EXPECT_EQ(detect_trajectory_format(sci), TrajectoryFormat::kTum);
  EXPECT_EQ(read_trajectory(sci).at(0).t_ns, 1403715529112143517);
}

TEST(TrajectoryRead, KittiIsProjectedOntoRotations) {
  const fs::path path = write_file(test_dir() / "kitti.txt",
                                   "1.0 0 0 1\n0 0.99999994 0 2\n0 0 1 3\n"  // not 12 per line: error
                                   );
  EXPECT_THROW(read_trajectory(path, TrajectoryFormat::kKitti), InputError);
  const fs::path good = write_file(test_dir() / "kitti2.txt",
                                   "1.0 0 0 1 0 0.99999994 0 2 0 0 1 3\n"
                                   "1.0 0 0 4 0 1 0 5 0 0 1.0000001 6\n");
  const Trajectory t = read_trajectory(good);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[0].t_ns, 0);
  EXPECT_EQ(t[1].t_ns, 1);
  EXPECT_EQ(t[1].T_world_body.translation(), Eigen::Vector3d(4, 5, 6));
  EXPECT_LT((t[0].T_world_body.linear().transpose() * t[0].T_world_body.linear() - Eigen::Matrix3d::Identity())
                .cwiseAbs()
                .maxCoeff(),
            1e-15);
}

// KITTI rows are the 3x4 matrix row by row: a 90 degree yaw (not symmetric) tells rows from columns.
TEST(TrajectoryRead, KittiRowsAreRowMajor) {
  const fs::path path = write_file(test_dir() / "kitti_yaw.txt", "0 -1 0 1 1 0 0 2 0 0 1 3\n");
  const Trajectory t = read_trajectory(path, TrajectoryFormat::kKitti);
  ASSERT_EQ(t.size(), 1u);
  Eigen::Matrix3d yaw;
  yaw << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  EXPECT_LT((t[0].T_world_body.linear() - yaw).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_EQ(t[0].T_world_body.translation(), Eigen::Vector3d(1, 2, 3));
}

TEST(TrajectoryRead, DuplicateStampPolicies) {
  const fs::path path = write_file(test_dir() / "dup.txt",
                                   "1.0 1 0 0 0 0 0 1\n"
                                   "2.0 2 0 0 0 0 0 1\n"
                                   "2.0 3 0 0 0 0 0 1\n"
                                   "3.0 4 0 0 0 0 0 1\n");
  try {
    read_trajectory(path);
    FAIL() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("dup.txt:3"), std::string::npos) << e.what();
  }
  TrajectoryReadOptions options;
  options.duplicate_stamps = DuplicateStamps::kKeepLast;
  const TrajectoryFile last = read_trajectory_file(path, options);
  ASSERT_EQ(last.trajectory.size(), 3u);
  EXPECT_EQ(last.trajectory[1].T_world_body.translation().x(), 3.0);
  EXPECT_EQ(last.duplicates_dropped, 1u);
  EXPECT_EQ(last.first_duplicate_line, 3u);
  EXPECT_EQ(last.format, TrajectoryFormat::kTum);
  options.duplicate_stamps = DuplicateStamps::kKeepFirst;
  EXPECT_EQ(read_trajectory_file(path, options).trajectory[1].T_world_body.translation().x(), 2.0);
}

struct BadInput {
  const char* name;
  std::optional<TrajectoryFormat> format;
  const char* text;
  int line;             // expected line number in the message
  const char* reason;   // expected words in the message
};

class TrajectoryBadInput : public ::testing::TestWithParam<BadInput> {};

TEST_P(TrajectoryBadInput, ThrowsNamingFileAndLine) {
  const BadInput& bad = GetParam();
  const fs::path path = write_file(test_dir() / (std::string(bad.name) + ".txt"), bad.text);
  try {
    read_trajectory(path, bad.format);
    FAIL() << "expected an InputError for " << bad.name;
  } catch (const InputError& e) {
    const std::string where = path.string() + ":" + std::to_string(bad.line);
    EXPECT_EQ(e.where(), where) << e.what();
    EXPECT_NE(std::string(e.what()).find(bad.reason), std::string::npos) << e.what();
  }
}

constexpr auto kTum = TrajectoryFormat::kTum;
constexpr auto kEuroc = TrajectoryFormat::kEuroc;
constexpr auto kKitti = TrajectoryFormat::kKitti;

INSTANTIATE_TEST_SUITE_P(
    AllCases, TrajectoryBadInput,
    ::testing::Values(
        BadInput{"tum_too_few", kTum, "# c\n1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 1\n", 3, "wrong number of columns"},
        BadInput{"tum_too_many", kTum, "1.0 0 0 0 0 0 0 1 5\n", 1, "wrong number of columns"},
        BadInput{"tum_truncated", kTum, "1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0", 2, "truncated line"},
        BadInput{"tum_nan", kTum, "1.0 0 0 0 0 0 0 1\n\n2.0 nan 0 0 0 0 0 1\n", 3, "not finite"},
        BadInput{"tum_inf", kTum, "1.0 0 0 inf 0 0 0 1\n", 1, "not finite"},
        BadInput{"tum_word", kTum, "1.0 0 0 x1 0 0 0 1\n", 1, "not a number"},
        BadInput{"tum_bad_stamp", kTum, "1.0.0 0 0 0 0 0 0 1\n", 1, "bad timestamp"},
        BadInput{"tum_zero_quaternion", kTum, "1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 0 0\n", 2, "zero-norm"},
        BadInput{"tum_decreasing", kTum, "2.0 0 0 0 0 0 0 1\n1.0 0 0 0 0 0 0 1\n", 2, "decrease"},
        BadInput{"tum_repeated", std::nullopt, "1.0 0 0 0 0 0 0 1\n1.0 0 0 0 0 0 0 1\n", 2, "repeated"},
        BadInput{"tum_empty_field", kTum, "1.0,0,,0,0,0,0,1\n", 1, "empty field"},
        BadInput{"tum_trailing_comma", kTum, "1.0,0,0,0,0,0,0,1,\n", 1, "empty field"},
        BadInput{"euroc_short", kEuroc, "#h\n100,0,0,0,1,0,0\n", 2, "wrong number of columns"},
        BadInput{"euroc_fraction", kEuroc, "100,0,0,0,1,0,0,0\n1x0,0,0,0,1,0,0,0\n", 2, "bad nanosecond"},
        // A TUM file read as EuRoC: seconds with a fraction (zeros alone are accepted, as in the EuRoC excerpt).
        BadInput{"euroc_seconds", kEuroc, "100.000,0,0,0,1,0,0,0\n1305031102.175304 1.3 0.6 1.6 0.6 0.6 -0.3 -0.3\n", 2,
                 "has a fraction: EuRoC stamps are integer nanoseconds"},
        BadInput{"euroc_extra_nan", kEuroc, "100,0,0,0,1,0,0,0,nan\n", 1, "not finite"},
        BadInput{"euroc_zero_quaternion", kEuroc, "100,0,0,0,0,0,0,0\n", 1, "zero-norm"},
        BadInput{"euroc_repeated", kEuroc, "100,0,0,0,1,0,0,0\n100,0,0,0,1,0,0,0\n", 2, "repeated"},
        BadInput{"kitti_short", kKitti, "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n", 2, "wrong number"},
        BadInput{"kitti_not_rotation", kKitti, "1 0 0 0 0 2 0 0 0 0 1 0\n", 1, "not a rotation"},
        BadInput{"kitti_reflection", kKitti, "1 0 0 0 0 1 0 0 0 0 -1 0\n", 1, "not a rotation"},
        BadInput{"kitti_inf", kKitti, "1 0 0 inf 0 1 0 0 0 0 1 0\n", 1, "not finite"},
        BadInput{"undetectable", std::nullopt, "# header\n1 2 3 4 5\n", 2, "cannot tell"}),
    [](const auto& param_info) { return std::string(param_info.param.name); });

TEST(TrajectoryRead, EmptyAndMissingFilesNameTheFile) {
  const fs::path dir = test_dir();
  for (const char* text : {"", "# only a comment\n\n"}) {
    const fs::path path = write_file(dir / "empty.txt", text);
    for (auto format : {std::optional<TrajectoryFormat>{}, std::optional<TrajectoryFormat>{kTum}}) {
      try {
        read_trajectory(path, format);
        FAIL() << "expected an InputError";
      } catch (const InputError& e) {
        EXPECT_EQ(e.where(), path.string());
        EXPECT_NE(std::string(e.what()).find("no poses"), std::string::npos) << e.what();
      }
    }
  }
  const fs::path missing = dir / "missing.txt";
  try {
    read_trajectory(missing);
    FAIL() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), missing.string());
  }
}

TEST(TrajectoryWrite, UnwritablePathIsInputError) {
  const fs::path dir = test_dir();
  write_file(dir / "a_file", "x");
  EXPECT_THROW(write_trajectory(dir / "a_file" / "traj.txt", Trajectory(1), kTum), InputError);
}

}  // namespace
}  // namespace fleetslam::core
