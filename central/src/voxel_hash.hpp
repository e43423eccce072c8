#pragma once
// Internal: voxel keys, a flat hash map from voxel key to a 32-bit value, and a voxel grid that groups
// a cloud's points by voxel (points of one voxel contiguous, in index order) for grouped neighbour
// queries. Voxels are anchored at the origin: voxel (i, j, k) spans [i, i+1) * size on x, and so on.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace fleetslam::central::detail {

// Voxel coordinates are clamped to +-2^20 - 1 (+-10 km at 1 cm voxels): farther points share the border
// voxels rather than overflow.
constexpr int kMaxVoxelCoordinate = (1 << 20) - 1;

inline Eigen::Vector3i voxel_of(const Eigen::Vector3f& p, float inverse_size) {
  Eigen::Vector3i v;
  for (int axis = 0; axis < 3; ++axis) {
    float scaled = std::floor(p[axis] * inverse_size);
    if (std::isnan(scaled)) scaled = 0.0f;  // callers drop non-finite points; this only avoids UB
    v[axis] = static_cast<int>(std::clamp(scaled, -static_cast<float>(kMaxVoxelCoordinate),
                                          static_cast<float>(kMaxVoxelCoordinate)));
  }
  return v;
}

// 21 bits per axis in the low 63 bits; never equals kEmptyKey.
inline std::uint64_t pack_voxel(const Eigen::Vector3i& v) {
  const auto field = [](int c) { return static_cast<std::uint64_t>(c + (1 << 20)) & 0x1fffffu; };
  return (field(v.x()) << 42) | (field(v.y()) << 21) | field(v.z());
}

constexpr std::uint64_t kEmptyKey = ~std::uint64_t{0};

// Open addressing (linear probing, load <= 0.5) from voxel key to a 32-bit value.
class VoxelMap {
 public:
  explicit VoxelMap(std::size_t expected_keys) {
    std::size_t capacity = 64;
    while (capacity < 2 * expected_keys) capacity *= 2;
    slots_.assign(capacity, Slot{kEmptyKey, 0});
    mask_ = capacity - 1;
  }

  // The value of key, or nullptr.
  const std::uint32_t* find(std::uint64_t key) const {
    for (std::size_t h = hash(key);; h = (h + 1) & mask_) {
      const Slot& slot = slots_[h];
      if (slot.key == key) return &slot.value;
      if (slot.key == kEmptyKey) return nullptr;
    }
  }

  // The value slot of key, inserted with `value` when absent; second is true when inserted.
  std::pair<std::uint32_t*, bool> insert(std::uint64_t key, std::uint32_t value) {
    if (2 * (size_ + 1) > slots_.size()) grow();
    for (std::size_t h = hash(key);; h = (h + 1) & mask_) {
      Slot& slot = slots_[h];
      if (slot.key == key) return {&slot.value, false};
      if (slot.key == kEmptyKey) {
        slot = Slot{key, value};
        ++size_;
        return {&slot.value, true};
      }
    }
  }

  std::size_t size() const { return size_; }

 private:
  struct Slot {
    std::uint64_t key;
    std::uint32_t value;
  };

  std::size_t hash(std::uint64_t key) const {
    key ^= key >> 31;  // splitmix64 finaliser: packed keys are very regular
    key *= 0x7fb5d329728ea185ull;
    key ^= key >> 27;
    key *= 0x81dadef4bc2dd44dull;
    key ^= key >> 33;
    return static_cast<std::size_t>(key) & mask_;
  }

  void grow() {
    std::vector<Slot> old;
    old.swap(slots_);
    slots_.assign(old.size() * 2, Slot{kEmptyKey, 0});
    mask_ = slots_.size() - 1;
    size_ = 0;
    for (const Slot& slot : old) {
      if (slot.key != kEmptyKey) insert(slot.key, slot.value);
    }
  }

  std::vector<Slot> slots_;
  std::size_t mask_ = 0;
  std::size_t size_ = 0;
};

// A cloud's points grouped by voxel: cell c holds order[begin[c] .. begin[c + 1]) (point indices,
// ascending). Cells are numbered in the order their first point appears in the cloud.
class VoxelGrid {
 public:
  VoxelGrid(const std::vector<Eigen::Vector3f>& points, float voxel_size)
      : inverse_size_(1.0f / voxel_size), map_(points.size() / 4 + 1) {
    std::vector<std::uint32_t> cell_of(points.size());
    std::vector<std::uint32_t> counts;
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector3i v = voxel_of(points[i], inverse_size_);
      const auto [cell, inserted] = map_.insert(pack_voxel(v), static_cast<std::uint32_t>(coords_.size()));
      if (inserted) {
        coords_.push_back(v);
        counts.push_back(0);
      }
      cell_of[i] = *cell;
      ++counts[*cell];
    }
    begin_.assign(coords_.size() + 1, 0);
    for (std::size_t c = 0; c < coords_.size(); ++c) begin_[c + 1] = begin_[c] + counts[c];
    order_.resize(points.size());
    std::vector<std::uint32_t> fill(begin_.begin(), begin_.end() - 1);
    for (std::size_t i = 0; i < points.size(); ++i) order_[fill[cell_of[i]]++] = static_cast<std::uint32_t>(i);
  }

  std::size_t cells() const { return coords_.size(); }
  const Eigen::Vector3i& coord(std::size_t cell) const { return coords_[cell]; }
  // Point indices of a cell.
  const std::uint32_t* cell_begin(std::size_t cell) const { return order_.data() + begin_[cell]; }
  const std::uint32_t* cell_end(std::size_t cell) const { return order_.data() + begin_[cell + 1]; }
  // Cell number of voxel coordinates, or -1.
  long find(const Eigen::Vector3i& v) const {
    const std::uint32_t* cell = map_.find(pack_voxel(v));
    return cell ? static_cast<long>(*cell) : -1;
  }

 private:
  float inverse_size_;
  VoxelMap map_;
  std::vector<Eigen::Vector3i> coords_;
  std::vector<std::uint32_t> begin_;
  std::vector<std::uint32_t> order_;
};

}  // namespace fleetslam::central::detail
