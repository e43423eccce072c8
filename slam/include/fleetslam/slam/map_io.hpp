#pragma once
// Map files: an agent's Map saved to a versioned binary file and loaded back exactly (every field of
// every keyframe, frame, map point, the covisibility graph and spanning tree as they are, BoW vectors,
// culled-keyframe records, replaced points, id counters), so that a later run localises in it.
//
// Format, version 2, little-endian fixed-width fields throughout (doubles as IEEE 754 bits):
//   header   8 bytes magic "FSMAP\0\0\1", u32 format version, u32 section count (5), u64 payload bytes
//   payload  sections in this order, each u32 tag ("META", "KFRM", "MPTS", "CULL", "REPL"), u32 0,
//            u64 size, then `size` bytes:
//     META   i64 next keyframe id, i64 next point id, u64 vocabulary fingerprint (0: none),
//            u64 n, n x i32 map components, u64 keyframes, u64 points
//     KFRM   per keyframe (ascending id): id, stamp, component, root, connected, T_world_cam (4x4),
//            the Frame (id, stamp, camera, pyramid, bf, close depth, bounds, keypoints, uv, levels,
//            descriptors, depth, u_right, map points, outlier flags, optional pose), BoW vector, feature
//            vector, covisibility weights, ordered neighbours, parent, children, loop edges (version 2;
//            version 1 files, without them, are refused). The feature grid is
//            rebuilt from uv, the levels and the bounds as Frame::finalize() builds it.
//     MPTS   per map point (ascending id): every MapPoint field
//     CULL   per culled keyframe (ascending id): id, parent, T_parent_kf (4x4)
//     REPL   per replaced point (ascending id): old id, replacement id
//   trailer  u64 FNV-1a 64 of every byte before it
// A reader checks the magic, version, that the file is exactly as long as the header says, the checksum,
// each section's tag and size, every count against the bytes left, and the map's invariants (two-way
// point-feature links, keyframe references, levels within the pyramid) before anything uses it: bad files
// are InputErrors naming the file and what is wrong, never a crash.

#include <cstdint>
#include <filesystem>
#include <string>

#include "fleetslam/slam/map.hpp"
#include "fleetslam/slam/vocabulary.hpp"

namespace fleetslam::slam {

// Version 2 adds each keyframe's loop edges (files of version 1 are refused with an InputError).
inline constexpr std::uint32_t kMapFormatVersion = 2;

// A map as a file holds it: the map and the fingerprint of the vocabulary its BoW vectors came from.
struct SavedMap {
  Map map;
  std::uint64_t vocabulary_fingerprint = 0;  // 0: no vocabulary (BoW vectors empty)
};

// FNV-1a 64 over the vocabulary's tree (branching, depth, parents, node descriptors, words, weights);
// 0 for an empty vocabulary.
std::uint64_t vocabulary_fingerprint(const Vocabulary& vocabulary);

// The file's bytes, and the map back from them (`where` names the source in errors).
std::string map_to_bytes(const Map& map, std::uint64_t vocabulary_fingerprint = 0);
SavedMap map_from_bytes(const std::string& bytes, const std::string& where);

// Throws InputError naming the file when it cannot be written / read or is not a valid map file.
void save_map(const Map& map, const std::filesystem::path& file, std::uint64_t vocabulary_fingerprint = 0);
SavedMap load_map(const std::filesystem::path& file);

// Empty when the two maps are identical field by field (doubles compared bit for bit, the feature grids
// included), otherwise the first difference found, e.g. "keyframe 3: frame.uv[17] differs".
std::string map_difference(const Map& a, const Map& b);

}  // namespace fleetslam::slam
