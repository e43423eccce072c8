#include "fleetslam/slam/frame.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "fleetslam/core/error.hpp"

namespace fleetslam::slam {
namespace {

// Spacing of the border samples in undistorted_image_bounds: fine enough that the bulge of any
// calibrated radial distortion between two samples stays far below a pixel.
constexpr int kBorderSampleStepPx = 4;

ImageBounds bounding_box(const std::vector<Eigen::Vector2d>& uv) {
  ImageBounds box{std::numeric_limits<double>::max(), std::numeric_limits<double>::lowest(),
                  std::numeric_limits<double>::max(), std::numeric_limits<double>::lowest()};
  for (const Eigen::Vector2d& p : uv) {
    if (!p.allFinite()) continue;
    box.min_u = std::min(box.min_u, p.x());
    box.max_u = std::max(box.max_u, p.x());
    box.min_v = std::min(box.min_v, p.y());
    box.max_v = std::max(box.max_v, p.y());
  }
  if (box.min_u > box.max_u) return {};
  // The grid's upper bounds are exclusive: step past the largest coordinates.
  box.max_u += 1.0;
  box.max_v += 1.0;
  return box;
}

}  // namespace

ScalePyramid ScalePyramid::make(int levels, double scale_factor) {
  if (levels < 1) throw std::invalid_argument("ScalePyramid: levels must be >= 1, got " + std::to_string(levels));
  if (!(std::isfinite(scale_factor) && scale_factor >= 1.0)) {
    throw std::invalid_argument("ScalePyramid: scale_factor must be finite and >= 1, got " +
                                std::to_string(scale_factor));
  }
  ScalePyramid p;
  p.levels = levels;
  p.scale_factor = scale_factor;
  double s = 1.0;
  for (int l = 0; l < levels; ++l, s *= scale_factor) {
    p.scale.push_back(s);
    p.inv_scale.push_back(1.0 / s);
    p.sigma2.push_back(s * s);
    p.inv_sigma2.push_back(1.0 / (s * s));
  }
  return p;
}

ImageBounds ImageBounds::of_image(int width, int height) {
  return {-0.5, width - 0.5, -0.5, height - 0.5};
}

ImageBounds undistorted_image_bounds(const core::PinholeCamera& raw) {
  const ImageBounds image = ImageBounds::of_image(raw.width(), raw.height());
  if (raw.distortion().is_zero()) return image;
  std::vector<Eigen::Vector2d> border;
  for (double u = image.min_u; u < image.max_u + kBorderSampleStepPx; u += kBorderSampleStepPx) {
    const double uc = std::min(u, image.max_u);
    border.emplace_back(uc, image.min_v);
    border.emplace_back(uc, image.max_v);
  }
  for (double v = image.min_v; v < image.max_v + kBorderSampleStepPx; v += kBorderSampleStepPx) {
    const double vc = std::min(v, image.max_v);
    border.emplace_back(image.min_u, vc);
    border.emplace_back(image.max_u, vc);
  }
  const ImageBounds box = bounding_box(raw.undistort_points(border));
  return box.empty() ? image : box;
}

FeatureGrid::FeatureGrid(const std::vector<Eigen::Vector2d>& uv, const std::vector<int>& level, double min_u,
                         double max_u, double min_v, double max_v, int cols, int rows) {
  FLEETSLAM_CHECK(cols > 0 && rows > 0, "FeatureGrid needs at least one cell");
  FLEETSLAM_CHECK(std::isfinite(min_u) && std::isfinite(max_u) && std::isfinite(min_v) && std::isfinite(max_v),
                  "FeatureGrid bounds must be finite");
  FLEETSLAM_CHECK(uv.size() <= static_cast<std::size_t>(std::numeric_limits<int>::max() - kGatherSlice),
                  "FeatureGrid: too many features for int indices");
  FLEETSLAM_CHECK(level.empty() || level.size() == uv.size(), "FeatureGrid: one level per feature, or none");
  cols_ = cols;
  rows_ = rows;
  min_u_ = min_u;
  min_v_ = min_v;
  cell_w_ = (max_u > min_u ? max_u - min_u : 1.0) / cols;
  cell_h_ = (max_v > min_v ? max_v - min_v : 1.0) / rows;
  inv_cell_w_ = 1.0 / cell_w_;
  inv_cell_h_ = 1.0 / cell_h_;
  has_levels_ = level.size() == uv.size();  // with no features, vacuously
  built_from_ = uv.size();
  const double end_u = min_u_ + cell_w_ * cols;
  const double end_v = min_v_ + cell_h_ * rows;
  const std::size_t cells = static_cast<std::size_t>(cols) * static_cast<std::size_t>(rows);
  // Counting sort by cell: count per cell (shifted by one), prefix sums give each cell's start, then
  // the entries in ascending feature order, so that each cell's slice is ascending.
  std::vector<int> cell_of(uv.size(), -1);
  cell_start_.assign(cells + 1, 0);
  for (std::size_t i = 0; i < uv.size(); ++i) {
    const double u = uv[i].x();
    const double v = uv[i].y();
    // Written so that NaN fails every comparison and is skipped.
    if (!(u >= min_u_ && u < end_u && v >= min_v_ && v < end_v)) continue;
    // Rounding can put a coordinate just below the end into cell `cols`: clamp.
    const int cx = std::min(static_cast<int>((u - min_u_) / cell_w_), cols_ - 1);
    const int cy = std::min(static_cast<int>((v - min_v_) / cell_h_), rows_ - 1);
    cell_of[i] = cy * cols_ + cx;
    ++cell_start_[static_cast<std::size_t>(cell_of[i]) + 1];
  }
  for (std::size_t c = 0; c < cells; ++c) cell_start_[c + 1] += cell_start_[c];
  const std::size_t entries = static_cast<std::size_t>(cell_start_[cells]) + kGatherSlice;
  index_.assign(entries, 0);
  u_.assign(entries, 0.0);
  v_.assign(entries, 0.0);
  level_.assign(entries, 0);
  std::vector<int> next(cell_start_.begin(), cell_start_.end() - 1);
  for (std::size_t i = 0; i < uv.size(); ++i) {
    if (cell_of[i] < 0) continue;
    const auto e = static_cast<std::size_t>(next[static_cast<std::size_t>(cell_of[i])]++);
    index_[e] = static_cast<int>(i);
    u_[e] = uv[i].x();
    v_[e] = uv[i].y();
    level_[e] = has_levels_ ? level[i] : 0;
  }
}

std::vector<int> FeatureGrid::features_in_area(double u, double v, double radius_px, int min_level,
                                               int max_level) const {
  std::vector<int> found;
  features_in_area(u, v, radius_px, min_level, max_level, found);
  std::sort(found.begin(), found.end());
  return found;
}

std::size_t FeatureGrid::features_in_area(double u, double v, double radius_px, int min_level, int max_level,
                                          std::vector<int>& found) const {
  const std::size_t before = found.size();
  visit_area(u, v, radius_px, min_level, max_level, [&found](int i) { found.push_back(i); });
  return found.size() - before;
}

std::optional<Eigen::Vector3d> Frame::unproject(std::size_t i) const {
  FLEETSLAM_CHECK(i < uv.size() && i < depth_m.size(), "Frame::unproject: feature index out of range");
  const double z = depth_m[i];
  if (!(z > 0.0) || !std::isfinite(z)) return std::nullopt;
  return Eigen::Vector3d((uv[i].x() - camera.cx()) / camera.fx() * z, (uv[i].y() - camera.cy()) / camera.fy() * z, z);
}

void Frame::finalize() {
  const std::size_t n = uv.size();
  if (depth_m.empty()) depth_m.assign(n, -1.0);
  FLEETSLAM_CHECK(depth_m.size() == n, "Frame::finalize: per-feature vectors differ in size");
  if (u_right.empty()) {
    u_right.assign(n, -1.0);
    for (std::size_t i = 0; i < n; ++i) {
      if (has_right(i)) u_right[i] = uv[i].x() - bf / depth_m[i];
    }
  }
  FLEETSLAM_CHECK(keypoints.size() == n && level.size() == n && u_right.size() == n,
                  "Frame::finalize: per-feature vectors differ in size");
  FLEETSLAM_CHECK(static_cast<std::size_t>(descriptors.rows) == n || (n == 0 && descriptors.empty()),
                  "Frame::finalize: descriptor rows differ from the number of features");
  map_points.assign(n, kNoMapPoint);
  outlier.assign(n, false);
  ImageBounds area = bounds;
  if (area.empty() && camera.width() > 0) area = ImageBounds::of_image(camera.width(), camera.height());
  if (area.empty()) area = bounding_box(uv);
  grid = FeatureGrid(uv, level, area);
}

}  // namespace fleetslam::slam
