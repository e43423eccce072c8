#pragma once
// 3D Gaussian filtering of positions (PAPER.md section 4, paper eq. 13 with an isotropic covariance
// sigma_m^2 I): each point x0 moves to the Gaussian-weighted mean of itself and its `neighbours` nearest
// points within radius_m,
//   x0' = sum_i w_i x_i / sum_i w_i,  w_i = exp(-|x_i - x0|^2 / (2 sigma_m^2)),  i over {x0} and its neighbours
// (the paper: six neighbours). Every point is filtered from the input positions (not from already moved
// ones), neighbours with equal distances are taken by smaller index: the result does not depend on the
// processing order and is bit-identical run to run. Colours are unchanged; a point with no neighbour
// within radius_m stays where it is; non-finite points are dropped and counted.

#include <cstddef>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/point_cloud.hpp"

namespace fleetslam::central {

struct GaussianFilterConfig {
  bool enabled = true;
  int neighbours = 6;      // besides the point itself (the paper's six)
  double sigma_m = 0.02;   // about the 2 cm spacing of the sampled map
  double radius_m = 0.05;  // neighbours farther than this are not used

  template <class V>
  void visit(V& v) {
    v("enabled", enabled);
    v("neighbours", neighbours, core::Limits<int>{1, 64});
    v("sigma_m", sigma_m, core::Limits<double>{1e-4, 10.0});
    v("radius_m", radius_m, core::Limits<double>{1e-3, 10.0});  // voxels of the radius: >= 1 mm (+-1 km)
  }
};

struct FilterResult {
  core::PointCloud cloud;
  std::size_t points = 0;              // == cloud.size()
  std::size_t non_finite_dropped = 0;
  std::size_t isolated = 0;            // points left in place: no neighbour within radius_m
  double mean_shift_m = 0.0;           // mean distance the points moved
};

class GaussianFilter {
 public:
  using Config = GaussianFilterConfig;

  // Throws InputError ("gaussian_filter.<key>: ...") for non-positive sigma, radius or neighbours.
  explicit GaussianFilter(const Config& config);

  // With enabled == false, returns the finite points unchanged.
  FilterResult filter(const core::PointCloud& cloud) const;

  const Config& config() const { return config_; }

 private:
  Config config_;
};

}  // namespace fleetslam::central
