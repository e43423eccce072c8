#pragma once
// Dubins and Reeds-Shepp state spaces whose motions are collision-checked along the curve. OMPL 1.5
// counts the checks of a motion (validSegmentCount, used by its motion validators) from the SE(2)
// components of its ends: the straight xy distance and the yaw change, not the curve the motion drives.
// A loop that ends near where it starts was checked at a handful of points. Here the count comes from
// the curve's length (distance() of these spaces), at the space's longest valid segment apart. Private to
// the planners library (OMPL stays out of its public headers); its test includes it from here.

#include <algorithm>
#include <cmath>

#include <ompl/base/spaces/DubinsStateSpace.h>
#include <ompl/base/spaces/ReedsSheppStateSpace.h>

namespace fleetslam::planners {

template <class CurveSpace>
class CurveCheckedSpace : public CurveSpace {
 public:
  using CurveSpace::CurveSpace;

  unsigned int validSegmentCount(const ompl::base::State* a, const ompl::base::State* b) const override {
    const double segment = this->getLongestValidSegmentLength();
    const double curve = this->distance(a, b);
    const unsigned int along_curve =
        segment > 0.0 && std::isfinite(curve) ? static_cast<unsigned int>(std::ceil(curve / segment)) : 1U;
    // Never fewer than OMPL's own count (a turn on the spot has a short curve and a large yaw change).
    return std::max({1U, along_curve * this->longestValidSegmentCountFactor_, CurveSpace::validSegmentCount(a, b)});
  }
};

using CurveCheckedDubins = CurveCheckedSpace<ompl::base::DubinsStateSpace>;
using CurveCheckedReedsShepp = CurveCheckedSpace<ompl::base::ReedsSheppStateSpace>;

}  // namespace fleetslam::planners
