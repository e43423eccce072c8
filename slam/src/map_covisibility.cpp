// Covisibility graph, spanning tree, keyframe culling and map point statistics.

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "fleetslam/core/error.hpp"
#include "fleetslam/slam/map.hpp"
#include "fleetslam/slam/matcher.hpp"

namespace fleetslam::slam {

void Map::set_neighbours(Keyframe& kf) {
  kf.neighbours.assign(kf.connections.begin(), kf.connections.end());
  std::stable_sort(kf.neighbours.begin(), kf.neighbours.end(),
                   [](const auto& a, const auto& b) { return a.second > b.second; });
}

void Map::update_connections(KeyframeId kf_id, int min_weight) {
  Keyframe* kf = keyframe(kf_id);
  FLEETSLAM_CHECK(kf != nullptr, "update_connections: unknown keyframe " + std::to_string(kf_id));
  std::map<KeyframeId, int> counts;
  for (MapPointId id : kf->frame.map_points) {
    const MapPoint* p = id == kNoMapPoint ? nullptr : point(id);
    if (p == nullptr) continue;
    for (const auto& observation : p->observations) {
      if (observation.first != kf_id) ++counts[observation.first];
    }
  }
  // Drop the old mirrored links first: weights may have fallen below the threshold.
  for (const auto& entry : kf->connections) {
    if (Keyframe* other = keyframe(entry.first)) {
      other->connections.erase(kf_id);
      set_neighbours(*other);
    }
  }
  kf->connections.clear();
  if (counts.empty()) {
    set_neighbours(*kf);
    return;
  }
  // The strongest neighbour (ties: the older keyframe) stays linked even below the threshold.
  const auto best = std::max_element(counts.begin(), counts.end(),
                                     [](const auto& a, const auto& b) { return a.second < b.second; });
  for (const auto& [other_id, weight] : counts) {
    if (weight < min_weight && other_id != best->first) continue;
    Keyframe* other = keyframe(other_id);
    if (other == nullptr) continue;
    kf->connections[other_id] = weight;
    other->connections[kf_id] = weight;
    set_neighbours(*other);
  }
  set_neighbours(*kf);
  if (!kf->connected && !kf->root) {
    // The parent is older than its child, so the tree can never close a cycle.
    for (const auto& [neighbour, weight] : kf->neighbours) {
      if (neighbour >= kf_id) continue;
      kf->parent = neighbour;
      keyframe(neighbour)->children.insert(kf_id);
      break;
    }
  }
  kf->connected = kf->connected || kf->parent >= 0;
}

// Children of a culled keyframe move to the candidate (its parent, or an already re-parented sibling)
// they share most points with, repeatedly, so the tree stays a tree; the rest go to the parent.
void Map::adopt_children(Keyframe& culled) {
  std::set<KeyframeId> candidates{culled.parent};
  std::set<KeyframeId> orphans = culled.children;
  while (!orphans.empty()) {
    KeyframeId best_child = -1, best_parent = -1;
    int best_weight = -1;
    for (KeyframeId child : orphans) {
      const Keyframe* c = keyframe(child);
      if (c == nullptr) continue;
      for (const auto& [neighbour, weight] : c->neighbours) {
        if (candidates.count(neighbour) > 0 && weight > best_weight) {
          best_child = child, best_parent = neighbour, best_weight = weight;
        }
      }
    }
    if (best_child < 0) break;
    Keyframe* child = keyframe(best_child);
    child->parent = best_parent;
    keyframe(best_parent)->children.insert(best_child);
    candidates.insert(best_child);
    orphans.erase(best_child);
  }
  for (KeyframeId orphan : orphans) {
    if (Keyframe* child = keyframe(orphan)) {
      child->parent = culled.parent;
      keyframe(culled.parent)->children.insert(orphan);
    }
  }
}

bool Map::add_loop_edge(KeyframeId a, KeyframeId b) {
  Keyframe* ka = keyframe(a);
  Keyframe* kb = keyframe(b);
  if (ka == nullptr || kb == nullptr || a == b) return false;
  ka->loop_edges.insert(b);
  kb->loop_edges.insert(a);
  return true;
}

bool Map::erase_keyframe(KeyframeId kf_id) {
  Keyframe* kf = keyframe(kf_id);
  if (kf == nullptr || kf->root || kf->parent < 0 || keyframe(kf->parent) == nullptr || !kf->loop_edges.empty()) {
    return false;
  }
  for (std::size_t i = 0; i < kf->frame.size(); ++i) {
    const MapPointId id = kf->frame.map_points[i];
    if (id != kNoMapPoint) erase_observation(id, kf_id);
  }
  for (const auto& entry : kf->connections) {
    if (Keyframe* other = keyframe(entry.first)) {
      other->connections.erase(kf_id);
      set_neighbours(*other);
    }
  }
  Keyframe* parent = keyframe(kf->parent);
  parent->children.erase(kf_id);
  adopt_children(*kf);
  culled_[kf_id] = CulledKeyframe{kf->parent, parent->T_cam_world() * kf->T_world_cam};
  keyframes_.erase(kf_id);
  return true;
}

namespace {

// Median (lower middle) Hamming distance from descriptor i to all others; 0 when it is alone.
int median_distance_to_others(const std::vector<Descriptor>& descriptors, std::size_t i) {
  std::vector<int> distances;
  for (std::size_t j = 0; j < descriptors.size(); ++j) {
    if (j != i) distances.push_back(hamming_distance(descriptors[i].data(), descriptors[j].data()));
  }
  if (distances.empty()) return 0;
  std::sort(distances.begin(), distances.end());
  return distances[(distances.size() - 1) / 2];
}

}  // namespace

void Map::update_point_statistics(MapPointId point_id) {
  MapPoint* p = point(point_id);
  if (p == nullptr || p->observations.empty()) return;
  // Descriptor: the observation with the least median Hamming distance to the others (ORB-SLAM).
  std::vector<Descriptor> descriptors;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  for (const auto& [kf_id, feature] : p->observations) {
    const Keyframe* kf = keyframe(kf_id);
    if (kf == nullptr) continue;
    descriptors.push_back(descriptor_row(kf->frame.descriptors, feature));
    normal += (p->position - kf->center()).normalized();
  }
  if (descriptors.empty()) return;
  const std::size_t n = descriptors.size();
  std::size_t best = 0;
  int best_median = std::numeric_limits<int>::max();
  for (std::size_t i = 0; i < n; ++i) {
    const int median = median_distance_to_others(descriptors, i);
    if (median < best_median) best_median = median, best = i;
  }
  p->descriptor = descriptors[best];
  if (normal.norm() > 0.0) p->normal = normal.normalized();

  // Distance range from the reference keyframe: the level it was seen at fixes the scale.
  if (p->observations.count(p->reference_keyframe) == 0) p->reference_keyframe = p->observations.begin()->first;
  const Keyframe* ref = keyframe(p->reference_keyframe);
  if (ref == nullptr) return;
  const int level = ref->frame.level[static_cast<std::size_t>(p->observations.at(p->reference_keyframe))];
  const ScalePyramid& pyramid = ref->frame.pyramid;
  const double distance = (p->position - ref->center()).norm();
  const bool has_scales = static_cast<std::size_t>(level) < pyramid.scale.size();
  p->max_distance_m = distance * (has_scales ? pyramid.scale[static_cast<std::size_t>(level)] : 1.0);
  p->min_distance_m = p->max_distance_m / (has_scales ? pyramid.scale.back() : 1.0);
}

}  // namespace fleetslam::slam
