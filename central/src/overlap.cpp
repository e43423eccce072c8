#include "fleetslam/central/overlap.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "fleetslam/central/kdtree.hpp"
#include "fleetslam/core/error.hpp"
#include "voxel_hash.hpp"

namespace fleetslam::central {
namespace {

// Finite points of `cloud` within `radius` of some finite point of `other`, as a voxel test: voxels
// slightly larger than the radius, so any such pair lies in neighbouring voxels. The indices come out
// voxel by voxel (spatially coherent queries later).
std::vector<std::uint32_t> points_near(const core::PointCloud& cloud, const core::PointCloud& other, float voxel_size) {
  const detail::VoxelGrid grid(cloud.points, voxel_size);
  const float inverse_size = 1.0f / voxel_size;
  detail::VoxelMap other_voxels(other.size() / 8 + 1);
  for (const Eigen::Vector3f& p : other.points) {
    if (p.allFinite()) other_voxels.insert(detail::pack_voxel(detail::voxel_of(p, inverse_size)), 0);
  }
  std::vector<std::uint32_t> near;
  for (std::size_t cell = 0; cell < grid.cells(); ++cell) {
    const Eigen::Vector3i& v = grid.coord(cell);
    bool any = false;
    for (int dx = -1; dx <= 1 && !any; ++dx) {
      for (int dy = -1; dy <= 1 && !any; ++dy) {
        for (int dz = -1; dz <= 1 && !any; ++dz) {
          any = other_voxels.find(detail::pack_voxel(v + Eigen::Vector3i(dx, dy, dz))) != nullptr;
        }
      }
    }
    if (!any) continue;
    for (const std::uint32_t* i = grid.cell_begin(cell); i != grid.cell_end(cell); ++i) {
      if (cloud.points[*i].allFinite()) near.push_back(*i);
    }
  }
  return near;
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
}

Overlap OverlapFinder::find(const core::PointCloud& a_world, const core::PointCloud& b_world) const {
  FLEETSLAM_CHECK(a_world.size() < Neighbour::kNone && b_world.size() < Neighbour::kNone,
                  "too many points for 32-bit indices");
  Overlap overlap;
  if (a_world.empty() || b_world.empty()) return overlap;
  const auto radius = static_cast<float>(config_.coarse_radius_m);
  const float voxel_size = radius * 1.01f;  // margin for the rounding of floor(p / size)

  // Only these can pair at all. The trees hold points in ascending index order, so that their
  // tie-breaking (smaller tree index) is the documented one (smaller cloud index).
  std::vector<std::uint32_t> a_near = points_near(a_world, b_world, voxel_size);
  const std::vector<std::uint32_t> b_near = points_near(b_world, a_world, voxel_size);
  if (a_near.empty() || b_near.empty()) return overlap;
  std::sort(a_near.begin(), a_near.end());

  // Nearest point of A for each candidate of B.
  const KdTree tree_a(gather(a_world, a_near));
  std::vector<std::uint32_t> nearest_a(b_world.size(), Neighbour::kNone);
  std::vector<std::uint32_t> b_hit;
  for (std::uint32_t b : b_near) {
    const Neighbour n = tree_a.nearest(b_world.points[b], radius);
    if (!n.found()) continue;
    nearest_a[b] = a_near[n.index];
    b_hit.push_back(b);
  }
  if (b_hit.empty()) return overlap;

  // Nearest point of B for each A point that some B point chose. Any B point nearer to such an a than
  // its chooser is within the radius of a, so it has a nearest point in A too: the tree over b_hit
  // answers exactly.
  std::vector<char> chosen(a_world.size(), 0);
  for (std::uint32_t b : b_hit) chosen[nearest_a[b]] = 1;
  std::sort(b_hit.begin(), b_hit.end());
  const KdTree tree_b(gather(b_world, b_hit));
  double distance_sum = 0.0;
  for (std::size_t a = 0; a < a_world.size(); ++a) {
    if (!chosen[a]) continue;
    const Neighbour n = tree_b.nearest(a_world.points[a], radius);
    if (!n.found()) continue;
    const std::uint32_t b = b_hit[n.index];
    if (nearest_a[b] != a) continue;  // not mutual
    overlap.indices_a.push_back(static_cast<std::uint32_t>(a));
    overlap.indices_b.push_back(b);
    distance_sum += std::sqrt(static_cast<double>(n.distance_sq_m2));
  }
  if (!overlap.empty()) overlap.mean_distance_m = distance_sum / static_cast<double>(overlap.size());
  return overlap;
}

core::PointCloud select_points(const core::PointCloud& cloud, const std::vector<std::uint32_t>& indices) {
  core::PointCloud out;
  const bool colored = cloud.has_colors();
  out.reserve(indices.size(), colored);
  for (std::uint32_t i : indices) {
    FLEETSLAM_CHECK(i < cloud.size(), "select_points: index out of range");
    if (colored) {
      out.push_back(cloud.points[i], cloud.colors[i]);
    } else {
      out.push_back(cloud.points[i]);
    }
  }
  return out;
}

}  // namespace fleetslam::central
