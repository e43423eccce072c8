#pragma once
// What pose optimisation and bundle adjustment see of one feature of a frame, for the source files that
// build their problems (tracking, local mapping, loop closing).

#include <cstddef>

#include "fleetslam/slam/frame.hpp"
#include "fleetslam/slam/optimizer.hpp"

namespace fleetslam::slam {

// Feature i's pixel, its (real or virtual) right coordinate when it has one (three residuals: depth
// constrains the point too) and the inverse variance of its pyramid level.
inline Observation observation_of(const Frame& f, std::size_t i) {
  Observation o;
  o.uv = f.uv[i];
  if (f.has_right(i)) o.u_right = f.u_right[i];
  o.inv_sigma2 = f.pyramid.inv_sigma2[static_cast<std::size_t>(f.level[i])];
  return o;
}

}  // namespace fleetslam::slam
