#pragma once
// Internal: voxel keys, a flat hash map from voxel key to a 32-bit value, and a voxel grid that groups
// a cloud's points by voxel (points of one voxel contiguous) for grouped neighbour queries. Voxels are
// anchored at the origin: voxel (i, j, k) spans [i, i+1) * size on x, and so on.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace fleetslam::central::detail {

// Voxel coordinates are clamped to +-(2^20 - 2) (+-10 km at 1 cm voxels): farther points share the border
// voxels rather than overflow, and a neighbour (+-1) still packs without carrying into the next field.
constexpr int kMaxVoxelCoordinate = (1 << 20) - 2;

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

// 21 bits per axis in the low 63 bits, x highest: keys sort like (x, y, z). Never equals kEmptyKey.
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

// A cloud's points grouped by voxel, cells sorted by voxel key (x, then y, then z): cell c holds
// order[begin[c] .. begin[c + 1]) (point indices, ascending) and a copy of their positions in the same
// order, so a cell's points are one contiguous block and neighbouring cells lie close in memory. Visiting
// cells in order with a NeighbourSweep finds each cell's 3x3x3 neighbourhood by merging sorted runs
// instead of hashing (measured on 300k points: hashed lookups in first-appearance order were
// cache-miss bound and 3-4x slower).
class VoxelGrid {
 public:
  VoxelGrid(const std::vector<Eigen::Vector3f>& points, float voxel_size) {
    const float inverse_size = 1.0f / voxel_size;
    std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
      keyed[i] = {pack_voxel(voxel_of(points[i], inverse_size)), static_cast<std::uint32_t>(i)};
    }
    std::sort(keyed.begin(), keyed.end());
    order_.resize(points.size());
    sorted_.resize(points.size());
    for (std::size_t i = 0; i < keyed.size(); ++i) {
      if (i == 0 || keyed[i].first != keyed[i - 1].first) {
        keys_.push_back(keyed[i].first);
        begin_.push_back(static_cast<std::uint32_t>(i));
      }
      order_[i] = keyed[i].second;
      sorted_[i] = points[keyed[i].second];
    }
    begin_.push_back(static_cast<std::uint32_t>(keyed.size()));
  }

  std::size_t cells() const { return keys_.size(); }
  std::uint64_t key(std::size_t cell) const { return keys_[cell]; }
  Eigen::Vector3i coord(std::size_t cell) const { return unpack_voxel(keys_[cell]); }
  // Point indices of a cell (ascending).
  const std::uint32_t* cell_begin(std::size_t cell) const { return order_.data() + begin_[cell]; }
  const std::uint32_t* cell_end(std::size_t cell) const { return order_.data() + begin_[cell + 1]; }
  // Positions of a cell's points, in the order of cell_begin .. cell_end.
  const Eigen::Vector3f* cell_points(std::size_t cell) const { return sorted_.data() + begin_[cell]; }
  std::size_t cell_size(std::size_t cell) const { return begin_[cell + 1] - begin_[cell]; }
  // Cell number of voxel coordinates, or -1 (binary search).
  long find(const Eigen::Vector3i& v) const {
    const std::uint64_t k = pack_voxel(v);
    const auto it = std::lower_bound(keys_.begin(), keys_.end(), k);
    return it != keys_.end() && *it == k ? static_cast<long>(it - keys_.begin()) : -1;
  }

  static Eigen::Vector3i unpack_voxel(std::uint64_t key) {
    const auto field = [](std::uint64_t bits) { return static_cast<int>(bits & 0x1fffffu) - (1 << 20); };
    return {field(key >> 42), field(key >> 21), field(key)};
  }

 private:
  std::vector<std::uint64_t> keys_;
  std::vector<std::uint32_t> begin_;
  std::vector<std::uint32_t> order_;
  std::vector<Eigen::Vector3f> sorted_;
};

// The cells of a grid within one voxel of each cell (itself included), for cells visited in increasing
// order: nine cursors, one per (dx, dy), each advancing monotonically over the sorted keys.
class NeighbourSweep {
 public:
  explicit NeighbourSweep(const VoxelGrid& grid) : grid_(grid) { cursors_.fill(0); }

  // Cells next to `cell` (ascending per row); `cell` must not decrease between calls.
  void neighbours(std::size_t cell, std::vector<std::uint32_t>& out) {
    out.clear();
    const Eigen::Vector3i v = grid_.coord(cell);
    int row = 0;
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy, ++row) {
        const std::uint64_t lo = pack_voxel(Eigen::Vector3i(v.x() + dx, v.y() + dy, v.z() - 1));
        const std::uint64_t hi = pack_voxel(Eigen::Vector3i(v.x() + dx, v.y() + dy, v.z() + 1));
        std::size_t& c = cursors_[static_cast<std::size_t>(row)];
        while (c < grid_.cells() && grid_.key(c) < lo) ++c;
        for (std::size_t k = c; k < grid_.cells() && grid_.key(k) <= hi; ++k) out.push_back(static_cast<std::uint32_t>(k));
      }
    }
  }

 private:
  const VoxelGrid& grid_;
  std::array<std::size_t, 9> cursors_;
};

}  // namespace fleetslam::central::detail
