#include "fleetslam/slam/orb_extractor.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "fleetslam/core/error.hpp"

namespace fleetslam::slam {
namespace {

constexpr int kOrbPatchSizePx = 31;  // ORB's descriptor patch (and the keypoint size at level 0)
constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

// The detection area of a level image: [x0, x1) x [y0, y1).
struct Area {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  int width() const { return x1 - x0; }
  int height() const { return y1 - y0; }
  bool contains(const cv::Point2f& p) const {
    return p.x >= static_cast<float>(x0) && p.x < static_cast<float>(x1) && p.y >= static_cast<float>(y0) &&
           p.y < static_cast<float>(y1);
  }
};

cv::Mat to_gray(const cv::Mat& image) {
  if (image.type() == CV_8UC1) return image;
  cv::Mat gray;
  if (image.type() == CV_8UC3) {
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  } else if (image.type() == CV_8UC4) {
    cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY);
  } else {
    throw InputError("OrbExtractor::extract", "unsupported image type " + std::to_string(image.type()) +
                                                  " (need 8-bit gray, BGR or BGRA)");
  }
  return gray;
}

// FAST (9/16, non-maximum suppression) at `threshold` on the window of `level` that covers `area` plus
// a margin, keeping the corners inside `area`. FAST skips 3 pixels at a window's border and suppression
// compares each corner with its 8 neighbours, so a 4-pixel margin makes the corners inside `area`
// exactly those of FAST on the whole level.
void fast_in_area(const cv::Mat& level, const Area& area, int threshold, std::vector<cv::KeyPoint>& out) {
  constexpr int kMarginPx = 4;
  const cv::Rect window = cv::Rect(area.x0 - kMarginPx, area.y0 - kMarginPx, area.width() + 2 * kMarginPx,
                                   area.height() + 2 * kMarginPx) &
                          cv::Rect(0, 0, level.cols, level.rows);
  std::vector<cv::KeyPoint> found;
  cv::FAST(level(window), found, threshold, true, cv::FastFeatureDetector::TYPE_9_16);
  const cv::Point2f offset(static_cast<float>(window.x), static_cast<float>(window.y));
  for (cv::KeyPoint& k : found) {
    k.pt += offset;
    if (area.contains(k.pt)) out.push_back(k);
  }
}

// The cells of a detection area: cols x rows cells of about cell_size_px, the last ones cut at the area.
struct CellGrid {
  Area area;
  int cols = 1, rows = 1, cell_w = 1, cell_h = 1;

  CellGrid(const Area& a, int cell_size_px)
      : area(a),
        cols(std::max(1, a.width() / cell_size_px)),
        rows(std::max(1, a.height() / cell_size_px)),
        cell_w((a.width() + cols - 1) / cols),
        cell_h((a.height() + rows - 1) / rows) {}
  std::size_t size() const { return static_cast<std::size_t>(cols * rows); }
  std::size_t index_of(const cv::Point2f& p) const {
    return static_cast<std::size_t>(((static_cast<int>(p.y) - area.y0) / cell_h) * cols +
                                    (static_cast<int>(p.x) - area.x0) / cell_w);
  }
  // Cells [first, last] of one row of cells, as one area.
  Area cells(int row, int first, int last) const {
    const int y0 = area.y0 + row * cell_h;
    return {area.x0 + first * cell_w, y0, std::min(area.x0 + (last + 1) * cell_w, area.x1), std::min(y0 + cell_h, area.y1)};
  }
};

// With more empty cells than this share, one low-threshold pass over the whole level is cheaper than
// passes over the empty cells; both give the same corners.
constexpr double kWholeLevelFallbackShare = 0.5;

// FAST corners of the detection area: per cell, those with a score >= ini_fast_threshold, or, in a cell
// without any, those >= min_fast_threshold. One pass at the high threshold over the whole area, then a
// low-threshold pass per empty cell, or over the whole area when many cells are empty (FAST's corners
// at a threshold t are exactly its corners at a lower threshold with a score >= t).
std::vector<cv::KeyPoint> detect_corners(const cv::Mat& level, const Area& area, const OrbExtractorConfig& config) {
  std::vector<cv::KeyPoint> corners;
  if (area.width() <= 0 || area.height() <= 0) return corners;
  fast_in_area(level, area, config.ini_fast_threshold, corners);
  const CellGrid grid(area, config.cell_size_px);
  std::vector<bool> strong(grid.size(), false);
  for (const cv::KeyPoint& k : corners) strong[grid.index_of(k.pt)] = true;
  const auto empty = static_cast<std::size_t>(std::count(strong.begin(), strong.end(), false));
  if (empty == 0) return corners;
  if (static_cast<double>(empty) > kWholeLevelFallbackShare * static_cast<double>(grid.size())) {
    std::vector<cv::KeyPoint> weak;
    fast_in_area(level, area, config.min_fast_threshold, weak);
    for (const cv::KeyPoint& k : weak) {
      if (!strong[grid.index_of(k.pt)]) corners.push_back(k);
    }
    return corners;
  }
  // Runs of empty cells along a row share one FAST call: each call has a fixed cost.
  for (int row = 0; row < grid.rows; ++row) {
    for (int first = 0; first < grid.cols;) {
      if (strong[static_cast<std::size_t>(row * grid.cols + first)]) {
        ++first;
        continue;
      }
      int last = first;
      while (last + 1 < grid.cols && !strong[static_cast<std::size_t>(row * grid.cols + last + 1)]) ++last;
      fast_in_area(level, grid.cells(row, first, last), config.min_fast_threshold, corners);
      first = last + 1;
    }
  }
  return corners;
}

// A node of the distribution quadtree: a half-open box and the corners inside it.
struct Node {
  double x0, y0, x1, y1;
  std::vector<int> points;
  bool splittable() const { return points.size() > 1 && std::max(x1 - x0, y1 - y0) > 1.0; }
};

// The non-empty quarters of a node.
std::vector<Node> split(const Node& node, const std::vector<cv::KeyPoint>& corners) {
  const double xm = 0.5 * (node.x0 + node.x1);
  const double ym = 0.5 * (node.y0 + node.y1);
  std::vector<Node> children{{node.x0, node.y0, xm, ym, {}}, {xm, node.y0, node.x1, ym, {}},
                             {node.x0, ym, xm, node.y1, {}}, {xm, ym, node.x1, node.y1, {}}};
  for (const int i : node.points) {
    const cv::Point2f& p = corners[static_cast<std::size_t>(i)].pt;
    const std::size_t q = (static_cast<double>(p.x) < xm ? 0u : 1u) + (static_cast<double>(p.y) < ym ? 0u : 2u);
    children[q].points.push_back(i);
  }
  children.erase(std::remove_if(children.begin(), children.end(), [](const Node& n) { return n.points.empty(); }),
                 children.end());
  return children;
}

// Splits nodes, the most populated first, until there are at least `target` nodes. Returns false
// when nothing could be split.
bool split_largest_first(std::vector<Node>& nodes, const std::vector<cv::KeyPoint>& corners, std::size_t target) {
  std::vector<std::size_t> order(nodes.size());
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return nodes[a].points.size() > nodes[b].points.size(); });
  std::vector<Node> result;
  std::vector<bool> replaced(nodes.size(), false);
  std::size_t count = nodes.size();
  bool any = false;
  for (const std::size_t i : order) {
    if (count >= target) break;
    if (!nodes[i].splittable()) continue;
    std::vector<Node> children = split(nodes[i], corners);
    count += children.size() - 1;
    replaced[i] = true;
    any = true;
    for (Node& c : children) result.push_back(std::move(c));
  }
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    if (!replaced[i]) result.push_back(std::move(nodes[i]));
  }
  nodes = std::move(result);
  return any;
}

// One round that splits every splittable node; false (nodes untouched) when that would give more than
// `target` nodes or nothing can be split.
bool split_all(std::vector<Node>& nodes, const std::vector<cv::KeyPoint>& corners, std::size_t target) {
  std::vector<Node> next;
  bool any = false;
  for (const Node& node : nodes) {
    if (!node.splittable()) {
      next.push_back(node);
      continue;
    }
    any = true;
    for (Node& c : split(node, corners)) next.push_back(std::move(c));
  }
  if (!any || next.size() > target) return false;
  nodes = std::move(next);
  return true;
}

// ORB-SLAM's distribution: split the area into square-ish root nodes, then quarter nodes holding more
// than one corner until there are `target` nodes (or no node can be split); each node keeps its
// strongest corner. Returns indices into `corners`, at most `target`.
std::vector<int> distribute(const std::vector<cv::KeyPoint>& corners, const Area& area, int target) {
  if (target <= 0 || corners.empty()) return {};
  const auto wanted = static_cast<std::size_t>(target);
  const int roots = std::max(1, static_cast<int>(std::lround(static_cast<double>(area.width()) / area.height())));
  const double root_w = static_cast<double>(area.width()) / roots;
  std::vector<Node> nodes;
  for (int r = 0; r < roots; ++r) {
    nodes.push_back({area.x0 + r * root_w, static_cast<double>(area.y0), area.x0 + (r + 1) * root_w,
                     static_cast<double>(area.y1), {}});
  }
  for (std::size_t i = 0; i < corners.size(); ++i) {
    const auto r = std::min(roots - 1, static_cast<int>((static_cast<double>(corners[i].pt.x) - area.x0) / root_w));
    nodes[static_cast<std::size_t>(r)].points.push_back(static_cast<int>(i));
  }
  nodes.erase(std::remove_if(nodes.begin(), nodes.end(), [](const Node& n) { return n.points.empty(); }),
              nodes.end());
  while (nodes.size() < wanted) {
    if (split_all(nodes, corners, wanted)) continue;
    if (!split_largest_first(nodes, corners, wanted)) break;
  }
  std::vector<int> best;
  for (const Node& node : nodes) {
    // Ties go to the first corner in FAST's (row-major) order, which keeps the result deterministic.
    best.push_back(*std::max_element(node.points.begin(), node.points.end(), [&](int a, int b) {
      return corners[static_cast<std::size_t>(a)].response < corners[static_cast<std::size_t>(b)].response;
    }));
  }
  if (best.size() > wanted) {
    std::stable_sort(best.begin(), best.end(), [&](int a, int b) {
      return corners[static_cast<std::size_t>(a)].response > corners[static_cast<std::size_t>(b)].response;
    });
    best.resize(wanted);
  }
  return best;
}

// Half-widths of the rows of the orientation disc: pixels with x^2 + y^2 <= r^2 + r, i.e. within
// r + 1/2 of the centre; the set is symmetric under x <-> y, so rotating the image by 90 degrees
// rotates the measured angle by exactly 90 degrees.
std::vector<int> disc_half_widths() {
  const int r = kOrbOrientationRadiusPx;
  std::vector<int> half(static_cast<std::size_t>(r) + 1);
  for (int v = 0; v <= r; ++v) {
    int u = 0;
    while ((u + 1) * (u + 1) + v * v <= r * r + r) ++u;
    half[static_cast<std::size_t>(v)] = u;
  }
  return half;
}

// Intensity-centroid orientation (Rosin; ORB): the angle of the vector from the corner to the
// centroid of the disc around it, in degrees [0, 360). The corner lies >= r pixels from the border.
float orientation_deg(const cv::Mat& level, int x, int y, const std::vector<int>& half) {
  // |moments| <= 15 * 255 * 709 pixels: int is enough.
  int m10 = 0, m01 = 0;
  for (int v = -kOrbOrientationRadiusPx; v <= kOrbOrientationRadiusPx; ++v) {
    const std::uint8_t* row = level.ptr<std::uint8_t>(y + v) + x;
    const int w = half[static_cast<std::size_t>(std::abs(v))];
    int row_sum = 0;
    for (int u = -w; u <= w; ++u) {
      m10 += u * row[u];
      row_sum += row[u];
    }
    m01 += v * row_sum;
  }
  double angle = std::atan2(static_cast<double>(m01), static_cast<double>(m10)) * kRadToDeg;
  if (angle < 0.0) angle += 360.0;
  // A value just below 360 can round to 360.0f: keep the documented range.
  const auto deg = static_cast<float>(angle);
  return deg >= 360.0f ? 0.0f : deg;
}

// rBRIEF descriptors of level keypoints (level coordinates) by cv::ORB on this level image alone (it
// blurs the image with ORB's 7x7 Gaussian and uses our angles). cv::ORB drops keypoints within its
// edge threshold of the border; ours are kept outside it, but each keypoint carries its index in
// class_id so that a dropped one is found and removed instead of shifting descriptors onto the wrong
// keypoints. Returns the keypoints that got a descriptor, in their original order.
std::vector<cv::KeyPoint> describe(const cv::Mat& level, std::vector<cv::KeyPoint> keypoints, cv::Mat& descriptors) {
  for (std::size_t i = 0; i < keypoints.size(); ++i) {
    keypoints[i].octave = 0;
    keypoints[i].class_id = static_cast<int>(i);
  }
  const std::size_t before = keypoints.size();
  cv::Ptr<cv::ORB> orb = cv::ORB::create(static_cast<int>(before), 1.2f, 1, kOrbEdgePx, 0, 2, cv::ORB::HARRIS_SCORE,
                                         kOrbPatchSizePx);
  orb->compute(level, keypoints, descriptors);
  FLEETSLAM_CHECK(static_cast<std::size_t>(descriptors.rows) == keypoints.size() || keypoints.empty(),
                  "cv::ORB returned descriptors for other keypoints than it kept");
  // cv::ORB keeps the order of the keypoints it does not drop: check it, since everything relies on it.
  for (std::size_t i = 1; i < keypoints.size(); ++i) {
    FLEETSLAM_CHECK(keypoints[i - 1].class_id < keypoints[i].class_id, "cv::ORB reordered the keypoints");
  }
  return keypoints;
}

Area detection_area(const cv::Mat& level) {
  return {kOrbEdgePx, kOrbEdgePx, level.cols - kOrbEdgePx, level.rows - kOrbEdgePx};
}

}  // namespace

std::vector<cv::KeyPoint> detect_level_corners(const cv::Mat& level, const OrbExtractorConfig& config) {
  FLEETSLAM_CHECK(level.type() == CV_8UC1, "detect_level_corners needs an 8-bit gray image");
  return detect_corners(level, detection_area(level), config);
}

std::vector<cv::Mat> build_image_pyramid(const cv::Mat& gray, const ScalePyramid& pyramid) {
  FLEETSLAM_CHECK(gray.type() == CV_8UC1 && !gray.empty(), "build_image_pyramid needs a non-empty 8-bit gray image");
  std::vector<cv::Mat> levels{gray};
  for (int l = 1; l < pyramid.levels; ++l) {
    const double inv = pyramid.inv_scale[static_cast<std::size_t>(l)];
    const cv::Size size(std::max(1, static_cast<int>(std::lround(gray.cols * inv))),
                        std::max(1, static_cast<int>(std::lround(gray.rows * inv))));
    cv::Mat level;
    cv::resize(levels.back(), level, size, 0.0, 0.0, cv::INTER_LINEAR);
    levels.push_back(level);
  }
  return levels;
}

cv::Point2d to_level(const cv::Point2d& p0, const cv::Size& size0, const cv::Size& level_size) {
  const double rx = static_cast<double>(level_size.width) / size0.width;
  const double ry = static_cast<double>(level_size.height) / size0.height;
  return {(p0.x + 0.5) * rx - 0.5, (p0.y + 0.5) * ry - 0.5};
}

cv::Point2d to_level0(const cv::Point2d& p, const cv::Size& size0, const cv::Size& level_size) {
  const double rx = static_cast<double>(level_size.width) / size0.width;
  const double ry = static_cast<double>(level_size.height) / size0.height;
  return {(p.x + 0.5) / rx - 0.5, (p.y + 0.5) / ry - 0.5};
}

OrbExtractor::OrbExtractor(const OrbExtractorConfig& config) : config_(config) {
  if (config.num_features < 1 || config.num_levels < 1 || !(config.scale_factor > 1.0) || config.cell_size_px < 1 ||
      config.min_fast_threshold < 1) {
    throw InputError("orb", "num_features, num_levels, cell_size_px and the FAST thresholds must be positive and "
                            "scale_factor > 1");
  }
  if (config.min_fast_threshold > config.ini_fast_threshold) {
    throw InputError("orb.min_fast_threshold", "must not exceed ini_fast_threshold (" +
                                                   std::to_string(config.ini_fast_threshold) + "), got " +
                                                   std::to_string(config.min_fast_threshold));
  }
  pyramid_ = ScalePyramid::make(config.num_levels, config.scale_factor);
  // Geometric shares: level l gets N (1 - q) q^l / (1 - q^L) with q = 1 / scale_factor, the last the rest.
  const double q = 1.0 / config.scale_factor;
  double share = config.num_features * (1.0 - q) / (1.0 - std::pow(q, config.num_levels));
  int assigned = 0;
  for (int l = 0; l + 1 < config.num_levels; ++l, share *= q) {
    const int n = std::min(config.num_features - assigned, static_cast<int>(std::lround(share)));
    features_per_level_.push_back(n);
    assigned += n;
  }
  features_per_level_.push_back(config.num_features - assigned);
}

OrbFeatures OrbExtractor::extract(const cv::Mat& image) const {
  OrbFeatures out;
  if (image.empty()) return out;
  out.levels = build_image_pyramid(to_gray(image), pyramid_);
  const std::vector<int> half = disc_half_widths();
  std::vector<cv::Mat> level_descriptors;
  for (int l = 0; l < pyramid_.levels; ++l) {
    const cv::Mat& level = out.levels[static_cast<std::size_t>(l)];
    const Area area = detection_area(level);
    if (area.width() <= 0 || area.height() <= 0) continue;  // the level is too small for any corner
    const std::vector<cv::KeyPoint> corners = detect_corners(level, area, config_);
    std::vector<cv::KeyPoint> chosen;
    for (const int i : distribute(corners, area, features_per_level_[static_cast<std::size_t>(l)])) {
      cv::KeyPoint k = corners[static_cast<std::size_t>(i)];
      k.angle = orientation_deg(level, static_cast<int>(k.pt.x), static_cast<int>(k.pt.y), half);
      chosen.push_back(k);
    }
    if (chosen.empty()) continue;
    cv::Mat descriptors;
    const std::vector<cv::KeyPoint> described = describe(level, chosen, descriptors);
    const double size = kOrbPatchSizePx * pyramid_.scale[static_cast<std::size_t>(l)];
    for (cv::KeyPoint k : described) {
      const cv::Point2d p0 = to_level0(cv::Point2d(k.pt), out.levels[0].size(), level.size());
      k.pt = cv::Point2f(static_cast<float>(p0.x), static_cast<float>(p0.y));
      k.octave = l;
      k.size = static_cast<float>(size);
      k.class_id = -1;
      out.keypoints.push_back(k);
    }
    if (!described.empty()) level_descriptors.push_back(descriptors);
  }
  if (!level_descriptors.empty()) cv::vconcat(level_descriptors, out.descriptors);
  return out;
}

}  // namespace fleetslam::slam
