#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <spdlog/logger.h>

#include "fleetslam/core/error.hpp"
#include "fleetslam/core/log.hpp"

namespace fleetslam::core {
namespace {

std::vector<std::size_t> reports(std::size_t total, const std::vector<std::size_t>& updates, double step) {
  std::vector<std::size_t> seen;
  Progress progress("work", total, [&](std::size_t done, std::size_t, const std::string&) { seen.push_back(done); },
                    Progress::Config{step});
  for (std::size_t u : updates) progress.update(u);
  progress.finish();
  return seen;
}

TEST(Progress, ReportsAtEachStepAndOnceAtTheEnd) {
  std::vector<std::size_t> all;
  for (std::size_t i = 0; i <= 100; ++i) all.push_back(i);
  const auto seen = reports(100, all, 0.25);
  EXPECT_EQ(seen, (std::vector<std::size_t>{0, 25, 50, 75, 100}));
}

TEST(Progress, IgnoresGoingBackwardsAndRepeatedFinish) {
  const auto seen = reports(10, {5, 3, 5, 10, 10}, 0.5);
  EXPECT_EQ(seen, (std::vector<std::size_t>{5, 10}));
}

TEST(Progress, EmptyWorkReportsCompletion) {
  const auto seen = reports(0, {}, 0.1);
  EXPECT_EQ(seen, (std::vector<std::size_t>{0}));
}

TEST(Logger, WritesToAFileAndIsIndependent) {
  const auto path = std::filesystem::temp_directory_path() / "fleetslam_test_log.txt";
  {
    Logger a = make_logger("robot_a", LogLevel::kInfo, path.string());
    Logger b = make_logger("robot_b", LogLevel::kWarn);
    a->info("hello {}", 42);
    a->debug("hidden");
    EXPECT_FALSE(b->should_log(spdlog::level::info));
    a->flush();
  }
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find("[robot_a] [info] hello 42"), std::string::npos);
  EXPECT_EQ(text.str().find("hidden"), std::string::npos);
  std::filesystem::remove(path);
}

TEST(Logger, UnwritableFileIsAnInputError) {
  // A regular file where a folder should be: cannot be created, even as root.
  const auto blocker = std::filesystem::temp_directory_path() / "fleetslam_test_log_blocker";
  std::ofstream(blocker) << "x";
  EXPECT_THROW(make_logger("x", LogLevel::kInfo, (blocker / "log.txt").string()), InputError);
  std::filesystem::remove(blocker);
}

TEST(Logger, NullLoggerDropsEverything) {
  Logger logger = null_logger();
  EXPECT_FALSE(logger->should_log(spdlog::level::critical));
  logger->error("nothing");
}

}  // namespace
}  // namespace fleetslam::core
