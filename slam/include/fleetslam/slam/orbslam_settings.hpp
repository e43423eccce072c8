#pragma once
// An ORB-SLAM settings file's front-end values over the agent's front-end config: how `replay` and the
// experiments run a sequence with the settings it comes with (core/orbslam_settings.hpp reads the file).

#include "fleetslam/core/orbslam_settings.hpp"
#include "fleetslam/slam/frame_builder.hpp"

namespace fleetslam::slam {

// ORBextractor.nFeatures / scaleFactor / nLevels / iniThFAST / minThFAST, and ThDepth when it is set.
void apply_orbslam_settings(const core::OrbSlamSettings& settings, FrameBuilderConfig& frontend);

}  // namespace fleetslam::slam
