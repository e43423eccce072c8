#include "fleetslam/central/filtering.hpp"

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "fleetslam/core/error.hpp"
#include "voxel_hash.hpp"

namespace fleetslam::central {
namespace {

// The finite points of a cloud (colours alongside when present); counts the others.
core::PointCloud finite_points(const core::PointCloud& cloud, std::size_t& dropped) {
  core::PointCloud finite = cloud;
  dropped = core::remove_non_finite(finite);
  return finite;
}

struct Candidate {
  Eigen::Vector3f point;
  std::uint32_t index;
};

struct Near {
  float distance_sq;
  std::uint32_t index;
  bool before(const Near& other) const {
    return distance_sq < other.distance_sq || (distance_sq == other.distance_sq && index < other.index);
  }
};

// Up to k nearest candidates within radius_sq (the point itself included), nearest first.
void nearest_candidates(const Eigen::Vector3f& query, const std::vector<Candidate>& candidates, std::size_t k,
                        float radius_sq, std::vector<Near>& best) {
  best.clear();
  float worst = radius_sq;
  for (const Candidate& c : candidates) {
    const float d = (c.point - query).squaredNorm();
    if (d > worst) continue;
    const Near near{d, c.index};
    if (best.size() == k) {
      if (!near.before(best.back())) continue;
      best.pop_back();
    }
    auto at = best.end();
    while (at != best.begin() && near.before(*(at - 1))) --at;
    best.insert(at, near);
    if (best.size() == k) worst = best.back().distance_sq;
  }
}

}  // namespace

GaussianFilter::GaussianFilter(const Config& config) : config_(config) {
  if (config_.neighbours < 1) throw InputError("gaussian_filter.neighbours", "must be at least 1");
  if (!(config_.sigma_m > 0.0) || !std::isfinite(config_.sigma_m)) {
    throw InputError("gaussian_filter.sigma_m", "must be positive, got " + std::to_string(config_.sigma_m));
  }
  if (!(config_.radius_m > 0.0) || !std::isfinite(config_.radius_m)) {
    throw InputError("gaussian_filter.radius_m", "must be positive, got " + std::to_string(config_.radius_m));
  }
}

FilterResult GaussianFilter::filter(const core::PointCloud& cloud) const {
  FilterResult result;
  result.cloud = finite_points(cloud, result.non_finite_dropped);
  result.points = result.cloud.size();
  if (!config_.enabled || result.cloud.empty()) return result;

  const std::vector<Eigen::Vector3f> points = result.cloud.points;  // filtered from these, written into result.cloud
  const auto radius = static_cast<float>(config_.radius_m);
  const float radius_sq = radius * radius;
  const auto inverse_two_sigma_sq = static_cast<float>(1.0 / (2.0 * config_.sigma_m * config_.sigma_m));
  const std::size_t k = static_cast<std::size_t>(config_.neighbours) + 1;  // the point itself is one of them

  // Voxels of radius_m: a point's neighbours within radius_m lie in the 27 voxels around its own.
  // Points are processed voxel by voxel so that the candidates are gathered once per voxel.
  const detail::VoxelGrid grid(points, radius);
  std::vector<Candidate> candidates;
  std::vector<Near> best;
  double shift_sum = 0.0;
  for (std::size_t cell = 0; cell < grid.cells(); ++cell) {
    candidates.clear();
    const Eigen::Vector3i& v = grid.coord(cell);
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          const long other = grid.find(v + Eigen::Vector3i(dx, dy, dz));
          if (other < 0) continue;
          for (const std::uint32_t* i = grid.cell_begin(static_cast<std::size_t>(other));
               i != grid.cell_end(static_cast<std::size_t>(other)); ++i) {
            candidates.push_back(Candidate{points[*i], *i});
          }
        }
      }
    }
    for (const std::uint32_t* q = grid.cell_begin(cell); q != grid.cell_end(cell); ++q) {
      const Eigen::Vector3f& x0 = points[*q];
      nearest_candidates(x0, candidates, k, radius_sq, best);
      if (best.size() <= 1) {
        ++result.isolated;
        continue;
      }
      Eigen::Vector3f weighted = Eigen::Vector3f::Zero();  // relative to x0 (better conditioned)
      float weight_sum = 0.0f;
      for (const Near& n : best) {
        const float w = std::exp(-n.distance_sq * inverse_two_sigma_sq);
        weighted += w * (points[n.index] - x0);
        weight_sum += w;
      }
      const Eigen::Vector3f shift = weighted / weight_sum;
      result.cloud.points[*q] = x0 + shift;
      shift_sum += static_cast<double>(shift.norm());
    }
  }
  result.mean_shift_m = shift_sum / static_cast<double>(points.size());
  return result;
}

}  // namespace fleetslam::central
