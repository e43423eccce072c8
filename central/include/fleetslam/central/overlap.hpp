#pragma once
// Coarse matching (PAPER.md section 4, paper eqs. 6-7): clouds A and B already in the world frame (each
// mapped by its robot's initial-pose prior T_world_robot); the overlap sets P'_A, P'_B are the points of
// A and B that are mutual nearest neighbours within coarse_radius_m: a in A and b in B form a pair when
// b is a's nearest point of B, a is b's nearest point of A, and |a - b| <= coarse_radius_m. An empty
// overlap means no loop between the two robots (the coarse result stands).
//
// Exact (equal distances go to the smaller index), so the sets do not depend on the processing order.
// Only points within coarse_radius_m of the other cloud can pair: a voxel pre-pass (voxels of the radius)
// keeps the others out of the kd-trees, so the cost follows the overlapping part, not the whole clouds.
// Non-finite points never pair. When both clouds carry normals, a pair whose normals (both known)
// differ by more than max_normal_angle_deg is left out and counted: the two faces of a thin wall lie
// closer than the radius, face opposite ways, and are not the same surface.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/point_cloud.hpp"

namespace fleetslam::central {

struct OverlapConfig {
  // Must exceed the prior's error where the clouds overlap: 5 degrees of heading error moves a point
  // 3 m away by 26 cm.
  double coarse_radius_m = 0.3;
  // Generous: only faces turned clearly away from each other are refused. Normals from depth images are
  // noisy at edges and corners, and refusing those pairs too (60 degrees) thinned the apartment's overlap
  // so much that the merge placed bravo 14.6 cm off, against 7.4 cm at 120 (9.6 cm without normals,
  // with the thin walls' faces paired). 180: off.
  double max_normal_angle_deg = 120.0;

  template <class V>
  void visit(V& v) {
    v("coarse_radius_m", coarse_radius_m, core::Limits<double>{1e-3, 100.0});
    v("max_normal_angle_deg", max_normal_angle_deg, core::Limits<double>{0.0, 180.0});
  }
};

struct Overlap {
  // Mutual pairs: indices_a[i] (into A) with indices_b[i] (into B), ascending in indices_a.
  std::vector<std::uint32_t> indices_a;
  std::vector<std::uint32_t> indices_b;
  double mean_distance_m = 0.0;  // over the pairs
  std::size_t normal_rejected = 0;  // mutual nearest neighbours left out for disagreeing normals

  std::size_t size() const { return indices_a.size(); }
  bool empty() const { return indices_a.empty(); }
};

class OverlapFinder {
 public:
  using Config = OverlapConfig;

  // Throws InputError ("overlap.coarse_radius_m: ...") for a radius that is not positive, or an angle
  // outside [0, 180].
  explicit OverlapFinder(const Config& config);

  Overlap find(const core::PointCloud& a_world, const core::PointCloud& b_world) const;

  const Config& config() const { return config_; }

 private:
  Config config_;
};

// The overlap regions, a cheaper and looser selection than the mutual pairs: the points of A near B and
// those of B near A, by a voxel test with voxels of radius_m (a point is near when a voxel next to its own
// holds a point of the other cloud: every point within radius_m is included, none farther than
// 2 sqrt(3) radius_m). No kd-tree; MapMerger's refinement rounds use it. Ascending indices; non-finite
// points are left out.
struct OverlapRegions {
  std::vector<std::uint32_t> indices_a;
  std::vector<std::uint32_t> indices_b;
};
OverlapRegions overlap_regions(const core::PointCloud& a_world, const core::PointCloud& b_world, double radius_m);

// The points (and colours) of `cloud` at `indices`, in that order.
core::PointCloud select_points(const core::PointCloud& cloud, const std::vector<std::uint32_t>& indices);

}  // namespace fleetslam::central
