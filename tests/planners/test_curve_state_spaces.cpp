// Dubins and Reeds-Shepp motions are collision-checked along their curve: a loop that ends next to where
// it starts, through a blocked region its ends are far from, is refused (OMPL's own count checked it at
// a handful of points and let it through).

#include <cmath>
#include <memory>

#include <gtest/gtest.h>

#include <ompl/base/ScopedState.h>
#include <ompl/base/SpaceInformation.h>

#include "curve_state_spaces.hpp"  // planners/src (private)

namespace fleetslam::planners {
namespace {

namespace ob = ompl::base;

struct Checked {
  std::shared_ptr<ob::SE2StateSpace> space;
  ob::SpaceInformationPtr si;
};

// A 10 x 10 m space checked every 2.5 cm (the planner's half of a 5 cm cell), free except y > 1.5.
Checked make(const std::shared_ptr<ob::SE2StateSpace>& space) {
  ob::RealVectorBounds bounds(2);
  bounds.setLow(-5.0);
  bounds.setHigh(5.0);
  space->setBounds(bounds);
  auto si = std::make_shared<ob::SpaceInformation>(space);
  si->setStateValidityChecker([](const ob::State* st) { return st->as<ob::SE2StateSpace::StateType>()->getY() <= 1.5; });
  si->setStateValidityCheckingResolution(0.025 / space->getMaximumExtent());
  si->setup();
  return {space, si};
}

ob::ScopedState<ob::SE2StateSpace> pose(const Checked& c, double x, double y, double yaw) {
  ob::ScopedState<ob::SE2StateSpace> s(c.space);
  s->setXY(x, y);
  s->setYaw(yaw);
  return s;
}

// Facing +x, 10 cm left of a start facing +x: with a 1 m turning radius a forward-only Dubins car drives
// a loop about 2 m high (a left loop reaches y ~ 2); Reeds-Shepp may back up, so its motion is sideways
// parking, short and low.
TEST(CurveStateSpaces, DubinsLoopIsCheckedAlongTheCurve) {
  const Checked plain = make(std::make_shared<ob::DubinsStateSpace>(1.0));
  const Checked curve = make(std::make_shared<CurveCheckedDubins>(1.0));
  for (const Checked* c : {&plain, &curve}) {
    const auto a = pose(*c, 0.0, 0.0, 0.0);
    const auto b = pose(*c, 0.0, 0.1, 0.0);
    const double length = c->space->distance(a.get(), b.get());
    ASSERT_GT(length, 5.0);  // a loop, not the 10 cm between the ends
    // The loop's highest point: the dense interpolation along it, as the planner's own re-check samples.
    double top = -1e9;
    ob::ScopedState<ob::SE2StateSpace> s(c->space);
    for (int k = 0; k <= 1000; ++k) {
      c->space->interpolate(a.get(), b.get(), k / 1000.0, s.get());
      top = std::max(top, s->getY());
    }
    if (top <= 1.5) GTEST_SKIP() << "this OMPL's Dubins loop turns right; the region above is never entered";
    if (c == &plain) {
      // OMPL's count, from the ends: a few points, far fewer than the 2.5 cm steps along the curve.
      EXPECT_LT(c->space->validSegmentCount(a.get(), b.get()), length / 0.025 / 4.0);
    } else {
      EXPECT_GE(c->space->validSegmentCount(a.get(), b.get()), std::floor(length / 0.025));
      EXPECT_FALSE(c->si->checkMotion(a.get(), b.get())) << "the loop passes y = " << top;
    }
  }
}

TEST(CurveStateSpaces, ShortMotionsKeepAtLeastOmplsCount) {
  for (const bool reeds_shepp : {false, true}) {
    const Checked c = reeds_shepp ? make(std::make_shared<CurveCheckedReedsShepp>(0.5))
                                  : make(std::make_shared<CurveCheckedDubins>(0.5));
    const auto a = pose(c, 0.0, 0.0, 0.0);
    const auto b = pose(c, 1.0, 0.0, 0.0);  // straight ahead: the curve is the segment
    EXPECT_GE(c.space->validSegmentCount(a.get(), b.get()), 40u);  // 2.5 cm along 1 m
    const auto same = pose(c, 0.0, 0.0, 0.0);
    EXPECT_GE(c.space->validSegmentCount(a.get(), same.get()), 1u);
    EXPECT_TRUE(c.si->checkMotion(a.get(), b.get()));
  }
}

}  // namespace
}  // namespace fleetslam::planners
