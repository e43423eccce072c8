// Calibration files read through cv::FileStorage, and the file-system side of the writers.

#include <algorithm>
#include <cmath>
#include <fstream>
#include <system_error>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "dataset_internal.hpp"
#include "fleetslam/core/error.hpp"

namespace fleetslam::core::dataset_detail {

// The EuRoC sensor.yaml and ORB-SLAM settings files start with "%YAML:1.0", which yaml-cpp rejects;
// OpenCV's FileStorage reads them. Its exceptions become InputErrors naming the file.
SettingsFile::SettingsFile(const std::filesystem::path& file) : file_(file.string()) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) throw InputError(file_, "missing calibration file");
  try {
    storage_.open(file_, cv::FileStorage::READ);
  } catch (const cv::Exception& e) {
    throw InputError(file_, "malformed calibration file: " + e.err);
  }
  if (!storage_.isOpened()) throw InputError(file_, "cannot read the calibration file");
}

cv::FileNode SettingsFile::node(const std::string& key) const {
  try {
    return storage_[key];
  } catch (const cv::Exception& e) {
    throw InputError(where(key), e.err);
  }
}

bool SettingsFile::has(const std::string& key) const { return !node(key).empty(); }

double SettingsFile::number(const std::string& key) const {
  const cv::FileNode n = node(key);
  if (n.empty()) throw InputError(where(key), "missing key");
  if (!n.isReal() && !n.isInt()) throw InputError(where(key), "expected a number");
  const double value = n.real();
  if (!std::isfinite(value)) throw InputError(where(key), "not a finite number");
  return value;
}

std::string SettingsFile::text(const std::string& key) const {
  const cv::FileNode n = node(key);
  if (n.empty()) throw InputError(where(key), "missing key");
  if (!n.isString()) throw InputError(where(key), "expected text");
  return n.string();
}

std::vector<double> SettingsFile::numbers(const std::string& key, std::initializer_list<std::size_t> sizes,
                                          const std::string& child) const {
  const std::string name = child.empty() ? key : key + "." + child;
  cv::FileNode n = node(key);
  if (!child.empty() && n.isMap()) n = n[child];
  if (n.empty()) throw InputError(where(name), "missing key");
  if (!n.isSeq()) throw InputError(where(name), "expected a list of numbers");
  std::vector<double> values;
  for (const cv::FileNode& item : n) {
    if (!item.isReal() && !item.isInt()) throw InputError(where(name), "expected a list of numbers");
    values.push_back(item.real());
    if (!std::isfinite(values.back())) throw InputError(where(name), "holds a value that is not finite");
  }
  if (std::find(sizes.begin(), sizes.end(), values.size()) == sizes.end()) {
    throw InputError(where(name), "has " + std::to_string(values.size()) + " numbers, expected " +
                                      std::to_string(*sizes.begin()));
  }
  return values;
}

namespace {

// In a staging folder while a writer fills it: a folder named like a staging folder without it is not
// ours to remove.
constexpr const char* kStagingMarker = ".fleetslam_partial";

// `root` without a trailing separator, so that a sibling can be named after it ("out/" -> "out").
std::filesystem::path without_trailing_separator(const std::filesystem::path& root) {
  std::filesystem::path r = root.lexically_normal();
  if (r.filename().empty() && r.has_parent_path()) r = r.parent_path();
  return r;
}

}  // namespace

std::filesystem::path begin_staged_folder(const std::filesystem::path& root) {
  std::error_code ec;
  if (std::filesystem::exists(root, ec)) {
    if (!std::filesystem::is_directory(root, ec)) throw InputError(root.string(), "exists and is not a folder");
    if (!std::filesystem::is_empty(root, ec)) {
      throw InputError(root.string(), "output folder exists and is not empty (refusing to mix sequences)");
    }
  }
  const std::filesystem::path r = without_trailing_separator(root);
  if (r.filename().empty() || r.filename() == "." || r.filename() == "..") {
    throw InputError(root.string(), "name the output folder itself (a sequence is written beside it first)");
  }
  std::filesystem::path staging = r;
  staging += ".partial";
  if (std::filesystem::exists(staging, ec)) {
    const bool ours = std::filesystem::is_directory(staging, ec) &&
                      (std::filesystem::is_empty(staging, ec) || std::filesystem::exists(staging / kStagingMarker, ec));
    if (!ours) {
      throw InputError(staging.string(), "exists and is not an incomplete write of fleetslam's (it has no " +
                                             std::string(kStagingMarker) + "); move it away, the sequence is written "
                                                                            "there first");
    }
    std::filesystem::remove_all(staging, ec);
    if (ec) throw InputError(staging.string(), "cannot remove an earlier incomplete write: " + ec.message());
  }
  std::filesystem::create_directories(staging, ec);
  if (ec) throw InputError(staging.string(), "cannot create the folder: " + ec.message());
  std::ofstream marker(staging / kStagingMarker);
  marker << "an incomplete sequence written by fleetslam; a new write to " << r.string() << " removes it\n";
  if (!marker) throw InputError((staging / kStagingMarker).string(), "cannot write the file");
  return staging;
}

void commit_staged_folder(const std::filesystem::path& staging, const std::filesystem::path& root) {
  const std::filesystem::path r = without_trailing_separator(root);
  std::error_code ec;
  std::filesystem::remove(staging / kStagingMarker, ec);
  if (ec) throw InputError((staging / kStagingMarker).string(), "cannot remove the file: " + ec.message());
  if (std::filesystem::is_directory(r, ec) && std::filesystem::is_empty(r, ec)) std::filesystem::remove(r, ec);
  std::filesystem::rename(staging, r, ec);
  if (ec) throw InputError(r.string(), "cannot move the written sequence here from " + staging.string() + ": " + ec.message());
}

void write_image(const std::filesystem::path& file, const cv::Mat& image) {
  bool written = false;
  try {
    written = cv::imwrite(file.string(), image);
  } catch (const cv::Exception& e) {
    throw InputError(file.string(), "cannot write the image: " + e.err);
  }
  if (!written) throw InputError(file.string(), "cannot write the image");
}

void check_imu_truth_pairs(const SensorFrame& frame, const std::string& frame_name) {
  // The truths' stamps must be a subsequence of the samples' (both in time order).
  auto sample = frame.imu.begin();
  for (const ImuTruth& truth : frame.imu_truth) {
    while (sample != frame.imu.end() && sample->t_ns != truth.t_ns) ++sample;
    if (sample == frame.imu.end()) {
      throw InputError(frame_name, "its IMU truth at " + std::to_string(truth.t_ns) +
                                       " ns is not at one of its IMU samples (in time order, one truth per sample)");
    }
    ++sample;
  }
}

std::vector<MergedRow> merge_in_time(const std::vector<TimeNs>& first, const std::vector<TimeNs>& second) {
  std::vector<MergedRow> rows;
  rows.reserve(first.size() + second.size());
  std::size_t f = 0;
  std::size_t k = 0;
  while (f < first.size() || k < second.size()) {
    if (k == second.size() || (f < first.size() && first[f] <= second[k])) {
      if (k < second.size() && second[k] == first[f]) ++k;
      rows.push_back({true, f++});
    } else {
      rows.push_back({false, k++});
    }
  }
  return rows;
}

}  // namespace fleetslam::core::dataset_detail
