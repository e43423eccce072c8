#include "fleetslam/slam/orbslam_settings.hpp"

namespace fleetslam::slam {

void apply_orbslam_settings(const core::OrbSlamSettings& settings, FrameBuilderConfig& frontend) {
  OrbExtractorConfig& orb = frontend.orb;
  orb.num_features = settings.orb.num_features;
  orb.scale_factor = settings.orb.scale_factor;
  orb.num_levels = settings.orb.num_levels;
  orb.ini_fast_threshold = settings.orb.ini_fast_threshold;
  orb.min_fast_threshold = settings.orb.min_fast_threshold;
  if (settings.th_depth > 0.0) frontend.close_depth_baselines = settings.th_depth;
}

}  // namespace fleetslam::slam
