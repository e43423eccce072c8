#pragma once
// A picture of an evaluation as a self-contained SVG file (written by hand, no plotting library):
// on top the ground truth and the aligned estimate seen from above — on the two axes along which the
// ground truth extends most, at equal scale, with a metric grid, axis labels, a legend and a scale bar —
// and below the ATE of each pair over time with its RMSE. Lines break where the data has a gap (more than
// five times the median spacing), so that dropouts do not show as straight segments.

#include <filesystem>
#include <string>

#include "fleetslam/core/trajectory.hpp"
#include "fleetslam/core/trajectory_metrics.hpp"

namespace fleetslam::core {

struct TrajectoryPlotLabels {
  std::string title;         // first line, e.g. the two file names
  std::string subtitle;      // second line, e.g. "se3 alignment, ATE RMSE 0.0081 m"
  std::string gt_name = "ground truth";
  std::string est_name = "estimate (aligned)";
  bool errors_over_time = true;  // false: the error curve runs over the pose index (KITTI has no time)
};

// gt and est_aligned in the same frame (apply_alignment); ate gives the error curve (may be empty).
std::string trajectory_svg(const Trajectory& gt, const Trajectory& est_aligned, const AteResult& ate,
                           const TrajectoryPlotLabels& labels);

// Writes trajectory_svg to path (creates parent folders); InputError naming the file on failure.
void write_trajectory_svg(const std::filesystem::path& path, const Trajectory& gt, const Trajectory& est_aligned,
                          const AteResult& ate, const TrajectoryPlotLabels& labels);

}  // namespace fleetslam::core
