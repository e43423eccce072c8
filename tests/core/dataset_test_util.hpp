#pragma once
// Helpers of the dataset tests: temporary folders, seeded synthetic content, error-message checks.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <initializer_list>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <opencv2/core.hpp>

#include "fleetslam/core/error.hpp"
#include "fleetslam/core/sensor_frame.hpp"

namespace fleetslam::core::test {

// A fresh folder per test, removed afterwards.
class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = std::filesystem::temp_directory_path() /
            ("fleetslam_" + std::string(info->test_suite_name()) + "_" + info->name() + "_" +
             std::to_string(::getpid()));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

inline cv::Mat random_image(int width, int height, int type, std::uint64_t seed) {
  cv::Mat image(height, width, type);
  cv::RNG rng(seed);
  rng.fill(image, cv::RNG::UNIFORM, 0, 256);
  return image;
}

// Depth in [0.3, 6) m with every 7th pixel 0 (no measurement).
inline cv::Mat random_depth(int width, int height, std::uint64_t seed) {
  cv::Mat depth(height, width, CV_32FC1);
  cv::RNG rng(seed);
  rng.fill(depth, cv::RNG::UNIFORM, 0.3, 6.0);
  for (int i = 0; i < width * height; i += 7) depth.at<float>(i / width, i % width) = 0.0f;
  return depth;
}

inline Eigen::Isometry3d random_pose(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng) + 2.0).normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(u(rng), u(rng), u(rng));
  return T;
}

inline bool same_image(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0.0;
}

// Runs fn, expects an InputError whose message holds every part; returns the message.
inline std::string expect_input_error(const std::function<void()>& fn, std::initializer_list<std::string> parts) {
  try {
    fn();
  } catch (const InputError& e) {
    const std::string message = e.what();
    for (const std::string& part : parts) {
      EXPECT_NE(message.find(part), std::string::npos) << "'" << part << "' not in: " << message;
    }
    EXPECT_EQ(message.find('\n'), std::string::npos) << "not one line: " << message;
    return message;
  }
  ADD_FAILURE() << "no InputError thrown";
  return {};
}

inline void write_file(const std::filesystem::path& file, const std::string& text) {
  std::ofstream out(file, std::ios::binary);
  out << text;
}

inline std::string read_file(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// Replaces the 1-based line `number` of a text file.
inline void replace_line(const std::filesystem::path& file, std::size_t number, const std::string& text) {
  std::ifstream in(file);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  in.close();
  lines.at(number - 1) = text;
  std::ofstream out(file);
  for (const std::string& line : lines) out << line << "\n";
}

// Line number (1-based) of the first line containing `part`; 0 when none.
inline std::size_t line_of(const std::filesystem::path& file, const std::string& part) {
  std::ifstream in(file);
  std::size_t number = 0;
  for (std::string line; std::getline(in, line);) {
    ++number;
    if (line.find(part) != std::string::npos) return number;
  }
  return 0;
}

}  // namespace fleetslam::core::test
