// Tests of report.html (runner/report_html.hpp): a synthetic two-robot report renders every section with
// escaped names and the same bytes each time and needs nothing from outside; empty and odd-typed input
// says "not available" instead of throwing; an unwritable file is an InputError naming it; and a real
// headless Chromium parses the page (its DOM holds the verdict and criteria) and draws it (screenshot).

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <unordered_set>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "cli_test_util.hpp"

#include "fleetslam/core/error.hpp"
#include "fleetslam/runner/report_html.hpp"

namespace fleetslam {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using runner::render_report_html;
using runner::write_report_html;

constexpr const char* kOddName = "b<e>t&\"a\"";
constexpr const char* kOddNameEscaped = "b&lt;e&gt;t&amp;&quot;a&quot;";
constexpr double kPi = 3.14159265358979323846;

fs::path test_dir() { return test::fresh_test_dir("fleetslam_test_report_html"); }

std::size_t count_of(const std::string& text, const std::string& needle) {
  std::size_t count = 0;
  for (std::size_t at = text.find(needle); at != std::string::npos; at = text.find(needle, at + needle.size())) {
    ++count;
  }
  return count;
}

// One robot driving 90 % of a circle of `radius_m` around (cx, cy) in 20 s; its estimate drifts at
// `drift_m_per_s` along x and -y.
json circle_robot(const std::string& name, double cx, double cy, double radius_m, double drift_m_per_s) {
  json robot = {{"name", name}};
  json estimated = json::array();
  json truth = json::array();
  json ate = json::array();
  json decisions = json::array();
  for (int i = 0; i <= 200; ++i) {
    const double t_s = 0.1 * i;
    const double angle = 1.8 * kPi * t_s / 20.0;
    const double drift_m = drift_m_per_s * t_s;
    const double x = cx + radius_m * std::cos(angle);
    const double y = cy + radius_m * std::sin(angle);
    truth.push_back({t_s, x, y});
    estimated.push_back({t_s, x + drift_m, y - drift_m});
    ate.push_back({t_s, drift_m * std::sqrt(2.0)});
    decisions.push_back({t_s, 0.5 + 0.4 * std::sin(0.7 * t_s + cx), i % 15 == 0 ? 1 : 0});
  }
  robot["estimated_xy"] = estimated;
  robot["truth_xy"] = truth;
  robot["ate_over_time"] = ate;
  robot["keyframe_decisions"] = decisions;
  robot["plans"] = json::array({{{"t_s", 5.0}, {"status", "solved"}, {"path_xy", {{cx, cy}, {cx + 1.0, cy + 1.0}}}},
                                {{"t_s", 10.0}, {"status", "solved"}, {"path_xy", {{cx, cy}, {cx - 1.0, cy + 2.0}}}}});
  robot["goals_xy"] = json::array({{cx + 1.0, cy + 1.0}, {cx - 1.0, cy + 2.0}});
  return robot;
}

json robot_metrics(const std::string& name, double rmse_m) {
  return {{"name", name},
          {"status", "finished"},
          {"frames", 200},
          {"tracked", 198},
          {"lost", 2},
          {"keyframes", 14},
          {"collisions", 0},
          {"goals_reached", 2},
          {"goals_total", 2},
          {"ate_world_m", {{"rmse", rmse_m}, {"mean", rmse_m * 0.9}, {"max", rmse_m * 2.0}}},
          {"timings_ms", {{"tracking", {{"mean", 12.5}, {"median", 11.0}, {"p95", 20.25}}},
                          {"local_mapping", {{"mean", 40.0}, {"median", 38.0}, {"p95", 61.0}}}}}};
}

// A room of 12 m x 8 m: 30k map points scattered on its floor and walls (a fixed pseudo-random sequence),
// coloured by where they lie, so that few share a pixel and a colour: the size of the page is near its worst.
json map_points() {
  std::uint32_t state = 12345;
  const auto uniform = [&state]() {
    state = state * 1664525U + 1013904223U;
    return static_cast<double>(state >> 8) / static_cast<double>(1U << 24);
  };
  json points = json::array();
  for (int i = 0; i < 30000; ++i) {
    const double u = uniform();
    const double v = uniform();
    const int shade = static_cast<int>(255.0 * uniform());
    if (i % 2 == 0) {
      points.push_back({-6.0 + 12.0 * u, -4.0 + 8.0 * v, 0.0, 120 + shade / 3, 110 + shade / 3, 90 + shade / 3});
    } else if (i % 4 == 1) {
      points.push_back({-6.0 + 12.0 * u, (v < 0.5 ? 4.0 : -4.0) + 0.05 * v, 1.5 * v, 40, shade / 2 + 60, shade});
    } else {
      points.push_back({(v < 0.5 ? 6.0 : -6.0) - 0.05 * v, -4.0 + 8.0 * u, 1.5 * v, shade, 60, 50});
    }
  }
  return points;
}

json synthetic_report(bool passed) {
  json criteria = json::array();
  criteria.push_back({{"name", "ate_world_rmse_m"}, {"robot", "alpha"}, {"value", 0.021}, {"limit", 0.05},
                      {"comparison", "<="}, {"passed", true}, {"note", "world frame"}});
  criteria.push_back({{"name", "coverage_final"}, {"robot", ""}, {"value", 0.62}, {"limit", 0.5},
                      {"comparison", ">="}, {"passed", true}, {"note", ""}});
  criteria.push_back({{"name", "collisions_max"}, {"robot", kOddName}, {"value", nullptr}, {"limit", 0},
                      {"comparison", "<="}, {"passed", passed}, {"note", "value <missing>"}});
  json coverage = json::array();
  for (int i = 0; i <= 20; ++i) coverage.push_back({1.0 * i, 0.62 * (1.0 - std::exp(-0.2 * i))});
  json report;
  report["title"] = "fleetslam run: office_2robots.yaml";
  report["metrics"] = {{"scenario", "office_2robots"},
                       {"seed", 7},
                       {"simulated_s", 20.0},
                       {"wall_s", 41.5},
                       {"real_time_factor", 0.482},
                       {"verdict", {{"passed", passed}, {"criteria", criteria}}},
                       {"robots", {robot_metrics("alpha", 0.021), robot_metrics(kOddName, 0.034)}},
                       {"merged_map_accuracy",
                        {{"map_points", 30000}, {"mean_m", 0.031}, {"median_m", 0.025}, {"p95_m", 0.08},
                         {"completeness", 0.71}}},
                       {"coverage", {{"final", 0.62}, {"free_cells_truth", 5120}}},
                       {"central_timings_ms", {{"merge", 153.0}, {"fusion", 21.5}}}};
  report["series"] = {{"robots",
                       {circle_robot("alpha", -2.5, 0.0, 1.5, 0.002), circle_robot(kOddName, 2.5, 0.5, 1.2, 0.0035)}},
                      {"coverage_over_time", coverage},
                      {"map_points", map_points()}};
  return report;
}

// Runs a shell command, returns what it printed on stdout.
std::string shell_output(const std::string& command) {
  std::string output;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return output;
  char buffer[4096];
  std::size_t n = 0;
  while ((n = fread(buffer, 1, sizeof(buffer), pipe)) > 0) output.append(buffer, n);
  pclose(pipe);
  return output;
}

std::string chromium_command(const fs::path& user_data_dir, const std::string& action, const fs::path& html) {
  return "timeout 60 /usr/bin/chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run "
         "--disable-background-networking --disable-component-update --disable-sync --user-data-dir='" +
         user_data_dir.string() + "' --window-size=1200,2400 " + action + " 'file://" + html.string() + "'";
}

TEST(ReportHtml, SyntheticReportShowsEverySection) {
  const json report = synthetic_report(true);
  const std::string html = render_report_html(report);
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0U);
  EXPECT_NE(html.find("class=\"banner pass\""), std::string::npos);
  EXPECT_NE(html.find(">PASS<small>3 of 3 criteria passed</small>"), std::string::npos) << "banner";
  for (const char* name : {"ate_world_rmse_m", "coverage_final", "collisions_max"}) {
    EXPECT_NE(html.find("<tr><td>" + std::string(name) + "</td>"), std::string::npos) << name;
  }
  EXPECT_EQ(count_of(html, "<span class=\"pill"), 3U) << "one result per criterion";
  // Top-down view, ATE, coverage and a keyframe chart per robot.
  EXPECT_EQ(count_of(html, "<svg class=\"chart\""), 5U);
  EXPECT_EQ(count_of(html, "<polyline"), 5U) << "two ATE lines, one coverage line, two keyframe score lines";
  EXPECT_NE(html.find("run-wide"), std::string::npos);
  EXPECT_NE(html.find("&le; 0.05</td>"), std::string::npos) << "limit with its comparison";
  EXPECT_NE(html.find("&ge; 0.5</td>"), std::string::npos);
  EXPECT_NE(html.find("office_2robots"), std::string::npos);
  EXPECT_NE(html.find("2.1</td>"), std::string::npos) << "alpha's ATE rmse in cm";
  EXPECT_NE(html.find("tracking"), std::string::npos);
  EXPECT_NE(html.find("153.00"), std::string::npos) << "central timing";
  EXPECT_NE(html.find("<g class=\"scale\">"), std::string::npos) << "scale bar";
  // Escaped names and notes, never raw.
  EXPECT_NE(html.find(kOddNameEscaped), std::string::npos);
  EXPECT_EQ(html.find("b<e>"), std::string::npos);
  EXPECT_NE(html.find("value &lt;missing&gt;"), std::string::npos);
  // Self-contained.
  for (const char* external : {"http://", "https://", "<script", "<link", "url(", "@import"}) {
    EXPECT_EQ(html.find(external), std::string::npos) << external;
  }
  EXPECT_LT(html.size(), 2'000'000U) << "30k map points must stay small";
  EXPECT_EQ(render_report_html(report), html) << "same JSON, same bytes";
}

TEST(ReportHtml, FailedVerdictAndNoCriteria) {
  json report = synthetic_report(false);
  const std::string failed = render_report_html(report);
  EXPECT_NE(failed.find("class=\"banner fail\""), std::string::npos);
  EXPECT_NE(failed.find(">FAIL<small>2 of 3 criteria passed</small>"), std::string::npos);
  report["metrics"]["verdict"] = {{"passed", true}, {"criteria", json::array()}};
  const std::string none = render_report_html(report);
  EXPECT_NE(none.find(">PASS<small>no criteria</small>"), std::string::npos);
}

// A failed criterion never reads as if it held: a value just over its limit gets the decimals that tell
// them apart (0.03004 against 0.03 read "0.03 <= 0.03 FAIL").
TEST(ReportHtml, AValueJustOverItsLimitIsPrintedApart) {
  json report = synthetic_report(false);
  report["metrics"]["verdict"] = {
      {"passed", false},
      {"criteria", {{{"name", "ate_world_rmse_m"}, {"robot", ""}, {"value", 0.03004}, {"limit", 0.03},
                     {"comparison", "<="}, {"passed", false}, {"note", ""}}}}};
  const std::string html = render_report_html(report);
  EXPECT_NE(html.find(">0.03004</td>"), std::string::npos) << html;
  EXPECT_NE(html.find("0.03</td>"), std::string::npos);
}

TEST(ReportHtml, EmptyReportSaysNotAvailable) {
  std::string html;
  ASSERT_NO_THROW(html = render_report_html(json::object()));
  EXPECT_NE(html.find("</html>"), std::string::npos);
  EXPECT_NE(html.find("not available"), std::string::npos);
  EXPECT_NE(html.find("NO VERDICT"), std::string::npos);
  EXPECT_EQ(html.find("<svg class=\"chart\""), std::string::npos);
  for (const json& odd : {json(), json(5), json("text"), json::array({1, 2}), json::parse("{\"metrics\": null}")}) {
    EXPECT_NO_THROW(html = render_report_html(odd)) << odd.dump();
    EXPECT_NE(html.find("not available"), std::string::npos) << odd.dump();
  }
}

TEST(ReportHtml, OddTypedKeysRenderWithoutThrowing) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  json report;
  report["title"] = 42;
  report["metrics"] = {{"scenario", 3},
                       {"seed", "seven"},
                       {"simulated_s", nan},
                       {"wall_s", "long"},
                       {"real_time_factor", inf},
                       {"verdict", {{"passed", "yes"}, {"criteria", {3, "x", {{"name", 4}, {"value", "big"},
                                                                            {"limit", nan}, {"passed", 1}}}}}},
                       {"robots", {"alpha", {{"name", 5}, {"frames", "many"}, {"ate_world_m", {1, 2}},
                                             {"timings_ms", {{"tracking", "fast"}, {"mapping", {{"mean", nan}}}}}}}},
                       {"merged_map_accuracy", "none"},
                       {"coverage", {{"final", nan}}},
                       {"central_timings_ms", {{"merge", "x"}, {"fusion", nan}}}};
  report["series"] = {{"robots", {{{"name", "alpha"}, {"estimated_xy", {{0, nan, 1}, {"a", 1, 2}, {1, 2}}},
                                   {"truth_xy", "circle"}, {"ate_over_time", {{0, inf}}},
                                   {"keyframe_decisions", {{0, nan, 1}, {1, 0.5, "yes"}}},
                                   {"plans", {{{"path_xy", 3}}, 7}}, {"goals_xy", {{nan, 0}}}},
                                  "beta"}},
                      {"coverage_over_time", 5},
                      {"map_points", {{1, "a"}, {nan, 0, 0}, {inf, inf}, "p", {0.0, 0.0, 0.0, "r", 0, 0}}}};
  std::string html;
  ASSERT_NO_THROW(html = render_report_html(report));
  EXPECT_NE(html.find("not available"), std::string::npos);
  EXPECT_NE(html.find("n/a"), std::string::npos);
  EXPECT_EQ(html.find("nan"), std::string::npos);
  EXPECT_EQ(html.find("inf<"), std::string::npos);
  EXPECT_NE(html.find("NO VERDICT"), std::string::npos) << "\"yes\" is no boolean";
  // The map point (0, 0) with an odd colour is still drawn, in grey.
  EXPECT_NE(html.find("fill=\"#999\""), std::string::npos);
  // Finite but absurd values are no reason to fail either.
  report["series"]["robots"][0]["estimated_xy"] = {{0.0, -1e300, 0.0}, {1.0, 1e300, 1.0}};
  report["series"]["robots"][0]["ate_over_time"] = {{0.0, 1e308}, {1.0, -1e308}};
  report["series"]["coverage_over_time"] = {{-1e308, 2.0}, {1e308, -3.0}};
  ASSERT_NO_THROW(html = render_report_html(report));
  EXPECT_NE(html.find("out of range"), std::string::npos);
}

TEST(ReportHtml, WritesTheFileAndNamesItWhenItCannot) {
  const fs::path dir = test_dir();
  const json report = synthetic_report(true);
  const fs::path file = dir / "report.html";
  write_report_html(file, report);
  EXPECT_EQ(test::read_text(file), render_report_html(report));

  const fs::path missing = dir / "no_such_folder" / "report.html";
  try {
    write_report_html(missing, report);
    ADD_FAILURE() << "no error for " << missing;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(missing.string()), std::string::npos) << e.what();
  }
  EXPECT_THROW(write_report_html(dir, report), InputError) << "a folder is no file";
  EXPECT_THROW(write_report_html(file / "report.html", report), InputError) << "below a file";
}

TEST(ReportHtml, HeadlessChromiumParsesAndDrawsThePage) {
  if (!fs::exists("/usr/bin/chromium")) {
    GTEST_SKIP() << "/usr/bin/chromium is not installed (scripts/install_deps.sh installs it)";
  }
  const fs::path dir = test_dir();
  const fs::path html = dir / "report.html";
  write_report_html(html, synthetic_report(true));

  const std::string dom = shell_output(chromium_command(dir / "profile_dom", "--dump-dom", html) + " 2>/dev/null");
  ASSERT_NE(dom.find("</html>"), std::string::npos) << "no DOM dumped: " << dom.substr(0, 500);
  EXPECT_NE(dom.find("PASS"), std::string::npos);
  for (const char* name : {"ate_world_rmse_m", "coverage_final", "collisions_max"}) {
    EXPECT_NE(dom.find(name), std::string::npos) << name;
  }
  EXPECT_NE(dom.find("<svg"), std::string::npos);

  const fs::path png = dir / "report.png";
  const std::string log =
      shell_output(chromium_command(dir / "profile_shot", "--screenshot='" + png.string() + "'", html) + " 2>&1");
  ASSERT_TRUE(fs::exists(png)) << log;
  const cv::Mat image = cv::imread(png.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty()) << "cannot decode " << png;
  EXPECT_GT(image.cols, 0);
  EXPECT_GT(image.rows, 0);
  EXPECT_EQ(image.cols, 1200);
  EXPECT_EQ(image.rows, 2400);
  std::unordered_set<std::uint32_t> colours;
  std::size_t banner_pixels = 0;
  for (int r = 0; r < image.rows; ++r) {
    for (int c = 0; c < image.cols; ++c) {
      const cv::Vec3b bgr = image.at<cv::Vec3b>(r, c);
      colours.insert((std::uint32_t{bgr[2]} << 16) | (std::uint32_t{bgr[1]} << 8) | bgr[0]);
      if (std::abs(bgr[2] - 0x1e) < 12 && std::abs(bgr[1] - 0x8e) < 12 && std::abs(bgr[0] - 0x3e) < 12) {
        ++banner_pixels;
      }
    }
  }
  EXPECT_GT(colours.size(), 10U) << "the page is one colour: nothing drawn";
  EXPECT_GT(banner_pixels, 5000U) << "no green PASS banner";
}

}  // namespace
}  // namespace fleetslam
