// End-to-end tests of `fleetslam eval`: runs the built CLI on real and synthetic files.

#include <gtest/gtest.h>

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "cli_test_util.hpp"

#include "fleetslam/core/trajectory.hpp"

namespace fleetslam {
namespace {

namespace fs = std::filesystem;
using test::read_text;
using RunResult = test::CliResult;

test::CliResult run_in(const fs::path& cwd, const std::string& arguments) { return test::run_cli(arguments, cwd); }
fs::path test_dir() { return test::fresh_test_dir("fleetslam_test_eval_cli"); }
using core::StampedPose;
using core::Trajectory;
using core::TrajectoryFormat;

const fs::path kData = FLEETSLAM_DATA_DIR;

nlohmann::json read_json(const fs::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

// A picture is complete: one svg element, closed, with both trajectories, the error curve and labels.
void expect_svg(const fs::path& path) {
  const std::string svg = read_text(path);
  EXPECT_EQ(svg.rfind("<?xml", 0), 0u);
  EXPECT_NE(svg.find("<svg xmlns=\"http://www.w3.org/2000/svg\""), std::string::npos);
  EXPECT_NE(svg.find("</svg>\n"), std::string::npos);
  EXPECT_GE(std::count(svg.begin(), svg.end(), '\n'), 20);
  std::size_t paths = 0;
  for (auto pos = svg.find("<path "); pos != std::string::npos; pos = svg.find("<path ", pos + 1)) ++paths;
  EXPECT_EQ(paths, 3u);  // ground truth, estimate, ATE curve
  for (const char* label : {"ground truth", "estimate (aligned)", "ATE [m]", " m</text>", "RMSE"}) {
    EXPECT_NE(svg.find(label), std::string::npos) << label;
  }
}

int lines_of(const std::string& text) { return static_cast<int>(std::count(text.begin(), text.end(), '\n')); }

// A helix-like path sampled at 20 Hz.
Trajectory synthetic_path(std::size_t n) {
  Trajectory t;
  for (std::size_t i = 0; i < n; ++i) {
    const double s = 0.05 * static_cast<double>(i);
    StampedPose p;
    p.t_ns = 1'000'000'000 + static_cast<core::TimeNs>(i) * 50'000'000;
    p.T_world_body.linear() = Eigen::AngleAxisd(s, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    p.T_world_body.translation() = Eigen::Vector3d(2.0 * std::cos(s), std::sin(s), 0.1 * s);
    t.push_back(p);
  }
  return t;
}

// The same motion seen in another frame at half the scale.
Trajectory scaled_and_moved(const Trajectory& gt) {
  Eigen::Isometry3d T_est_gt = Eigen::Isometry3d::Identity();
  T_est_gt.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  T_est_gt.translation() = Eigen::Vector3d(4, -1, 2);
  Trajectory est = gt;
  for (auto& p : est) {
    p.T_world_body = T_est_gt * p.T_world_body;
    p.T_world_body.translation() *= 0.5;
  }
  return est;
}

TEST(EvalCli, RealTumPairMatchesTheReferenceAndWritesOutputs) {
  const fs::path gt = kData / "trajectories" / "fr2_desk_groundtruth.txt";
  const fs::path est = kData / "trajectories" / "fr2_desk_ORB.txt";
  if (!fs::exists(gt) || !fs::exists(est)) GTEST_SKIP() << "real data not found in " << kData << " (../shared/data)";
  const fs::path dir = test_dir();
  const RunResult r = run_in(dir, "eval --gt '" + gt.string() + "' --est '" + est.string() + "' --out out");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("2223"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("rmse 0.008144"), std::string::npos) << r.output;
  const nlohmann::json j = read_json(dir / "out" / "metrics.json");
  EXPECT_EQ(j["association"]["pairs"], 2223);
  EXPECT_NEAR(j["ate_m"]["rmse"].get<double>(), 0.008144, 1e-6);
  EXPECT_NEAR(j["ate_m"]["median"].get<double>(), 0.007432, 1e-6);
  EXPECT_EQ(j["alignment"]["mode"], "se3");
  EXPECT_EQ(j["groundtruth"]["duplicate_stamps_dropped"], 1);
  EXPECT_EQ(j["ate_per_pair"]["error_m"].size(), 2223u);
  EXPECT_GT(j["rpe"]["translation_m"]["count"].get<int>(), 2000);
  expect_svg(dir / "out" / "trajectories.svg");
  EXPECT_EQ(core::read_trajectory(dir / "out" / "estimate_aligned.txt").size(), 2893u);
}

TEST(EvalCli, SyntheticSim3InMixedFormatsAndDefaultOutputFolder) {
  const fs::path dir = test_dir();
  const Trajectory gt = synthetic_path(300);
  core::write_trajectory(dir / "gt.txt", gt, TrajectoryFormat::kTum);
  core::write_trajectory(dir / "est.csv", scaled_and_moved(gt), TrajectoryFormat::kEuroc);
  const RunResult r = run_in(dir, "eval --gt gt.txt --est est.csv --align sim3 --rpe-delta 0.5 --rpe-unit m");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("scale 2.000000"), std::string::npos) << r.output;
  const nlohmann::json j = read_json(dir / "eval_out" / "metrics.json");  // the documented default
  EXPECT_EQ(j["estimate"]["format"], "euroc");
  EXPECT_EQ(j["groundtruth"]["format"], "tum");
  EXPECT_NEAR(j["alignment"]["scale"].get<double>(), 2.0, 1e-9);
  EXPECT_LT(j["ate_m"]["max"].get<double>(), 1e-9);
  EXPECT_LT(j["rpe"]["translation_m"]["max"].get<double>(), 1e-9);
  EXPECT_EQ(j["rpe"]["unit"], "m");
  expect_svg(dir / "eval_out" / "trajectories.svg");
}

TEST(EvalCli, KittiPairsByIndexAndOffsetShiftsTheEstimate) {
  const fs::path dir = test_dir();
  const Trajectory gt = synthetic_path(100);
  core::write_trajectory(dir / "gt.kitti", gt, TrajectoryFormat::kKitti);
  core::write_trajectory(dir / "est.kitti", gt, TrajectoryFormat::kKitti);
  RunResult r = run_in(dir, "eval --gt gt.kitti --est est.kitti --out k");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(read_json(dir / "k" / "metrics.json")["association"]["method"], "index");
  EXPECT_EQ(r.output.find("warning"), std::string::npos) << r.output;
  // KITTI in, KITTI out: the aligned estimate has no invented stamps.
  EXPECT_EQ(core::detect_trajectory_format(dir / "k" / "estimate_aligned.txt"), TrajectoryFormat::kKitti);
  EXPECT_EQ(core::read_trajectory(dir / "k" / "estimate_aligned.txt").size(), 100u);
  // Counts that differ pair the first poses of each, with a warning giving both counts.
  core::write_trajectory(dir / "short.kitti", Trajectory(gt.begin(), gt.begin() + 40), TrajectoryFormat::kKitti);
  r = run_in(dir, "eval --gt gt.kitti --est short.kitti --out s");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("gt.kitti has 100 poses, short.kitti 40; only the first 40 of each are paired"), std::string::npos)
      << r.output;
  // Poses without time have no RPE per second (it was NaN over no pairs, exit 0); a step longer than the
  // trajectory says there is no RPE.
  r = run_in(dir, "eval --gt gt.kitti --est est.kitti --rpe-unit s --out k");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--rpe-unit: s needs time stamps"), std::string::npos) << r.output;
  r = run_in(dir, "eval --gt gt.kitti --est est.kitti --rpe-delta 500 --out k");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("no two paired poses are 500 frames apart"), std::string::npos) << r.output;
  // A stamped file against an unstamped one pairs only when asked to (by index): poses of unrelated
  // times were paired with a warning and an ATE reported.
  core::write_trajectory(dir / "stamped.tum", gt, TrajectoryFormat::kTum);
  r = run_in(dir, "eval --gt stamped.tum --est est.kitti --out m");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("est.kitti: has no time stamps (KITTI) and stamped.tum has (tum)"), std::string::npos)
      << r.output;
  r = run_in(dir, "eval --gt stamped.tum --est est.kitti --associate index --out m");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  // An estimate stamped 1 s late pairs only with --offset -1.
  Trajectory late = gt;
  for (auto& p : late) p.t_ns += 1'000'000'000;
  core::write_trajectory(dir / "gt.tum", gt, TrajectoryFormat::kTum);
  core::write_trajectory(dir / "late.tum", late, TrajectoryFormat::kTum);
  r = run_in(dir, "eval --gt gt.tum --est late.tum --align none --offset -1 --out o");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(read_json(dir / "o" / "metrics.json")["association"]["pairs"], 100);
}

struct BadRun {
  const char* name;
  const char* gt_text;
  const char* est_text;
  const char* extra_arguments;
  const char* expected;  // in the single output line, besides the file name
};

// ctest shows the case by its name rather than the struct's bytes.
void PrintTo(const BadRun& bad, std::ostream* out) { *out << bad.name; }

class EvalCliBadInput : public ::testing::TestWithParam<BadRun> {};

TEST_P(EvalCliBadInput, ExitsNonZeroWithOneLineNamingTheFile) {
  const BadRun& bad = GetParam();
  const fs::path dir = test_dir();
  std::ofstream(dir / "gt.txt") << bad.gt_text;
  if (bad.est_text != nullptr) std::ofstream(dir / "est.txt") << bad.est_text;
  const RunResult r = run_in(dir, std::string("eval --gt gt.txt --est est.txt --out o ") + bad.extra_arguments);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_EQ(lines_of(r.output), 1) << r.output;
  EXPECT_NE(r.output.find(bad.expected), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "o" / "metrics.json"));
}

constexpr const char* kGoodTum =
    "1.00 0 0 0 0 0 0 1\n1.10 1 0 0 0 0 0 1\n1.20 1 1 0 0 0 0 1\n1.30 0 1 1 0 0 0 1\n";

INSTANTIATE_TEST_SUITE_P(
    Cases, EvalCliBadInput,
    ::testing::Values(BadRun{"missing_estimate", kGoodTum, nullptr, "", "est.txt"},
                      BadRun{"malformed_line", kGoodTum, "1.00 0 0 0 0 0 0 1\n\n1.10 0 0 0 0 0 1\n", "",
                             "est.txt:3: wrong number of columns"},
                      BadRun{"nan_in_ground_truth", "1.00 0 0 nan 0 0 0 1\n", kGoodTum, "", "gt.txt:1: value is not finite"},
                      BadRun{"no_pairs", kGoodTum, "5.00 0 0 0 0 0 0 1\n6.00 0 0 0 0 0 0 1\n", "",
                             "est.txt: no pose is within"},
                      BadRun{"too_few_pairs", kGoodTum, "1.00 0 0 0 0 0 0 1\n1.10 0 0 0 0 0 0 1\n", "",
                             "se3 alignment needs at least 3"},
                      BadRun{"repeated_stamp_strict", kGoodTum, "1.00 0 0 0 0 0 0 1\n1.00 0 0 0 0 0 0 1\n",
                             "--duplicates error", "est.txt:2: repeated timestamp"},
                      BadRun{"bad_max_diff", kGoodTum, kGoodTum, "--max-diff abc", "--max-diff"},
                      BadRun{"fractional_frames", kGoodTum, kGoodTum, "--rpe-delta 1.5", "--rpe-delta"},
                      // Spans past int64 nanoseconds wrapped: 1e10 s paired consecutive poses as "RPE/1e+10 s".
                      BadRun{"huge_rpe_delta", kGoodTum, kGoodTum, "--rpe-unit s --rpe-delta 1e10", "--rpe-delta"},
                      BadRun{"huge_max_diff", kGoodTum, kGoodTum, "--max-diff 8e9", "--max-diff"},
                      BadRun{"huge_offset", kGoodTum, kGoodTum, "--offset -2e9", "--offset"},
                      BadRun{"fractional_exponent", kGoodTum, kGoodTum, "--max-diff 2e-2.5", "--max-diff"}),
    [](const auto& param_info) { return std::string(param_info.param.name); });

// An output folder that cannot be made ends with its one line, before the report is printed.
TEST(EvalCli, AnOutputFolderThatIsAFileIsOneLine) {
  const fs::path dir = test_dir();
  std::ofstream(dir / "gt.txt") << kGoodTum;
  std::ofstream(dir / "taken") << "a file\n";
  const RunResult r = run_in(dir, "eval --gt gt.txt --est gt.txt --out taken");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_EQ(lines_of(r.output), 1) << r.output;
  EXPECT_NE(r.output.find("taken: cannot create the output folder"), std::string::npos) << r.output;
}

TEST(EvalCli, UnknownAlignmentIsAUsageError) {
  const fs::path dir = test_dir();
  std::ofstream(dir / "gt.txt") << kGoodTum;
  RunResult r = run_in(dir, "eval --gt gt.txt --est gt.txt --align se2");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--align"), std::string::npos) << r.output;
  // Every usage error exits 2 (bad input), not CLI11's own codes from 100 up; --help exits 0.
  for (const char* usage : {"eval --est gt.txt", "eval --gt gt.txt --est gt.txt --rpe-delta abc", "eval --gt gt.txt --est gt.txt --no-such-flag"}) {
    r = run_in(dir, usage);
    EXPECT_EQ(r.exit_code, 2) << usage << ": " << r.output;
  }
  EXPECT_EQ(run_in(dir, "eval --help").exit_code, 0);
  // Global flags may follow the command.
  r = run_in(dir, "eval --gt gt.txt --est gt.txt -q");
  EXPECT_EQ(r.exit_code, 0) << r.output;
}

}  // namespace
}  // namespace fleetslam
