#pragma once
// A coloured point cloud as a value: what dense mapping produces, what the central unit merges, and
// what the simulator's ground-truth surfaces are compared against. Positions are float (millimetre
// precision over kilometres is more than any map here needs, and it halves memory against double);
// the frame the points are in is the owner's business and goes into variable names (`cloud_world`).
// PCL stays out of this header: modules that use PCL convert in their .cpp files.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace fleetslam::core {

struct PointCloud {
  using Rgb = std::array<std::uint8_t, 3>;  // red, green, blue

  std::vector<Eigen::Vector3f> points;
  std::vector<Rgb> colors;  // empty, or one per point
  // Empty, or one per point: the unit surface normal on the side the sensor saw the surface from (dense
  // mapping estimates it from the depth image), or zero where it is unknown. Opposite faces of a thin
  // wall lie centimetres apart but have opposite normals: the central unit tells them apart by these.
  std::vector<Eigen::Vector3f> normals;

  std::size_t size() const { return points.size(); }
  bool empty() const { return points.empty(); }
  bool has_colors() const { return !colors.empty() && colors.size() == points.size(); }
  bool has_normals() const { return !normals.empty() && normals.size() == points.size(); }
  void reserve(std::size_t n, bool with_colors = true);
  void clear();
  void push_back(const Eigen::Vector3f& p);
  void push_back(const Eigen::Vector3f& p, const Rgb& rgb);
  void push_back(const Eigen::Vector3f& p, const Rgb& rgb, const Eigen::Vector3f& normal);
  // Appends point i of `other` with the colour and normal it has (a cloud built this way from one
  // source keeps that source's attributes).
  void push_back_from(const PointCloud& other, std::size_t i);
  // Appends `other`. Colours are kept only when both clouds have them (or this one is empty); normals
  // when either has them, the points of the other with zero ones (unknown).
  void append(const PointCloud& other);
};

// Points mapped by T (p' = T * p), normals rotated; colours unchanged.
PointCloud transformed(const PointCloud& cloud, const Eigen::Isometry3d& T);
void transform_in_place(PointCloud& cloud, const Eigen::Isometry3d& T);
// The points alone moved by T, computed as transform_in_place does (no copy of colours or normals).
std::vector<Eigen::Vector3f> transformed_points(const std::vector<Eigen::Vector3f>& points, const Eigen::Isometry3d& T);

// Drops points with a NaN or infinite coordinate; returns how many were dropped. A kept point's
// non-finite normal becomes zero (unknown): compared with others, NaN would disagree with every normal.
std::size_t remove_non_finite(PointCloud& cloud);

// Axis-aligned bounds of the finite points; both zero for an empty cloud.
struct Bounds3f {
  Eigen::Vector3f min = Eigen::Vector3f::Zero();
  Eigen::Vector3f max = Eigen::Vector3f::Zero();
};
Bounds3f bounds(const PointCloud& cloud);

// PLY (binary little-endian or ASCII; x y z as float, optional red green blue as uchar, optional nx ny nz
// as float) and PCD (binary or ASCII; x y z [rgb], no normals). Writers create parent folders; readers
// accept what the writers produce plus the common variants (double coordinates, extra properties ignored) and
// throw InputError naming the file and what is wrong (bad header, truncated body, unknown format).
enum class CloudEncoding { kBinary, kAscii };
void write_ply(const std::string& path, const PointCloud& cloud, CloudEncoding encoding = CloudEncoding::kBinary);
void write_pcd(const std::string& path, const PointCloud& cloud, CloudEncoding encoding = CloudEncoding::kBinary);
PointCloud read_ply(const std::string& path);
PointCloud read_pcd(const std::string& path);
// By extension (.ply / .pcd); anything else is an InputError.
void write_point_cloud(const std::string& path, const PointCloud& cloud);
PointCloud read_point_cloud(const std::string& path);

}  // namespace fleetslam::core
