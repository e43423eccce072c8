#pragma once
// Stamped pose sequences and their files.
//   TUM:   "t tx ty tz qx qy qz qw", t in decimal seconds, '#' comments, space/tab/comma separated.
//   EuRoC: "t_ns,px,py,pz,qw,qx,qy,qz[,...]" (extra columns such as velocity and biases ignored).
//   KITTI: 12 numbers per line, the row-major 3x4 matrix [R|t]; no time: line i gets t_ns = i.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "fleetslam/core/time.hpp"

namespace fleetslam::core {

struct StampedPose {
  TimeNs t_ns = 0;
  Eigen::Isometry3d T_world_body = Eigen::Isometry3d::Identity();
};

// Poses in time order (strictly increasing t_ns).
using Trajectory = std::vector<StampedPose>;

enum class TrajectoryFormat { kTum, kEuroc, kKitti };

std::string to_string(TrajectoryFormat format);
std::optional<TrajectoryFormat> trajectory_format_from_string(const std::string& name);

// Guesses the format from the first data lines: 12 numbers -> KITTI; comma-separated with an
// integer-nanosecond first column -> EuRoC; 8 numbers -> TUM. Throws InputError naming the file when
// it cannot tell or the file cannot be read.
TrajectoryFormat detect_trajectory_format(const std::filesystem::path& path);

// Reads a trajectory. Throws InputError "file:line: why" on malformed or truncated lines, NaN/inf values,
// zero-norm quaternions, and non-increasing timestamps; an empty file is an error too.
Trajectory read_trajectory(const std::filesystem::path& path,
                           std::optional<TrajectoryFormat> format = std::nullopt);

// Writes a trajectory (creates parent folders). Throws InputError when the file cannot be written.
void write_trajectory(const std::filesystem::path& path, const Trajectory& trajectory,
                      TrajectoryFormat format);

}  // namespace fleetslam::core
