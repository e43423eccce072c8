#include "fleetslam/slam/dense_mapping.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "fleetslam/core/error.hpp"
#include "fleetslam/core/stereo_rectify.hpp"

namespace fleetslam::slam {

namespace {

bool is_stereo_mode(core::SensorMode mode) {
  return mode == core::SensorMode::kStereo || mode == core::SensorMode::kStereoInertial;
}

// 21 bits per axis (about +-10 km at 1 cm voxels) packed into one key.
constexpr std::int64_t kAxisBits = 21;
constexpr std::int64_t kAxisOffset = std::int64_t{1} << (kAxisBits - 1);
constexpr std::int64_t kAxisMask = (std::int64_t{1} << kAxisBits) - 1;

core::PointCloud::Rgb color_at(const cv::Mat& image, int row, int col) {
  if (image.empty()) return {128, 128, 128};
  if (image.type() == CV_8UC3) {
    const cv::Vec3b& bgr = image.at<cv::Vec3b>(row, col);
    return {bgr[2], bgr[1], bgr[0]};
  }
  if (image.type() == CV_8UC4) {
    const cv::Vec4b& bgra = image.at<cv::Vec4b>(row, col);
    return {bgra[2], bgra[1], bgra[0]};
  }
  const std::uint8_t g = image.at<std::uint8_t>(row, col);
  return {g, g, g};
}

}  // namespace

DenseMapper::DenseMapper(const DenseMappingConfig& config, const FrameBuilder& builder)
    : config_(config), mode_(builder.rig().mode), bf_(builder.bf()), rectification_(builder.rectification()) {
  if (!(config_.min_depth_m < config_.max_depth_m)) {
    throw InputError("dense_mapping", "min_depth_m must be below max_depth_m");
  }
  if (config_.stereo_block_size < 1 || config_.stereo_block_size % 2 == 0) {
    throw InputError("dense_mapping.stereo_block_size", "must be odd and positive");
  }
  if (config_.pixel_stride < 1) throw InputError("dense_mapping.pixel_stride", "must be at least 1");
  if (config_.stereo_disparities < 1) throw InputError("dense_mapping.stereo_disparities", "must be positive");
  config_.stereo_disparities = (config_.stereo_disparities + 15) / 16 * 16;
  // RGB-D depth is registered to the raw (distorted) colour image; stereo depth lives in the rectified
  // (or already rectified, distortion-free) left image, which is the front end's camera.
  const bool raw = !is_stereo_mode(mode_);
  camera_ = raw ? builder.rig().cam0 : builder.camera();
  const int stride = config_.pixel_stride;
  sample_cols_ = (camera_.width() + stride - 1) / stride;
  sample_rows_ = (camera_.height() + stride - 1) / stride;
  rays_.assign(static_cast<std::size_t>(sample_cols_) * sample_rows_,
               Eigen::Vector2f::Constant(std::numeric_limits<float>::quiet_NaN()));
  for (int r = 0; r < sample_rows_; ++r) {
    for (int c = 0; c < sample_cols_; ++c) {
      const Eigen::Vector2d uv(c * stride, r * stride);
      const std::optional<Eigen::Vector3d> ray = camera_.unproject(uv);
      if (ray) rays_[static_cast<std::size_t>(r) * sample_cols_ + c] = ray->head<2>().cast<float>();
    }
  }
}

core::PointCloud DenseMapper::back_project(const cv::Mat& depth_m, const cv::Mat& image) const {
  core::PointCloud cloud;
  const int stride = config_.pixel_stride;
  const float min_d = static_cast<float>(config_.min_depth_m);
  const float max_d = static_cast<float>(config_.max_depth_m);
  const float step = static_cast<float>(config_.max_depth_step);
  const bool color_ok = !image.empty() && image.size() == depth_m.size();
  cloud.reserve(rays_.size() / 2);
  cloud.normals.reserve(rays_.size() / 2);
  auto depth_at = [&](int row, int col) -> float {
    if (row >= depth_m.rows || col >= depth_m.cols) return 0.0f;
    return depth_m.at<float>(row, col);
  };
  // The point of sample (r, c) when it has usable depth.
  auto sample_point = [&](int r, int c, Eigen::Vector3f& p) {
    if (r < 0 || c < 0 || r >= sample_rows_ || c >= sample_cols_) return false;
    const float z = depth_at(r * stride, c * stride);
    if (!(z > 0.0f && z >= min_d && z <= max_d)) return false;  // 0: no measurement, even with min_depth_m 0
    const Eigen::Vector2f& ray = rays_[static_cast<std::size_t>(r) * sample_cols_ + c];
    if (!ray.allFinite()) return false;
    p = Eigen::Vector3f(ray.x() * z, ray.y() * z, z);
    return true;
  };
  // The surface normal at p from its grid neighbours on the same surface (right or else left, down or
  // else up, each within the depth step), turned towards the camera; zero when there are none.
  const float same_surface = step > 0.0f ? step : 0.05f;
  auto normal_at = [&](int r, int c, const Eigen::Vector3f& p) -> Eigen::Vector3f {
    Eigen::Vector3f q;
    auto neighbour = [&](int dr, int dc, Eigen::Vector3f& d) {
      if (!sample_point(r + dr, c + dc, q) || std::abs(q.z() - p.z()) > same_surface * p.z()) return false;
      d = (q - p) * static_cast<float>(dr + dc);  // points right / down either way
      return true;
    };
    Eigen::Vector3f along_row, along_col;
    if (!neighbour(0, 1, along_row) && !neighbour(0, -1, along_row)) return Eigen::Vector3f::Zero();
    if (!neighbour(1, 0, along_col) && !neighbour(-1, 0, along_col)) return Eigen::Vector3f::Zero();
    Eigen::Vector3f n = along_row.cross(along_col);
    const float length = n.norm();
    if (!(length > 0.0f)) return Eigen::Vector3f::Zero();
    n /= length;
    return n.dot(p) > 0.0f ? Eigen::Vector3f(-n) : n;
  };
  for (int r = 0; r < sample_rows_; ++r) {
    const int row = r * stride;
    for (int c = 0; c < sample_cols_; ++c) {
      const int col = c * stride;
      Eigen::Vector3f p;
      if (!sample_point(r, c, p)) continue;  // also drops NaN
      const float z = p.z();
      if (step > 0.0f) {
        // A sample whose neighbour (one stride right or down) jumps in depth sits on an edge, where
        // sensors report "flying pixels" between foreground and background.
        const float right = depth_at(row, col + stride);
        const float down = depth_at(row + stride, col);
        if ((right > 0.0f && std::abs(right - z) > step * z) || (down > 0.0f && std::abs(down - z) > step * z)) {
          continue;
        }
      }
      const core::PointCloud::Rgb rgb = color_ok ? color_at(image, row, col) : core::PointCloud::Rgb{128, 128, 128};
      cloud.push_back(p, rgb, normal_at(r, c, p));
    }
  }
  return cloud;
}

cv::Mat DenseMapper::stereo_depth(const core::SensorFrame& sensor, cv::Mat& left_color) const {
  cv::Mat left = sensor.image;
  cv::Mat right = sensor.right;
  if (right.empty() || right.size() != left.size() || right.type() != left.type()) return {};
  if (rectification_) {
    try {
      std::tie(left, right) = core::rectify_images(*rectification_, left, right);
    } catch (const std::invalid_argument&) {
      return {};
    }
  }
  left_color = left;
  cv::Mat left_gray = left;
  cv::Mat right_gray = right;
  if (left.channels() == 3) {
    cv::cvtColor(left, left_gray, cv::COLOR_BGR2GRAY);
    cv::cvtColor(right, right_gray, cv::COLOR_BGR2GRAY);
  } else if (left.channels() == 4) {
    cv::cvtColor(left, left_gray, cv::COLOR_BGRA2GRAY);
    cv::cvtColor(right, right_gray, cv::COLOR_BGRA2GRAY);
  }
  const int block = config_.stereo_block_size;
  cv::Ptr<cv::StereoSGBM> sgbm = cv::StereoSGBM::create(0, config_.stereo_disparities, block, 8 * block * block,
                                                        32 * block * block, 1, 63, config_.stereo_uniqueness_percent,
                                                        100, 2, cv::StereoSGBM::MODE_SGBM);
  cv::Mat disparity16;
  sgbm->compute(left_gray, right_gray, disparity16);
  cv::Mat depth(disparity16.size(), CV_32FC1, cv::Scalar(0.0f));
  for (int r = 0; r < disparity16.rows; ++r) {
    const std::int16_t* d = disparity16.ptr<std::int16_t>(r);
    float* z = depth.ptr<float>(r);
    for (int c = 0; c < disparity16.cols; ++c) {
      if (d[c] > 0) z[c] = static_cast<float>(bf_ * 16.0 / d[c]);
    }
  }
  return depth;
}

core::PointCloud DenseMapper::keyframe_cloud(const core::SensorFrame& sensor) const {
  if (!config_.enabled) return {};
  const cv::Size expected(camera_.width(), camera_.height());
  if (is_stereo_mode(mode_)) {
    if (sensor.image.empty() || sensor.image.depth() != CV_8U) return {};
    cv::Mat left_color;
    const cv::Mat depth = stereo_depth(sensor, left_color);
    if (depth.empty() || depth.size() != expected) return {};
    return back_project(depth, left_color);
  }
  if (mode_ != core::SensorMode::kRgbd) return {};
  if (sensor.depth_m.empty() || sensor.depth_m.type() != CV_32FC1 || sensor.depth_m.size() != expected) return {};
  const cv::Mat image = sensor.image.depth() == CV_8U ? sensor.image : cv::Mat();
  return back_project(sensor.depth_m, image);
}

std::int64_t DenseMapper::voxel_key(const Eigen::Vector3f& p) const {
  const double inv = 1.0 / config_.voxel_size_m;
  // Clamped to the 21 bits: far points share the border voxels instead of wrapping into voxels near the
  // origin (at 0.1 mm voxels, points 105 m apart shared a key and the later one was dropped).
  constexpr double kLimit = static_cast<double>(kAxisOffset - 1);
  const auto axis = [&](float x) {
    const double v = std::clamp(std::floor(static_cast<double>(x) * inv), -kLimit, kLimit);
    return (static_cast<std::int64_t>(v) + kAxisOffset) & kAxisMask;
  };
  return (axis(p.x()) << (2 * kAxisBits)) | (axis(p.y()) << kAxisBits) | axis(p.z());
}

std::size_t DenseMapper::add_keyframe(KeyframeId id, const Eigen::Isometry3d& T_world_cam,
                                      const core::PointCloud& cloud_cam) {
  if (!added_.insert(id).second) return 0;
  back_projected_ += cloud_cam.size();
  core::PointCloud kept;
  std::vector<std::int64_t>& voxels = voxels_[id];
  if (config_.voxel_size_m <= 0.0) {
    kept = cloud_cam;
  } else {
    const Eigen::Matrix3f R = T_world_cam.linear().cast<float>();
    const Eigen::Vector3f t = T_world_cam.translation().cast<float>();
    const bool colored = cloud_cam.has_colors();
    kept.reserve(cloud_cam.size() / 4, colored);
    for (std::size_t i = 0; i < cloud_cam.size(); ++i) {
      const Eigen::Vector3f& p = cloud_cam.points[i];
      if (!p.allFinite()) continue;
      const std::int64_t key = voxel_key(R * p + t);
      if (!occupied_.insert(key).second) continue;
      voxels.push_back(key);
      kept.push_back_from(cloud_cam, i);
    }
  }
  const std::size_t n = kept.size();
  clouds_[id].append(kept);  // after any points it inherited before its own came
  return n;
}

void DenseMapper::remove_keyframe(KeyframeId id, const std::optional<std::pair<KeyframeId, Eigen::Isometry3d>>& heir) {
  added_.erase(id);
  auto it = clouds_.find(id);
  if (it == clouds_.end()) return;
  core::PointCloud cloud = std::move(it->second);
  clouds_.erase(it);
  std::vector<std::int64_t> voxels = std::move(voxels_[id]);
  voxels_.erase(id);
  if (!heir || heir->first == id) {
    for (const std::int64_t key : voxels) occupied_.erase(key);
    return;
  }
  core::transform_in_place(cloud, heir->second);
  clouds_[heir->first].append(cloud);
  std::vector<std::int64_t>& heir_voxels = voxels_[heir->first];
  heir_voxels.insert(heir_voxels.end(), voxels.begin(), voxels.end());
}

const core::PointCloud* DenseMapper::keyframe_cloud_of(KeyframeId id) const {
  auto it = clouds_.find(id);
  return it == clouds_.end() ? nullptr : &it->second;
}

core::PointCloud DenseMapper::cloud_world(const PoseLookup& pose) const {
  core::PointCloud out;
  std::size_t total = 0;
  for (const auto& [id, cloud] : clouds_) total += cloud.size();
  out.reserve(total);
  for (const auto& [id, cloud] : clouds_) {
    const std::optional<Eigen::Isometry3d> T_world_cam = pose(id);
    if (!T_world_cam) continue;
    out.append(core::transformed(cloud, *T_world_cam));
  }
  return out;
}

DenseStats DenseMapper::stats() const {
  DenseStats s;
  s.keyframes = clouds_.size();
  for (const auto& [id, cloud] : clouds_) s.points += cloud.size();
  s.back_projected = back_projected_;
  s.occupied_voxels = occupied_.size();
  return s;
}

}  // namespace fleetslam::slam
