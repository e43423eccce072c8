#pragma once
// What the CLI tests share: running the built `fleetslam` binary (FLEETSLAM_CLI) and capturing what it
// printed, a fresh scratch folder per test, and reading a file whole.

#include <gtest/gtest.h>

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace fleetslam::test {

struct CliResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

// Runs `fleetslam ARGUMENTS` (in `cwd` when given).
inline CliResult run_cli(const std::string& arguments, const std::filesystem::path& cwd = {}) {
  const std::string prefix = cwd.empty() ? std::string() : "cd '" + cwd.string() + "' && ";
  const std::string command = prefix + "'" FLEETSLAM_CLI "' " + arguments + " 2>&1";
  CliResult result;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return result;
  std::array<char, 4096> buffer{};
  std::size_t n = 0;
  while ((n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) result.output.append(buffer.data(), n);
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

// An empty folder <tmp>/<group>/<suite>.<test> for the running test.
inline std::filesystem::path fresh_test_dir(const std::string& group) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / group / (std::string(info->test_suite_name()) + "." + info->name());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

inline std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace fleetslam::test
