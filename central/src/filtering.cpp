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

// The points of a voxel's neighbourhood, coordinates in separate arrays so that the distance loop
// vectorises.
struct Candidates {
  std::vector<float> x, y, z;
  std::vector<std::uint32_t> index;
  std::vector<float> distance_sq;      // scratch, per query
  std::vector<std::uint32_t> within;   // scratch, per query

  void clear() {
    x.clear();
    y.clear();
    z.clear();
    index.clear();
  }
  void push_back(const Eigen::Vector3f& p, std::uint32_t i) {
    x.push_back(p.x());
    y.push_back(p.y());
    z.push_back(p.z());
    index.push_back(i);
  }
};

struct Near {
  float distance_sq;
  std::uint32_t index;
  Eigen::Vector3f point;
  bool before(const Near& other) const {
    return distance_sq < other.distance_sq || (distance_sq == other.distance_sq && index < other.index);
  }
};

// Up to k nearest candidates within radius_sq (the point itself included), nearest first.
void nearest_candidates(const Eigen::Vector3f& query, Candidates& candidates, std::size_t k, float radius_sq,
                        std::vector<Near>& best) {
  const std::size_t n = candidates.index.size();
  candidates.distance_sq.resize(n);
  const float qx = query.x(), qy = query.y(), qz = query.z();
  const float* x = candidates.x.data();
  const float* y = candidates.y.data();
  const float* z = candidates.z.data();
  float* d = candidates.distance_sq.data();
  for (std::size_t j = 0; j < n; ++j) {
    const float dx = x[j] - qx, dy = y[j] - qy, dz = z[j] - qz;
    d[j] = dx * dx + dy * dy + dz * dz;
  }
  // Those within the radius, compacted without branches (most candidates are outside), then the k
  // nearest of those by insertion.
  candidates.within.resize(n);
  std::uint32_t* within = candidates.within.data();
  std::size_t m = 0;
  for (std::size_t j = 0; j < n; ++j) {
    within[m] = static_cast<std::uint32_t>(j);
    m += d[j] <= radius_sq ? 1 : 0;
  }
  best.clear();
  for (std::size_t w = 0; w < m; ++w) {
    const std::uint32_t j = within[w];
    const Near near{d[j], candidates.index[j], Eigen::Vector3f(x[j], y[j], z[j])};
    if (best.size() == k) {
      if (!near.before(best.back())) continue;
      best.pop_back();
    }
    auto at = best.end();
    while (at != best.begin() && near.before(*(at - 1))) --at;
    best.insert(at, near);
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
  detail::NeighbourSweep sweep(grid);
  std::vector<std::uint32_t> neighbour_cells;
  Candidates candidates;
  std::vector<Near> best;
  double shift_sum = 0.0;
  for (std::size_t cell = 0; cell < grid.cells(); ++cell) {
    candidates.clear();
    sweep.neighbours(cell, neighbour_cells);
    for (const std::uint32_t other : neighbour_cells) {
      const std::uint32_t* index = grid.cell_begin(other);
      const Eigen::Vector3f* position = grid.cell_points(other);
      for (std::size_t j = 0; j < grid.cell_size(other); ++j) candidates.push_back(position[j], index[j]);
    }
    const Eigen::Vector3f* cell_points = grid.cell_points(cell);
    for (const std::uint32_t* q = grid.cell_begin(cell); q != grid.cell_end(cell); ++q, ++cell_points) {
      const Eigen::Vector3f& x0 = *cell_points;
      nearest_candidates(x0, candidates, k, radius_sq, best);
      if (best.size() <= 1) {
        ++result.isolated;
        continue;
      }
      Eigen::Vector3f weighted = Eigen::Vector3f::Zero();  // relative to x0 (better conditioned)
      float weight_sum = 0.0f;
      for (const Near& n : best) {
        const float w = std::exp(-n.distance_sq * inverse_two_sigma_sq);
        weighted += w * (n.point - x0);
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
