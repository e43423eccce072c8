#include "fleetslam/core/sensor_rig.hpp"

namespace fleetslam::core {

std::string to_string(SensorMode mode) {
  switch (mode) {
    case SensorMode::kMonocular: return "monocular";
    case SensorMode::kStereo: return "stereo";
    case SensorMode::kRgbd: return "rgbd";
    case SensorMode::kMonoInertial: return "mono_inertial";
    case SensorMode::kStereoInertial: return "stereo_inertial";
  }
  return "unknown";
}

std::optional<SensorMode> sensor_mode_from_string(const std::string& name) {
  for (SensorMode mode : {SensorMode::kMonocular, SensorMode::kStereo, SensorMode::kRgbd,
                          SensorMode::kMonoInertial, SensorMode::kStereoInertial}) {
    if (to_string(mode) == name) return mode;
  }
  return std::nullopt;
}

}  // namespace fleetslam::core
