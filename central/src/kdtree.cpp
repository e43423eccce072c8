#include "fleetslam/central/kdtree.hpp"

#include <algorithm>

#include "fleetslam/core/error.hpp"

namespace fleetslam::central {
namespace {

struct Entry {
  Eigen::Vector3f point;
  std::uint32_t index;
};

// Strict order of candidates: by distance, then by index (makes answers unique).
bool closer(float distance_sq, std::uint32_t index, const Neighbour& other) {
  return distance_sq < other.distance_sq_m2 || (distance_sq == other.distance_sq_m2 && index < other.index);
}

}  // namespace

KdTree::KdTree(const std::vector<Eigen::Vector3f>& points, const Config& config) : config_(config) {
  if (config_.leaf_size < 1) throw InputError("kdtree.leaf_size", "must be at least 1");
  FLEETSLAM_CHECK(points.size() < Neighbour::kNone, "too many points for 32-bit indices");
  std::vector<Entry> entries(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) entries[i] = Entry{points[i], static_cast<std::uint32_t>(i)};
  // Build on the entries (contiguous, cache friendly), then split them into positions and indices.
  points_.resize(points.size());
  indices_.resize(points.size());
  nodes_.reserve(2 * points.size() / static_cast<std::size_t>(config_.leaf_size) + 1);
  if (!entries.empty()) {
    struct Range {
      std::size_t begin, end;
    };
    // Iterative pre-order build: the left child always directly follows its parent.
    std::vector<std::pair<Range, std::uint32_t>> stack;  // range, parent waiting for its right child (or kNone)
    stack.push_back({{0, entries.size()}, Neighbour::kNone});
    while (!stack.empty()) {
      const auto [range, parent] = stack.back();
      stack.pop_back();
      const auto id = static_cast<std::uint32_t>(nodes_.size());
      if (parent != Neighbour::kNone) nodes_[parent].right = id;
      Node node;
      node.begin = static_cast<std::uint32_t>(range.begin);
      node.end = static_cast<std::uint32_t>(range.end);
      if (range.end - range.begin <= static_cast<std::size_t>(config_.leaf_size)) {
        nodes_.push_back(node);
        continue;
      }
      Eigen::Vector3f lo = entries[range.begin].point;
      Eigen::Vector3f hi = lo;
      for (std::size_t i = range.begin + 1; i < range.end; ++i) {
        lo = lo.cwiseMin(entries[i].point);
        hi = hi.cwiseMax(entries[i].point);
      }
      int axis = 0;
      (hi - lo).maxCoeff(&axis);
      const std::size_t mid = range.begin + (range.end - range.begin) / 2;
      const auto first = entries.begin() + static_cast<std::ptrdiff_t>(range.begin);
      std::nth_element(first, entries.begin() + static_cast<std::ptrdiff_t>(mid),
                       entries.begin() + static_cast<std::ptrdiff_t>(range.end),
                       [axis](const Entry& a, const Entry& b) { return a.point[axis] < b.point[axis]; });
      node.axis = axis;
      node.split = entries[mid].point[axis];  // left: <= split, right: >= split
      nodes_.push_back(node);
      stack.push_back({{mid, range.end}, id});                 // right, linked when popped
      stack.push_back({{range.begin, mid}, Neighbour::kNone});  // left, next node
    }
  }
  for (std::size_t i = 0; i < entries.size(); ++i) {
    points_[i] = entries[i].point;
    indices_[i] = entries[i].index;
    lo_ = i == 0 ? points_[i] : lo_.cwiseMin(points_[i]);
    hi_ = i == 0 ? points_[i] : hi_.cwiseMax(points_[i]);
  }
}

// Searches descend to the query's side first; the other side is visited only when the box it covers can
// hold a point within the current bound. The distance to that box is tracked per axis (offsets), as in
// nanoflann: it prunes far better in 3D than the distance to the last split plane alone.
float KdTree::box_distance_sq(const Eigen::Vector3f& query, Eigen::Vector3f& offsets) const {
  offsets = (lo_ - query).cwiseMax(query - hi_).cwiseMax(0.0f);
  return offsets.squaredNorm();
}

Neighbour KdTree::nearest(const Eigen::Vector3f& query, float max_distance_m) const {
  if (nodes_.empty() || !(max_distance_m >= 0.0f)) return Neighbour{};
  Neighbour best;
  best.distance_sq_m2 = max_distance_m * max_distance_m;
  best.index = Neighbour::kNone;
  Eigen::Vector3f offsets;
  const float box = box_distance_sq(query, offsets);
  if (box > best.distance_sq_m2) return Neighbour{};
  nearest_in(0, query, best, box, offsets);
  if (!best.found()) return Neighbour{};
  return best;
}

void KdTree::nearest_in(std::uint32_t id, const Eigen::Vector3f& query, Neighbour& best, float box_sq,
                        Eigen::Vector3f& offsets) const {
  const Node& node = nodes_[id];
  if (node.axis < 0) {
    for (std::uint32_t i = node.begin; i < node.end; ++i) {
      const float d = (points_[i] - query).squaredNorm();
      // Within the bound (inclusive) and closer than the best so far.
      if (d <= best.distance_sq_m2 && (!best.found() || closer(d, indices_[i], best))) best = Neighbour{indices_[i], d};
    }
    return;
  }
  const float diff = query[node.axis] - node.split;
  const std::uint32_t near_child = diff <= 0.0f ? id + 1 : node.right;
  const std::uint32_t far_child = diff <= 0.0f ? node.right : id + 1;
  nearest_in(near_child, query, best, box_sq, offsets);
  const float saved = offsets[node.axis];
  const float far_box_sq = box_sq - saved * saved + diff * diff;
  if (far_box_sq <= best.distance_sq_m2) {
    offsets[node.axis] = diff;
    nearest_in(far_child, query, best, far_box_sq, offsets);
    offsets[node.axis] = saved;
  }
}

void KdTree::knn(const Eigen::Vector3f& query, std::size_t k, float max_distance_m, std::vector<Neighbour>& out) const {
  out.clear();
  if (nodes_.empty() || k == 0 || !(max_distance_m >= 0.0f)) return;
  float worst_sq = max_distance_m * max_distance_m;
  Eigen::Vector3f offsets;
  const float box = box_distance_sq(query, offsets);
  if (box > worst_sq) return;
  knn_in(0, query, k, worst_sq, box, offsets, out);
}

void KdTree::knn_in(std::uint32_t id, const Eigen::Vector3f& query, std::size_t k, float& worst_sq, float box_sq,
                    Eigen::Vector3f& offsets, std::vector<Neighbour>& out) const {
  const Node& node = nodes_[id];
  if (node.axis < 0) {
    for (std::uint32_t i = node.begin; i < node.end; ++i) {
      const float d = (points_[i] - query).squaredNorm();
      if (d > worst_sq) continue;
      const std::uint32_t index = indices_[i];
      if (out.size() == k && !closer(d, index, out.back())) continue;
      if (out.size() == k) out.pop_back();
      auto at = out.end();
      while (at != out.begin() && closer(d, index, *(at - 1))) --at;
      out.insert(at, Neighbour{index, d});
      if (out.size() == k) worst_sq = out.back().distance_sq_m2;
    }
    return;
  }
  const float diff = query[node.axis] - node.split;
  const std::uint32_t near_child = diff <= 0.0f ? id + 1 : node.right;
  const std::uint32_t far_child = diff <= 0.0f ? node.right : id + 1;
  knn_in(near_child, query, k, worst_sq, box_sq, offsets, out);
  const float saved = offsets[node.axis];
  const float far_box_sq = box_sq - saved * saved + diff * diff;
  if (far_box_sq <= worst_sq) {
    offsets[node.axis] = diff;
    knn_in(far_child, query, k, worst_sq, far_box_sq, offsets, out);
    offsets[node.axis] = saved;
  }
}

void KdTree::radius(const Eigen::Vector3f& query, float radius_m, std::vector<Neighbour>& out) const {
  out.clear();
  if (nodes_.empty() || !(radius_m >= 0.0f)) return;
  radius_in(0, query, radius_m * radius_m, out);
}

void KdTree::radius_in(std::uint32_t id, const Eigen::Vector3f& query, float radius_sq,
                       std::vector<Neighbour>& out) const {
  const Node& node = nodes_[id];
  if (node.axis < 0) {
    for (std::uint32_t i = node.begin; i < node.end; ++i) {
      const float d = (points_[i] - query).squaredNorm();
      if (d <= radius_sq) out.push_back(Neighbour{indices_[i], d});
    }
    return;
  }
  const float diff = query[node.axis] - node.split;
  if (diff <= 0.0f || diff * diff <= radius_sq) radius_in(id + 1, query, radius_sq, out);
  if (diff >= 0.0f || diff * diff <= radius_sq) radius_in(node.right, query, radius_sq, out);
}

}  // namespace fleetslam::central
