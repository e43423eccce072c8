#pragma once
// Stamped pose sequences and their files.
//   TUM:   "t tx ty tz qx qy qz qw", t in decimal seconds (exact, never through a double unless written in
//          scientific notation). A first column that is an integer of 16 or more digits is taken as
//          nanoseconds (ORB-SLAM3 writes EuRoC runs that way).
//   EuRoC: "t_ns,px,py,pz,qw,qx,qy,qz[,...]": integer nanoseconds (a fraction of zeros such as
//          "1403715274312143104.0000000000" is accepted); extra columns (velocity, biases) are ignored.
//   KITTI: 12 numbers per line, the row-major 3x4 matrix [R|t]; no time: line i (0-based pose index)
//          gets t_ns = i. R must be a rotation to 1e-3 and is projected onto SO(3) on reading.
// Every format: fields separated by spaces, tabs or one comma (with optional spaces around it); lines
// starting with '#' and blank lines are skipped. Line numbers in errors are 1-based physical lines.

#include <cstddef>
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

// "tum", "euroc", "kitti".
std::string to_string(TrajectoryFormat format);
// Accepts the names of to_string (case-insensitive); nullopt otherwise.
std::optional<TrajectoryFormat> trajectory_format_from_string(const std::string& name);

// Guesses the format from the header and the first data line:
//   - a '#' header naming nanoseconds ("[ns]") or a first column that is an integer nanosecond stamp in a
//     comma-separated line -> EuRoC (so a comma-separated "TUM" file with ns stamps and w,x,y,z order,
//     such as EuRoC ground truth exported by hand, reads as EuRoC);
//   - 12 numbers -> KITTI; 8 numbers -> TUM.
// Throws InputError naming the file (and line) when it cannot tell or the file cannot be read.
TrajectoryFormat detect_trajectory_format(const std::filesystem::path& path);

// What to do with two consecutive poses with the same stamp. Real files have them (TUM fr2_desk ground
// truth, some EuRoC estimates). The TUM benchmark tools keep the last one (a Python dict); a decreasing
// stamp is always an error.
enum class DuplicateStamps { kError, kKeepFirst, kKeepLast };

struct TrajectoryReadOptions {
  std::optional<TrajectoryFormat> format;  // nullopt: detect_trajectory_format
  DuplicateStamps duplicate_stamps = DuplicateStamps::kError;
  // EuRoC: keep each line's numbers after the quaternion (state ground truth: velocity and biases); a
  // line with another number of columns than the first is then an InputError at that line.
  bool keep_columns_after_pose = false;
};

// A trajectory with what reading it found out.
struct TrajectoryFile {
  Trajectory trajectory;
  TrajectoryFormat format = TrajectoryFormat::kTum;
  std::size_t duplicates_dropped = 0;
  std::size_t first_duplicate_line = 0;  // 1-based; 0 when there was none
  // With keep_columns_after_pose, for a EuRoC file: one entry per pose (of the line kept); empty otherwise.
  std::vector<std::vector<double>> columns_after_pose;
};

// Reads a trajectory. Throws InputError "file:line: why" on malformed or truncated lines, wrong column
// counts, NaN/inf values, zero-norm quaternions, non-rotation KITTI matrices and non-increasing
// timestamps (equal ones as options.duplicate_stamps says); an empty file (no poses) and a missing file
// are errors naming the file. TUM stamps are seconds, except stamps of 16+ integer digits and files whose
// stamps are all whole numbers a median of 1000 or more apart: nanoseconds (ORB-SLAM3's EuRoC output,
// "t_ns tx ty tz qx qy qz qw", also of a simulated clock that starts at 0).
TrajectoryFile read_trajectory_file(const std::filesystem::path& path,
                                    const TrajectoryReadOptions& options);

// Same with strict stamps; returns the poses only.
Trajectory read_trajectory(const std::filesystem::path& path,
                           std::optional<TrajectoryFormat> format = std::nullopt);

// Writes a trajectory (creates parent folders). Stamps are exact (TUM: 9 decimals, EuRoC: integer ns;
// KITTI has none and drops them). Numbers use the shortest form that reads back to the same double, so
// positions round-trip bit for bit and rotations to ~1e-16 (through a quaternion). Throws InputError
// when the file cannot be written.
void write_trajectory(const std::filesystem::path& path, const Trajectory& trajectory,
                      TrajectoryFormat format);
// write_trajectory's header line (newline included; empty for KITTI) and one line for a pose.
std::string trajectory_file_header(TrajectoryFormat format);
std::string format_trajectory_line(const StampedPose& pose, TrajectoryFormat format);

}  // namespace fleetslam::core
