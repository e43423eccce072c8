#pragma once
// Uniform sampling (PAPER.md section 4, PCL's UniformSampling semantics): a voxel grid of voxel_size_m
// anchored at the origin (voxel index floor(p * (1 / voxel_size_m)) per axis, centre (index + 0.5) * size,
// computed in float); each occupied voxel keeps the one point nearest its centre (equal distances: the
// smaller index). Kept points keep their colours and their order in the input. Non-finite points are
// dropped and counted.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/point_cloud.hpp"

namespace fleetslam::central {

struct UniformSamplingConfig {
  bool enabled = true;
  double voxel_size_m = 0.02;  // the agents' dense maps are de-duplicated at 2 cm (slam dense_mapping)

  template <class V>
  void visit(V& v) {
    v("enabled", enabled);
    v("voxel_size_m", voxel_size_m, core::Limits<double>{1e-3, 100.0});
  }
};

struct SamplingResult {
  core::PointCloud cloud;
  std::vector<std::uint32_t> kept;  // input index of each output point (ascending)
  std::size_t points_before = 0;    // input points
  std::size_t points_after = 0;     // == cloud.size()
  std::size_t non_finite_dropped = 0;
};

class UniformSampler {
 public:
  using Config = UniformSamplingConfig;

  // Throws InputError ("uniform_sampling.voxel_size_m: ...") for a voxel size that is not positive.
  explicit UniformSampler(const Config& config);

  // With enabled == false, returns the finite points unchanged.
  SamplingResult sample(const core::PointCloud& cloud) const;

  const Config& config() const { return config_; }

 private:
  Config config_;
};

}  // namespace fleetslam::central
