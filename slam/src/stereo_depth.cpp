// Depth for features: stereo stripe search with SAD refinement on rectified pairs, and RGB-D lookup.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "fleetslam/core/error.hpp"
#include "fleetslam/slam/matcher.hpp"
#include "fleetslam/slam/orb_extractor.hpp"

namespace fleetslam::slam {
namespace {

// For every row of the level-0 image, the right features whose row band covers it. A feature's band
// is +-row_band_scales * scale of its level: coarser levels localise worse.
std::vector<std::vector<int>> index_rows(const std::vector<cv::KeyPoint>& right, const ScalePyramid& pyramid,
                                         int rows, double band_scales) {
  std::vector<std::vector<int>> by_row(static_cast<std::size_t>(rows));
  for (std::size_t i = 0; i < right.size(); ++i) {
    const cv::KeyPoint& k = right[i];
    if (k.octave < 0 || k.octave >= pyramid.levels) continue;
    const double band = band_scales * pyramid.scale[static_cast<std::size_t>(k.octave)];
    const double y = static_cast<double>(k.pt.y);
    const int first = std::max(0, static_cast<int>(std::floor(y - band)));
    const int last = std::min(rows - 1, static_cast<int>(std::ceil(y + band)));
    for (int r = first; r <= last; ++r) by_row[static_cast<std::size_t>(r)].push_back(static_cast<int>(i));
  }
  return by_row;
}

struct Candidate {
  int right = -1;
  int distance = 0;
};

// The right feature on the left feature's row, of a neighbouring level, inside the disparity range,
// with the smallest Hamming distance (the first such on ties) when it is below max_distance.
Candidate best_on_row(const cv::KeyPoint& left, const std::uint8_t* left_descriptor, const std::vector<int>& on_row,
                      const std::vector<cv::KeyPoint>& right, const cv::Mat& right_descriptors, double max_disparity,
                      int max_distance) {
  const double u = static_cast<double>(left.pt.x);
  Candidate best{-1, max_distance};
  for (const int r : on_row) {
    const cv::KeyPoint& k = right[static_cast<std::size_t>(r)];
    if (std::abs(k.octave - left.octave) > 1) continue;
    const double ur = static_cast<double>(k.pt.x);
    if (ur > u || ur < u - max_disparity) continue;
    const int d = hamming_distance(left_descriptor, right_descriptors.ptr<std::uint8_t>(r));
    if (d < best.distance) best = {r, d};
  }
  return best;
}

bool window_fits(const cv::Mat& image, int x, int y, int half) {
  return x - half >= 0 && y - half >= 0 && x + half < image.cols && y + half < image.rows;
}

// Zero-mean SAD between the (2 half + 1)^2 window of `left` at (xl, y) and the windows of `right` at
// (xr0 + offset, y) for offset in [-reach, reach]. Subtracting each window's mean makes the cost blind
// to a brightness offset between the cameras. Computed exactly in integers, scaled by the pixel count
// n: n * sum |(L - mean_L) - (R - mean_R)| = sum |n (L - R) - (sum_L - sum_R)|, which also lets the
// compiler vectorise it. The windows must lie inside both images.
std::vector<float> zero_mean_sad(const cv::Mat& left, int xl, const cv::Mat& right, int xr0, int y, int half,
                                 int reach) {
  const int side = 2 * half + 1;
  const int n = side * side;
  int left_sum = 0;
  for (int r = 0; r < side; ++r) {
    const std::uint8_t* row = left.ptr<std::uint8_t>(y - half + r) + (xl - half);
    for (int c = 0; c < side; ++c) left_sum += row[c];
  }
  // Column sums of the right strip give every window's sum with a sliding sum.
  const int first_col = xr0 - reach - half;
  const int strip = side + 2 * reach;
  std::vector<int> column_sums(static_cast<std::size_t>(strip), 0);
  for (int r = 0; r < side; ++r) {
    const std::uint8_t* row = right.ptr<std::uint8_t>(y - half + r) + first_col;
    for (int c = 0; c < strip; ++c) column_sums[static_cast<std::size_t>(c)] += row[c];
  }
  std::vector<float> costs;
  for (int k = 0; k <= 2 * reach; ++k) {
    int right_sum = 0;
    for (int c = 0; c < side; ++c) right_sum += column_sums[static_cast<std::size_t>(k + c)];
    const int offset = left_sum - right_sum;
    int scaled_cost = 0;
    for (int r = 0; r < side; ++r) {
      const std::uint8_t* l = left.ptr<std::uint8_t>(y - half + r) + (xl - half);
      const std::uint8_t* rr = right.ptr<std::uint8_t>(y - half + r) + first_col + k;
      for (int c = 0; c < side; ++c) scaled_cost += std::abs(n * (int{l[c]} - int{rr[c]}) - offset);
    }
    costs.push_back(static_cast<float>(scaled_cost) / static_cast<float>(n));
  }
  return costs;
}

struct Refined {
  bool ok = false;
  double u_right = 0.0;  // level-0 coordinates
  float sad = 0.0f;
};

// Sub-pixel right column of a left feature matched to a right one at u_right0, by SAD on the left
// feature's level images and a parabola through the best offset and its neighbours.
Refined refine(const cv::KeyPoint& left, double u_right0, const cv::Mat& left_level, const cv::Mat& right_level,
               const cv::Size& size0, const StereoMatchConfig& config) {
  const int w = config.window_half_px;
  const int reach = config.search_half_px;
  const cv::Point2d pl = to_level(cv::Point2d(left.pt), size0, left_level.size());
  const int xl = static_cast<int>(std::lround(pl.x));
  const int yl = static_cast<int>(std::lround(pl.y));
  const int xr0 = static_cast<int>(std::lround(to_level(cv::Point2d(u_right0, 0.0), size0, right_level.size()).x));
  if (!window_fits(left_level, xl, yl, w) || !window_fits(right_level, xr0 - reach, yl, w) ||
      !window_fits(right_level, xr0 + reach, yl, w)) {
    return {};
  }
  const std::vector<float> costs = zero_mean_sad(left_level, xl, right_level, xr0, yl, w, reach);
  const auto best = static_cast<std::size_t>(std::min_element(costs.begin(), costs.end()) - costs.begin());
  // A minimum on the edge of the search may lie beyond it: no trustworthy sub-pixel position.
  if (best == 0 || best + 1 == costs.size()) return {};
  const double c1 = static_cast<double>(costs[best - 1]);
  const double c2 = static_cast<double>(costs[best]);
  const double c3 = static_cast<double>(costs[best + 1]);
  const double curvature = c1 + c3 - 2.0 * c2;
  if (!(curvature > 0.0)) return {};  // flat cost: texture-less along the row
  const double delta = (c1 - c3) / (2.0 * curvature);
  if (std::abs(delta) > 1.0) return {};
  const double x_level = xr0 + (static_cast<double>(best) - reach) + delta;
  const double u_right = to_level0(cv::Point2d(x_level, 0.0), size0, right_level.size()).x;
  return {true, u_right, costs[best]};
}

void check_levels(const std::vector<cv::Mat>& levels, const char* which) {
  FLEETSLAM_CHECK(!levels.empty(), std::string("match_stereo: no ") + which + " image");
  for (const cv::Mat& level : levels) {
    FLEETSLAM_CHECK(level.type() == CV_8UC1, std::string("match_stereo: the ") + which + " pyramid must be CV_8UC1");
  }
}

// ORB-SLAM's last step: drop matches whose SAD is far above the median (a wrong or occluded window).
int reject_sad_outliers(Frame& left, std::vector<std::pair<float, int>>& sads, double factor) {
  if (sads.empty()) return 0;
  std::vector<float> values;
  for (const auto& s : sads) values.push_back(s.first);
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  const double threshold = factor * static_cast<double>(*mid);
  int kept = 0;
  for (const auto& [cost, i] : sads) {
    if (static_cast<double>(cost) > threshold) {
      left.depth_m[static_cast<std::size_t>(i)] = -1.0;
      left.u_right[static_cast<std::size_t>(i)] = -1.0;
    } else {
      ++kept;
    }
  }
  return kept;
}

}  // namespace

int match_stereo_levels(Frame& left, const std::vector<cv::Mat>& left_levels,
                        const std::vector<cv::KeyPoint>& right_keypoints, const cv::Mat& right_descriptors,
                        const std::vector<cv::Mat>& right_levels, const StereoMatchConfig& config) {
  const std::size_t n = left.keypoints.size();
  left.depth_m.assign(n, -1.0);
  left.u_right.assign(n, -1.0);
  FLEETSLAM_CHECK(left.bf > 0.0, "match_stereo: the left frame needs bf > 0");
  FLEETSLAM_CHECK(static_cast<std::size_t>(left.descriptors.rows) == n || n == 0,
                  "match_stereo: one descriptor per left keypoint");
  FLEETSLAM_CHECK(static_cast<std::size_t>(right_descriptors.rows) == right_keypoints.size() || right_keypoints.empty(),
                  "match_stereo: one descriptor per right keypoint");
  check_levels(left_levels, "left");
  check_levels(right_levels, "right");
  FLEETSLAM_CHECK(left_levels[0].size() == right_levels[0].size(), "match_stereo: left and right sizes differ");
  if (n == 0 || right_keypoints.empty()) return 0;

  const cv::Size size0 = left_levels[0].size();
  const std::vector<std::vector<int>> by_row =
      index_rows(right_keypoints, left.pyramid, size0.height, config.row_band_scales);
  const double max_disparity = left.bf / config.min_depth_m;
  std::vector<std::pair<float, int>> sads;
  for (std::size_t i = 0; i < n; ++i) {
    const cv::KeyPoint& k = left.keypoints[i];
    const auto row = static_cast<long>(std::lround(static_cast<double>(k.pt.y)));
    const auto level = static_cast<std::size_t>(k.octave);
    if (row < 0 || row >= size0.height || k.octave < 0 || level >= left_levels.size() || level >= right_levels.size()) {
      continue;
    }
    const Candidate match = best_on_row(k, left.descriptors.ptr<std::uint8_t>(static_cast<int>(i)),
                                        by_row[static_cast<std::size_t>(row)], right_keypoints, right_descriptors,
                                        max_disparity, config.max_distance);
    if (match.right < 0) continue;
    const double u_right0 = static_cast<double>(right_keypoints[static_cast<std::size_t>(match.right)].pt.x);
    const Refined refined = refine(k, u_right0, left_levels[level], right_levels[level], size0, config);
    if (!refined.ok) continue;
    const double disparity = static_cast<double>(k.pt.x) - refined.u_right;
    if (!(disparity > 0.0 && disparity < max_disparity)) continue;
    left.depth_m[i] = left.bf / disparity;
    left.u_right[i] = refined.u_right;
    sads.emplace_back(refined.sad, static_cast<int>(i));
  }
  return reject_sad_outliers(left, sads, config.outlier_median_factor);
}

int match_stereo(Frame& left, const cv::Mat& left_image, const std::vector<cv::KeyPoint>& right_keypoints,
                 const cv::Mat& right_descriptors, const cv::Mat& right_image, const StereoMatchConfig& config) {
  FLEETSLAM_CHECK(left_image.type() == CV_8UC1 && right_image.type() == CV_8UC1,
                  "match_stereo: images must be CV_8UC1");
  return match_stereo_levels(left, build_image_pyramid(left_image, left.pyramid), right_keypoints, right_descriptors,
                             build_image_pyramid(right_image, left.pyramid), config);
}

int assign_rgbd_depth(Frame& frame, const cv::Mat& depth_m, double min_depth_m, double max_depth_m) {
  FLEETSLAM_CHECK(depth_m.type() == CV_32FC1, "assign_rgbd_depth: depth must be CV_32FC1 (metres)");
  const std::size_t n = frame.keypoints.size();
  FLEETSLAM_CHECK(frame.uv.size() == n, "assign_rgbd_depth: one uv per keypoint");
  frame.depth_m.assign(n, -1.0);
  frame.u_right.assign(n, -1.0);
  int assigned = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const long x = std::lround(static_cast<double>(frame.keypoints[i].pt.x));
    const long y = std::lround(static_cast<double>(frame.keypoints[i].pt.y));
    if (x < 0 || y < 0 || x >= depth_m.cols || y >= depth_m.rows) continue;
    const auto d = static_cast<double>(depth_m.at<float>(static_cast<int>(y), static_cast<int>(x)));
    // Written so that NaN fails: 0 means "no measurement" and falls below any positive minimum.
    if (!(d >= min_depth_m && d <= max_depth_m) || !(d > 0.0)) continue;
    frame.depth_m[i] = d;
    if (frame.bf > 0.0) frame.u_right[i] = frame.uv[i].x() - frame.bf / d;
    ++assigned;
  }
  return assigned;
}

}  // namespace fleetslam::slam
