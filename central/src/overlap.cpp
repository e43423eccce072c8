#include "fleetslam/central/overlap.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "fleetslam/central/kdtree.hpp"
#include "fleetslam/core/error.hpp"
#include "normal_test.hpp"
#include "voxel_hash.hpp"

namespace fleetslam::central {
namespace {

// Voxels holding a finite point of the cloud.
detail::VoxelMap occupied_voxels(const core::PointCloud& cloud, float inverse_size) {
  detail::VoxelMap voxels(1024);
  for (const Eigen::Vector3f& p : cloud.points) {
    if (p.allFinite()) voxels.insert(detail::pack_voxel(detail::voxel_of(p, inverse_size)), 0);
  }
  return voxels;
}

// Finite points of `cloud` (ascending indices) in a voxel next to one of `other_voxels`: with voxels
// slightly larger than the radius, every point within the radius of the other cloud is among them.
// Voxels are large, so both maps stay small and cache-resident; each voxel's verdict is memoised.
std::vector<std::uint32_t> points_near(const core::PointCloud& cloud, const detail::VoxelMap& other_voxels,
                                       float inverse_size) {
  detail::VoxelMap verdicts(1024);  // voxel -> 1 near, 0 not
  std::vector<std::uint32_t> near;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f& p = cloud.points[i];
    if (!p.allFinite()) continue;
    const Eigen::Vector3i v = detail::voxel_of(p, inverse_size);
    const std::uint64_t key = detail::pack_voxel(v);
    const std::uint32_t* known = verdicts.find(key);
    std::uint32_t is_near = known ? *known : 0;
    if (!known) {
      for (int dx = -1; dx <= 1 && !is_near; ++dx) {
        for (int dy = -1; dy <= 1 && !is_near; ++dy) {
          for (int dz = -1; dz <= 1 && !is_near; ++dz) {
            is_near = other_voxels.find(detail::pack_voxel(v + Eigen::Vector3i(dx, dy, dz))) != nullptr ? 1 : 0;
          }
        }
      }
      verdicts.insert(key, is_near);
    }
    if (is_near) near.push_back(static_cast<std::uint32_t>(i));
  }
  return near;
}

constexpr float kQueryVoxelsPerMetre = 10.0f;  // 10 cm voxels order the queries

// The indices reordered voxel by voxel (fine voxels): spatially coherent kd-tree queries hit the cache.
std::vector<std::uint32_t> in_voxel_order(const core::PointCloud& cloud, const std::vector<std::uint32_t>& indices,
                                          float inverse_size) {
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(indices.size());
  for (std::size_t i = 0; i < indices.size(); ++i) {
    keyed[i] = {detail::pack_voxel(detail::voxel_of(cloud.points[indices[i]], inverse_size)), indices[i]};
  }
  std::sort(keyed.begin(), keyed.end());
  std::vector<std::uint32_t> ordered(indices.size());
  for (std::size_t i = 0; i < keyed.size(); ++i) ordered[i] = keyed[i].second;
  return ordered;
}

std::vector<Eigen::Vector3f> gather(const core::PointCloud& cloud, const std::vector<std::uint32_t>& indices) {
  std::vector<Eigen::Vector3f> points;
  points.reserve(indices.size());
  for (std::uint32_t i : indices) points.push_back(cloud.points[i]);
  return points;
}

}  // namespace

OverlapFinder::OverlapFinder(const Config& config) : config_(config) {
  if (!(config_.coarse_radius_m > 0.0) || !std::isfinite(config_.coarse_radius_m)) {
    throw InputError("overlap.coarse_radius_m", "must be positive, got " + std::to_string(config_.coarse_radius_m));
  }
  if (!(config_.max_normal_angle_deg >= 0.0 && config_.max_normal_angle_deg <= 180.0)) {
    throw InputError("overlap.max_normal_angle_deg", "must be in [0, 180], got " + std::to_string(config_.max_normal_angle_deg));
  }
}

Overlap OverlapFinder::find(const core::PointCloud& a_world, const core::PointCloud& b_world) const {
  FLEETSLAM_CHECK(a_world.size() < Neighbour::kNone && b_world.size() < Neighbour::kNone,
                  "too many points for 32-bit indices");
  Overlap overlap;
  if (a_world.empty() || b_world.empty()) return overlap;
  const auto radius = static_cast<float>(config_.coarse_radius_m);
  const float voxel_size = radius * 1.01f;  // margin for the rounding of floor(p / size)

  // Only these can pair at all (ascending indices: the trees then break ties by the smaller cloud index,
  // as documented).
  const float inverse_size = 1.0f / voxel_size;
  const std::vector<std::uint32_t> a_near = points_near(a_world, occupied_voxels(b_world, inverse_size), inverse_size);
  const std::vector<std::uint32_t> b_near = points_near(b_world, occupied_voxels(a_world, inverse_size), inverse_size);
  if (a_near.empty() || b_near.empty()) return overlap;

  // Nearest point of A for each candidate of B.
  const KdTree tree_a(gather(a_world, a_near));
  std::vector<std::uint32_t> nearest_a(b_world.size(), Neighbour::kNone);
  std::vector<std::uint32_t> b_hit;
  for (std::uint32_t b : in_voxel_order(b_world, b_near, kQueryVoxelsPerMetre)) {
    const Neighbour n = tree_a.nearest(b_world.points[b], radius);
    if (!n.found()) continue;
    nearest_a[b] = a_near[n.index];
    b_hit.push_back(b);
  }
  if (b_hit.empty()) return overlap;

  // Nearest point of B for each A point that some B point chose. Any B point nearer to such an a than
  // its chooser is within the radius of a, so it has a nearest point in A too: the tree over b_hit
  // answers exactly.
  std::vector<std::uint32_t> chosen;
  {
    std::vector<char> is_chosen(a_world.size(), 0);
    for (std::uint32_t b : b_hit) is_chosen[nearest_a[b]] = 1;
    for (std::size_t a = 0; a < a_world.size(); ++a) {
      if (is_chosen[a]) chosen.push_back(static_cast<std::uint32_t>(a));
    }
  }
  std::sort(b_hit.begin(), b_hit.end());
  const KdTree tree_b(gather(b_world, b_hit));
  std::vector<Neighbour> partner(a_world.size());  // mutual partner in B (index into b_world), if any
  for (std::uint32_t a : in_voxel_order(a_world, chosen, kQueryVoxelsPerMetre)) {
    const Neighbour n = tree_b.nearest(a_world.points[a], radius);
    if (!n.found()) continue;
    const std::uint32_t b = b_hit[n.index];
    if (nearest_a[b] == a) partner[a] = Neighbour{b, n.distance_sq_m2};
  }
  const bool use_normals = a_world.has_normals() && b_world.has_normals() && config_.max_normal_angle_deg < 180.0;
  const float min_cos = detail::min_normal_cos(config_.max_normal_angle_deg);
  double distance_sum = 0.0;
  for (std::uint32_t a : chosen) {
    if (!partner[a].found()) continue;
    if (use_normals) {
      if (!detail::normals_agree(a_world.normals[a], b_world.normals[partner[a].index], min_cos)) {
        ++overlap.normal_rejected;
        continue;
      }
    }
    overlap.indices_a.push_back(a);
    overlap.indices_b.push_back(partner[a].index);
    distance_sum += std::sqrt(static_cast<double>(partner[a].distance_sq_m2));
  }
  if (!overlap.empty()) overlap.mean_distance_m = distance_sum / static_cast<double>(overlap.size());
  return overlap;
}

OverlapRegions overlap_regions(const core::PointCloud& a_world, const core::PointCloud& b_world, double radius_m) {
  if (!(radius_m > 0.0) || !std::isfinite(radius_m)) {
    throw InputError("overlap_regions.radius_m", "must be positive, got " + std::to_string(radius_m));
  }
  OverlapRegions regions;
  if (a_world.empty() || b_world.empty()) return regions;
  const float inverse_size = 1.0f / (static_cast<float>(radius_m) * 1.01f);
  regions.indices_a = points_near(a_world, occupied_voxels(b_world, inverse_size), inverse_size);
  regions.indices_b = points_near(b_world, occupied_voxels(a_world, inverse_size), inverse_size);
  return regions;
}

core::PointCloud select_points(const core::PointCloud& cloud, const std::vector<std::uint32_t>& indices) {
  core::PointCloud out;
  out.reserve(indices.size(), cloud.has_colors());
  for (std::uint32_t i : indices) {
    FLEETSLAM_CHECK(i < cloud.size(), "select_points: index out of range");
    out.push_back_from(cloud, i);
  }
  return out;
}

}  // namespace fleetslam::central
