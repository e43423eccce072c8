// Smoke tests of `fleetslam experiment`: each experiment on a few frames of the real TUM excerpt (skipped
// when ../shared/data is absent) and a short rendered office scenario writes well-formed CSV, Markdown and
// SVG; a repeat run gives the same CSV bytes apart from the timing columns; bad input exits 2 naming it.
// Never timing.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cli_test_util.hpp"
#include "fleetslam/experiments/results_document.hpp"
#include "fleetslam/experiments/sequences.hpp"

namespace fleetslam {
namespace {

namespace fs = std::filesystem;
using test::read_text;

const fs::path kData = FLEETSLAM_DATA_DIR;
const fs::path kTum = kData / "tum" / "rgbd_dataset_freiburg1_rpy_200";
const fs::path kTumCalibration = kData / "calib" / "TUM1.yaml";
const fs::path kEuroc = kData / "euroc" / "V1_01_easy_micro";
const fs::path kOffice = fs::path(FLEETSLAM_SOURCE_DIR) / "scenes" / "office" / "office_2robots.yaml";

std::string quoted(const fs::path& p) { return "'" + p.string() + "'"; }

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::stringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

// CSV: the header is `header`, then `rows` rows of as many fields (no quoted commas in these files).
void expect_csv(const fs::path& file, const std::string& header_prefix, std::size_t rows) {
  ASSERT_TRUE(fs::exists(file)) << file;
  const std::vector<std::string> lines = lines_of(read_text(file));
  ASSERT_EQ(lines.size(), rows + 1) << read_text(file);
  EXPECT_EQ(lines[0].rfind(header_prefix, 0), 0u) << lines[0];
  const auto fields = std::count(lines[0].begin(), lines[0].end(), ',');
  for (const std::string& line : lines) EXPECT_EQ(std::count(line.begin(), line.end(), ','), fields) << line;
}

void expect_markdown_table(const fs::path& file) {
  ASSERT_TRUE(fs::exists(file)) << file;
  const std::string text = read_text(file);
  EXPECT_EQ(text.rfind("# ", 0), 0u);
  EXPECT_NE(text.find("\n|---|"), std::string::npos) << text;
}

void expect_svg(const fs::path& file, const std::string& element) {
  ASSERT_TRUE(fs::exists(file)) << file;
  const std::string text = read_text(file);
  EXPECT_EQ(text.rfind("<svg xmlns=\"http://www.w3.org/2000/svg\"", 0), 0u);
  EXPECT_NE(text.find("</svg>"), std::string::npos);
  EXPECT_NE(text.find("<" + element), std::string::npos) << file;
  EXPECT_NE(text.find("<text"), std::string::npos);
  EXPECT_EQ(std::count(text.begin(), text.end(), '<'), std::count(text.begin(), text.end(), '>'));
}

// The CSV without its last `timing_columns` columns (the timing ones are last in every file here).
std::string without_timing(const fs::path& file, int timing_columns) {
  std::string out;
  for (std::string line : lines_of(read_text(file))) {
    for (int i = 0; i < timing_columns; ++i) line = line.substr(0, line.rfind(','));
    out += line + "\n";
  }
  return out;
}

class ExperimentCli : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(kTum)) GTEST_SKIP() << "no TUM excerpt at " << kTum;
    dir_ = test::fresh_test_dir("fleetslam_test_experiment_cli");
  }
  // Small data: 12 frames, a 0.7 s office rendering shared by the tests of one run (same --out/synthetic).
  std::string common(const fs::path& out, int frames = 12) const {
    return " --out " + quoted(out) + " --tum " + quoted(kTum) + " --tum-calibration " + quoted(kTumCalibration) +
           " --scenario " + quoted(kOffice) + " --synthetic-duration 0.7 --frames " + std::to_string(frames);
  }
  fs::path dir_;
};

void write_file(const fs::path& file, const std::string& text) {
  fs::create_directories(file.parent_path());
  std::ofstream(file, std::ios::binary | std::ios::trunc) << text;
}

// The key that decides whether a rendering is reused sees every input of the rendering that lives in a
// file: the scenario, the scene and the files it refers to (through an included file too), the duration,
// and the program that renders.
TEST(RenderingKey, ChangesWithEveryFileTheRenderingReads) {
  const fs::path dir = test::fresh_test_dir("fleetslam_test_rendering_key");
  const fs::path scenario = dir / "run.yaml";
  const fs::path scene = dir / "scene" / "scene.xml";
  const fs::path program = dir / "bin" / "fleetslam";
  write_file(scenario, "scene: scene/scene.xml\n");
  write_file(scene, "<mujoco><include file=\"parts.xml\"/><asset><texture name=\"t\" file=\"../textures/wall.png\"/>"
                    "</asset></mujoco>\n");
  write_file(dir / "scene" / "parts.xml", "<mujoco><asset><mesh file=\"meshes/chair.obj\"/></asset></mujoco>\n");
  write_file(dir / "textures" / "wall.png", "wall v1");
  write_file(dir / "scene" / "meshes" / "chair.obj", "chair v1");
  write_file(program, "program v1");
  const auto key = [&](double duration_s = 10.0) { return experiments::rendering_key(scenario, scene, duration_s, program); };
  const std::optional<std::string> first = key();
  ASSERT_TRUE(first.has_value());
  EXPECT_EQ(key(), first);
  EXPECT_NE(key(5.0), first);
  const auto changes_key = [&](const fs::path& file, const std::string& was, const std::string& now) {
    SCOPED_TRACE(file.string());
    write_file(file, now);
    EXPECT_NE(key(), first);
    write_file(file, was);
    EXPECT_EQ(key(), first);
  };
  changes_key(dir / "textures" / "wall.png", "wall v1", "wall v2");
  changes_key(dir / "scene" / "meshes" / "chair.obj", "chair v1", "chair v2");  // referred to by the include
  changes_key(program, "program v1", "program v2");
  changes_key(scenario, "scene: scene/scene.xml\n", "scene: scene/scene.xml\nduration_s: 3\n");
  fs::remove(dir / "textures" / "wall.png");
  const std::optional<std::string> without_texture = key();
  ASSERT_TRUE(without_texture.has_value());
  EXPECT_NE(without_texture, first);
  EXPECT_NE(without_texture->find("wall.png: missing"), std::string::npos) << *without_texture;
  // Without a readable program there is no key: nothing is reused.
  EXPECT_FALSE(experiments::rendering_key(scenario, scene, 10.0, dir / "bin" / "absent").has_value());
  fs::remove_all(dir);
}

TEST_F(ExperimentCli, MatchingWritesTable1) {
  const fs::path out = dir_ / "run";
  const std::string args = "-q experiment matching" + common(out) + " --euroc none --repetitions 2 --pairs 2 --features 250,500";
  const test::CliResult r = test::run_cli(args);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // 2 sequences (TUM, office/alpha) x 2 feature counts x 5 matchers.
  expect_csv(out / "matching" / "matching.csv", "sequence,origin,features,matcher,pairs,repetitions", 20);
  expect_markdown_table(out / "matching" / "matching.md");
  const std::string md = read_text(out / "matching" / "matching.md");
  const std::string overhead = "Cross-validation adds to the single-stage grid matcher's median time: ";
  const auto first_overhead = md.find(overhead);
  ASSERT_NE(first_overhead, std::string::npos) << md;
  EXPECT_NE(md.find(overhead, first_overhead + 1), std::string::npos) << "one line per sequence\n" << md;
  EXPECT_NE(md.find(" % at 250 features, ", first_overhead), std::string::npos) << md;
  EXPECT_NE(md.find(" % at 500 features.", first_overhead), std::string::npos) << md;
  expect_svg(out / "matching" / "matching_time_tum_rgbd_dataset_freiburg1_rpy_200.svg", "polyline");
  expect_svg(out / "matching" / "matching_precision_office_2robots_alpha.svg", "circle");
  const std::string csv = read_text(out / "matching" / "matching.csv");
  for (const char* matcher : {"brute_force,", "brute_force_opencv,", "flann_lsh,", "grid,", "cross_validation,"}) {
    EXPECT_NE(csv.find(matcher), std::string::npos) << matcher;
  }
  // A repeat run (the rendering reused) gives the same rows apart from the two timing columns; with
  // --rerender the rendering is made again (the same bytes: the simulator is deterministic).
  const fs::path first = dir_ / "first.csv";
  fs::copy_file(out / "matching" / "matching.csv", first);
  const fs::path rendered = out / "synthetic" / "office_2robots_0.7s" / "alpha" / "rgb.txt";
  ASSERT_TRUE(fs::exists(rendered));
  const auto rendered_at = fs::last_write_time(rendered);
  const test::CliResult again = test::run_cli(args);
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_EQ(without_timing(out / "matching" / "matching.csv", 2), without_timing(first, 2));
  EXPECT_EQ(fs::last_write_time(rendered), rendered_at) << "reused";
  const test::CliResult rerendered = test::run_cli(args + " --rerender");
  ASSERT_EQ(rerendered.exit_code, 0) << rerendered.output;
  EXPECT_NE(fs::last_write_time(rendered), rendered_at) << "rendered again";
  EXPECT_EQ(without_timing(out / "matching" / "matching.csv", 2), without_timing(first, 2));
}

TEST_F(ExperimentCli, SamplingWritesTable3) {
  const fs::path out = dir_ / "run";
  const test::CliResult r = test::run_cli("-q experiment sampling" + common(out) + " --euroc none");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  expect_csv(out / "sampling" / "sampling.csv", "dataset,origin,mode,robots,frames,duration_s,points_before", 2);
  const std::string csv = read_text(out / "sampling" / "sampling.csv");
  // The dataset length is the whole split sequence (12 frames, 0.368 s), not one robot's half of it.
  EXPECT_NE(csv.find("tum/rgbd_dataset_freiburg1_rpy_200,real,split,2,12,0.368,"), std::string::npos) << csv;
  EXPECT_NE(csv.find("office_2robots,synthetic,robots,2,24,"), std::string::npos) << csv;
  expect_markdown_table(out / "sampling" / "sampling.md");
  EXPECT_NE(read_text(out / "sampling" / "sampling.md").find("reduction (%)"), std::string::npos);
  expect_svg(out / "sampling" / "sampling_points.svg", "rect x=");
}

TEST_F(ExperimentCli, KeyframesWritesTable2AndFig7) {
  if (!fs::exists(kEuroc)) GTEST_SKIP() << "no EuRoC excerpt at " << kEuroc;
  const fs::path out = dir_ / "run";
  const test::CliResult r = test::run_cli("-q experiment keyframes" + common(out) + " --euroc " + quoted(kEuroc) + " --runs 2");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // 3 sequences x 3 policies; x 2 runs each in the per-run file.
  expect_csv(out / "keyframes" / "keyframes.csv", "sequence,origin,policy,runs,runs_with_ate,distinct_results", 9);
  expect_csv(out / "keyframes" / "keyframes_runs.csv", "sequence,policy,run,seed,threaded", 18);
  const std::string csv = read_text(out / "keyframes" / "keyframes.csv");
  for (const char* policy : {",orbslam3,", ",exponential,", ",fixed_interval,"}) {
    EXPECT_NE(csv.find(policy), std::string::npos) << policy;
  }
  EXPECT_NE(csv.find("tum/rgbd_dataset_freiburg1_rpy_200,real,exponential,2,2,"), std::string::npos) << csv;
  expect_markdown_table(out / "keyframes" / "keyframes.md");
  expect_svg(out / "keyframes" / "cumulative_ate_rmse_tum_rgbd_dataset_freiburg1_rpy_200.svg", "polyline");
  expect_svg(out / "keyframes" / "cumulative_ate_std_tum_rgbd_dataset_freiburg1_rpy_200.svg", "polyline");
}

// Threaded, the frames come at their own rate (as on a robot): no run is shorter than its 12 frames' span
// (TUM 0.368 s, the office rendering at 30 Hz 0.367 s), and the tables show how many frames each policy
// tracked.
TEST_F(ExperimentCli, ThreadedKeyframeRunsPlayTheFramesAtTheirRate) {
  const fs::path out = dir_ / "run";
  const test::CliResult r = test::run_cli("-q experiment keyframes --threaded --runs 1" + common(out) + " --euroc none");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::vector<std::string> rows = lines_of(read_text(out / "keyframes" / "keyframes_runs.csv"));
  ASSERT_EQ(rows.size(), 7u);  // header, 2 sequences x 3 policies
  for (std::size_t i = 1; i < rows.size(); ++i) {
    EXPECT_NE(rows[i].find(",1,12,"), std::string::npos) << "threaded, 12 frames: " << rows[i];
    EXPECT_GE(std::stod(rows[i].substr(rows[i].rfind(',') + 1)), 0.36) << rows[i];
  }
  EXPECT_NE(read_text(out / "keyframes" / "keyframes.md").find(" / 12 |"), std::string::npos);
}

TEST_F(ExperimentCli, AllWritesTheResultsDocument) {
  const fs::path out = dir_ / "run";
  const fs::path doc = dir_ / "docs" / "RESULTS.md";
  const test::CliResult r = test::run_cli("-q experiment all" + common(out, 8) + " --euroc none --runs 1 " +
                                          "--repetitions 1 --pairs 1 --features 250 --doc " + quoted(doc));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string text = read_text(doc);
  for (const char* part : {"## Table 1", "## Table 2", "## Table 3", "Machine:", "experiment all", "fr1_desk2",
                           "(results/sampling_points.svg)"}) {
    EXPECT_NE(text.find(part), std::string::npos) << part;
  }
  EXPECT_TRUE(fs::exists(doc.parent_path() / "results" / "sampling_points.svg"));
  EXPECT_TRUE(fs::exists(out / "matching" / "matching.csv"));
  EXPECT_TRUE(fs::exists(out / "keyframes" / "keyframes.csv"));
}

TEST(ExperimentCliErrors, MissingDatasetFolderExitsTwoNamingIt) {
  const fs::path missing = test::fresh_test_dir("fleetslam_test_experiment_cli") / "no_such_sequence";
  const test::CliResult r = test::run_cli("experiment matching --tum " + quoted(missing) + " --euroc none --scenario none");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find(missing.string()), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("no such folder"), std::string::npos) << r.output;
}

// A sequence whose ground truth has a drop-out at a pair's frames: the pair moves on to the next frames
// with poses (the experiment used to stop); with no three consecutive posed frames at all it is an error
// naming the folder. Runs on a short rendered office sequence (no real data needed).
TEST(ExperimentCliMatching, AGroundTruthDropOutMovesThePair) {
  const fs::path dir = test::fresh_test_dir("fleetslam_test_experiment_cli_dropout");
  const test::CliResult generated = test::run_cli("-q generate " + quoted(kOffice) + " --format tum --duration 0.5 --robots alpha --out " +
                                                  quoted(dir / "seq"));
  ASSERT_EQ(generated.exit_code, 0) << generated.output;
  const fs::path sequence = dir / "seq" / "alpha";
  const fs::path gt = sequence / "groundtruth.txt";
  const std::vector<std::string> lines = lines_of(read_text(gt));
  // The frames' stamps (rgb.txt rows after its 3 comment lines); the ground truth also has rows between
  // them (at the IMU samples).
  const std::vector<std::string> rgb = lines_of(read_text(sequence / "rgb.txt"));
  ASSERT_GT(rgb.size(), 12u);
  const auto frame_s = [&](std::size_t k) { return std::stod(rgb[3 + k].substr(0, rgb[3 + k].find(' '))); };
  const auto row_s = [&](const std::string& line) { return std::stod(line.substr(0, line.find(' '))); };
  // One pair over 15 frames starts at frame 7: drop every pose from frame 6 up to frame 7 (all rows
  // between frames 5 and 8), which leaves a gap too long to interpolate across.
  ASSERT_GT(lines.size(), 10u);
  std::string text = lines[0] + "\n";
  for (std::size_t i = 1; i < lines.size(); ++i) {
    if (!(row_s(lines[i]) > frame_s(5) && row_s(lines[i]) < frame_s(8))) text += lines[i] + "\n";
  }
  std::ofstream(gt) << text;
  const std::string common = "experiment matching --tum " + quoted(sequence) + " --tum-calibration " +
                             quoted(sequence / "orbslam_settings.yaml") +
                             " --euroc none --scenario none --frames 15 --pairs 1 --repetitions 1 --features 250";
  const std::string args = common + " --out " + quoted(dir / "out");
  test::CliResult r = test::run_cli(args);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("the pair starts at frame 9 instead"), std::string::npos) << r.output;
  EXPECT_TRUE(fs::exists(dir / "out" / "matching" / "matching.csv"));
  // --matchers runs those only, in the tables' usual order.
  r = test::run_cli(common + " --matchers cross_validation,grid --out " + quoted(dir / "two"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::vector<std::string> csv = lines_of(read_text(dir / "two" / "matching" / "matching.csv"));
  ASSERT_EQ(csv.size(), 3u);  // header, grid, cross_validation
  EXPECT_NE(csv[1].find(",grid,"), std::string::npos) << csv[1];
  EXPECT_NE(csv[2].find(",cross_validation,"), std::string::npos) << csv[2];
  EXPECT_NE(read_text(dir / "two" / "matching" / "matching.md").find("Cross-validation adds"), std::string::npos);
  text = lines[0] + "\n";  // poses at frames 2 and 5 only: no three in a row
  for (std::size_t i = 1; i < lines.size(); ++i) {
    if (row_s(lines[i]) == frame_s(2) || row_s(lines[i]) == frame_s(5)) text += lines[i] + "\n";
  }
  std::ofstream(gt) << text;
  r = test::run_cli(args);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("no three consecutive frames with a ground-truth pose"), std::string::npos) << r.output;
}

TEST(ExperimentCliErrors, BadSettingsExitTwo) {
  // `arguments` with every source none: exit 2 and a message holding `why`.
  const auto expect_exit_two = [](const std::string& arguments, const std::string& why) {
    const test::CliResult r = test::run_cli("experiment " + arguments + " --tum none --euroc none --scenario none");
    EXPECT_EQ(r.exit_code, 2) << arguments << ": " << r.output;
    EXPECT_NE(r.output.find(why), std::string::npos) << arguments << ": " << r.output;
  };
  expect_exit_two("keyframes --doc x.md", "--doc");
  expect_exit_two("matching --features 3", "--features");
  // Nothing to run on, or a frame count that is neither -1 nor positive, is an error, not empty tables.
  expect_exit_two("matching", "all are none");
  expect_exit_two("matching --frames -5", "--frames");
  expect_exit_two("matching --matchers grid,nope", "'nope' is no matcher");
  expect_exit_two("matching --matchers grid,cross_validation,grid", "grid is named twice");
  expect_exit_two("keyframes --matchers grid", "only with `fleetslam experiment matching`");
}

// Renderings and sequences are named by the scenario's file name: two of one name are refused up front
// (the second rendering replaced the first, and the tables failed after all the timing work).
TEST(ExperimentCliErrors, TwoScenariosOfOneNameExitTwo) {
  const fs::path dir = test::fresh_test_dir("fleetslam_test_experiment_cli") / "same_name";
  for (const char* sub : {"a", "b"}) {
    fs::create_directories(dir / sub);
    fs::copy_file(fs::path(FLEETSLAM_SOURCE_DIR) / "tests" / "scenarios" / "office_scripted.yaml", dir / sub / "office.yaml");
  }
  const test::CliResult r = test::run_cli("experiment matching --tum none --euroc none --scenario " +
                                          quoted(dir / "a" / "office.yaml") + " " + quoted(dir / "b" / "office.yaml"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("have one name (office)"), std::string::npos) << r.output;
}

// A sampling row with nothing merged has no reduction (NaN): the document says so instead of calling it
// within the paper's range (NaN failed both comparisons).
TEST(ResultsDocument, NothingMergedIsNoReduction) {
  const fs::path file = test::fresh_test_dir("fleetslam_test_experiment_cli") / "empty_merge" / "RESULTS.md";
  experiments::ResultsInput input;
  experiments::SamplingResult sampling;
  experiments::SamplingRow row;
  row.dataset = "empty";
  row.robots = 2;
  sampling.rows.push_back(row);
  input.sampling = sampling;
  experiments::write_results_document(input, file);
  const std::string text = read_text(file);
  EXPECT_NE(text.find("`empty`: no points were merged"), std::string::npos) << text;
  EXPECT_EQ(text.find("within it"), std::string::npos) << text;
}

}  // namespace
}  // namespace fleetslam
