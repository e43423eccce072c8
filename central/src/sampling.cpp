#include "fleetslam/central/sampling.hpp"

#include <cmath>
#include <string>

#include "fleetslam/core/error.hpp"
#include "voxel_hash.hpp"

namespace fleetslam::central {
namespace {

// The output cloud of the points marked kept, in input order.
SamplingResult gather(const core::PointCloud& cloud, const std::vector<char>& keep) {
  SamplingResult result;
  result.points_before = cloud.size();
  const bool colored = cloud.has_colors();
  std::size_t count = 0;
  for (char k : keep) count += k ? 1 : 0;
  result.cloud.reserve(count, colored);
  if (cloud.has_normals()) result.cloud.normals.reserve(count);
  result.kept.reserve(count);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!keep[i]) continue;
    result.kept.push_back(static_cast<std::uint32_t>(i));
    result.cloud.push_back_from(cloud, i);
  }
  result.points_after = result.cloud.size();
  return result;
}

}  // namespace

UniformSampler::UniformSampler(const Config& config) : config_(config) {
  if (!(config_.voxel_size_m > 0.0) || !std::isfinite(config_.voxel_size_m)) {
    throw InputError("uniform_sampling.voxel_size_m", "must be positive, got " + std::to_string(config_.voxel_size_m));
  }
}

SamplingResult UniformSampler::sample(const core::PointCloud& cloud) const {
  FLEETSLAM_CHECK(cloud.points.size() < 0xffffffffu, "too many points for 32-bit indices");
  std::vector<char> keep(cloud.size(), 0);
  std::size_t non_finite = 0;
  if (!config_.enabled) {
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      keep[i] = cloud.points[i].allFinite() ? 1 : 0;
      non_finite += keep[i] ? 0 : 1;
    }
    SamplingResult result = gather(cloud, keep);
    result.non_finite_dropped = non_finite;
    return result;
  }
  const auto size = static_cast<float>(config_.voxel_size_m);
  const float inverse_size = 1.0f / size;
  // Voxel -> index of the point nearest the voxel centre so far (ties: the first, i.e. smaller index).
  detail::VoxelMap best(cloud.size() / 2 + 1);
  std::vector<float> best_distance_sq;
  std::vector<std::uint32_t> best_index;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f& p = cloud.points[i];
    if (!p.allFinite()) {
      ++non_finite;
      continue;
    }
    const Eigen::Vector3i voxel = detail::voxel_of(p, inverse_size);
    const Eigen::Vector3f centre = (voxel.cast<float>() + Eigen::Vector3f::Constant(0.5f)) * size;
    const float d = (p - centre).squaredNorm();
    const auto [slot, inserted] = best.insert(detail::pack_voxel(voxel), static_cast<std::uint32_t>(best_index.size()));
    if (inserted) {
      best_distance_sq.push_back(d);
      best_index.push_back(static_cast<std::uint32_t>(i));
    } else if (d < best_distance_sq[*slot]) {
      best_distance_sq[*slot] = d;
      best_index[*slot] = static_cast<std::uint32_t>(i);
    }
  }
  for (std::uint32_t i : best_index) keep[i] = 1;
  SamplingResult result = gather(cloud, keep);
  result.non_finite_dropped = non_finite;
  return result;
}

}  // namespace fleetslam::central
