#pragma once
// A frame as the agent sees it: ORB features with undistorted coordinates, per-feature depth (RGB-D or
// stereo), a grid for radius search, and the map points its features are matched to.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

#include "fleetslam/core/camera.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/core/time.hpp"

namespace fleetslam::slam {

using MapPointId = std::int64_t;
using KeyframeId = std::int64_t;
inline constexpr MapPointId kNoMapPoint = -1;

// Scale of each pyramid level: scale[l] = scale_factor^l; sigma2[l] = scale[l]^2 (the variance of a
// keypoint's position at that level, in level-0 pixels^2). make() throws std::invalid_argument for
// levels < 1 or a scale_factor that is not finite and >= 1.
struct ScalePyramid {
  int levels = 8;
  double scale_factor = 1.2;
  std::vector<double> scale;
  std::vector<double> inv_scale;
  std::vector<double> sigma2;
  std::vector<double> inv_sigma2;

  static ScalePyramid make(int levels, double scale_factor);
};

// The region undistorted pixel coordinates of an image can fall in: [min_u, max_u) x [min_v, max_v).
struct ImageBounds {
  double min_u = 0.0;
  double max_u = 0.0;
  double min_v = 0.0;
  double max_v = 0.0;

  bool empty() const { return !(max_u > min_u && max_v > min_v); }
  // The pixel area of a distortion-free image: [-0.5, width - 0.5) x [-0.5, height - 0.5).
  static ImageBounds of_image(int width, int height);
};

// Bounding box of the raw image's border (sampled every few pixels, pixel edges included) mapped into
// the undistorted camera: every raw pixel undistorts inside it (ORB-SLAM undistorts only the four
// corners, which cuts off the bulging edges of barrel distortion). Border points whose undistortion
// fails are skipped; a camera without distortion gives ImageBounds::of_image.
ImageBounds undistorted_image_bounds(const core::PinholeCamera& raw);

namespace detail {
// Which of four consecutive grid entries lie in a query's area (bit k: entry k), with the arithmetic of
// the scalar test: (u - qu)^2 + (v - qv)^2 <= r2 in doubles, lowest <= level <= highest. The portable
// version, and the SSE2 one FeatureGrid::visit_area uses where the compiler targets SSE2 (every x86-64);
// tests check that they agree.
inline int in_area_mask4_portable(const double* u, const double* v, const int* level, double qu, double qv, double r2,
                                  int lowest, int highest) {
  int mask = 0;
  for (int k = 0; k < 4; ++k) {
    const double du = u[k] - qu;
    const double dv = v[k] - qv;
    const bool in = du * du + dv * dv <= r2 && level[k] >= lowest && level[k] <= highest;
    mask |= static_cast<int>(in) << k;
  }
  return mask;
}
#if defined(__SSE2__)
inline int in_area_mask4_sse2(const double* u, const double* v, const int* level, double qu, double qv, double r2,
                              int lowest, int highest) {
  const __m128d q_u = _mm_set1_pd(qu);
  const __m128d q_v = _mm_set1_pd(qv);
  const __m128d radius2 = _mm_set1_pd(r2);
  const __m128d du01 = _mm_sub_pd(_mm_loadu_pd(u), q_u);
  const __m128d du23 = _mm_sub_pd(_mm_loadu_pd(u + 2), q_u);
  const __m128d dv01 = _mm_sub_pd(_mm_loadu_pd(v), q_v);
  const __m128d dv23 = _mm_sub_pd(_mm_loadu_pd(v + 2), q_v);
  const __m128d d01 = _mm_add_pd(_mm_mul_pd(du01, du01), _mm_mul_pd(dv01, dv01));
  const __m128d d23 = _mm_add_pd(_mm_mul_pd(du23, du23), _mm_mul_pd(dv23, dv23));
  const int near = _mm_movemask_pd(_mm_cmple_pd(d01, radius2)) | (_mm_movemask_pd(_mm_cmple_pd(d23, radius2)) << 2);
  const __m128i l = _mm_loadu_si128(reinterpret_cast<const __m128i*>(level));
  const __m128i outside = _mm_or_si128(_mm_cmplt_epi32(l, _mm_set1_epi32(lowest)), _mm_cmpgt_epi32(l, _mm_set1_epi32(highest)));
  return near & ~_mm_movemask_ps(_mm_castsi128_ps(outside)) & 0xF;
}
#endif
inline int in_area_mask4(const double* u, const double* v, const int* level, double qu, double qv, double r2, int lowest,
                         int highest) {
#if defined(__SSE2__)
  return in_area_mask4_sse2(u, v, level, qu, qv, r2, lowest, highest);
#else
  return in_area_mask4_portable(u, v, level, qu, qv, r2, lowest, highest);
#endif
}
}  // namespace detail

// Buckets of features over the undistorted image for radius queries (ORB-SLAM's 64x48 grid). Stored
// contiguously (compressed rows): the entries of all cells in one sequence, cell by cell in row-major
// order and by ascending feature index within a cell, with each cell's start; a query reads one slice per
// grid row. Each entry holds a copy of its feature's index, position and level (structure of arrays), so
// that visit_area reads its slices front to back, four entries at a time (SIMD). The grid therefore
// describes the uv and levels it was built from: build it again when they change.
class FeatureGrid {
 public:
  FeatureGrid() = default;
  // Features outside [min_u, max_u) x [min_v, max_v) (and non-finite ones) are not indexed. An empty
  // area (max <= min) is widened to one pixel so that the grid stays valid. `level` has one entry per
  // feature, or none: then queries cannot bound the level (unless there are no features).
  FeatureGrid(const std::vector<Eigen::Vector2d>& uv, const std::vector<int>& level, double min_u, double max_u,
              double min_v, double max_v, int cols = 64, int rows = 48);
  FeatureGrid(const std::vector<Eigen::Vector2d>& uv, const std::vector<int>& level, const ImageBounds& bounds,
              int cols = 64, int rows = 48)
      : FeatureGrid(uv, level, bounds.min_u, bounds.max_u, bounds.min_v, bounds.max_v, cols, rows) {}

  // Indices of indexed features at distance <= radius_px of (u, v) (cells overlapping the query square,
  // then the exact distance), optionally only those whose level is in [min_level, max_level] (-1: no
  // bound). Sorted ascending. A non-finite query or a negative radius gives no features.
  std::vector<int> features_in_area(double u, double v, double radius_px, int min_level = -1, int max_level = -1) const;
  // The same features, appended to `found` (its contents are kept; no allocation once its capacity
  // suffices, so one vector can serve many queries) in grid order: by cell row, then cell column,
  // ascending within a cell, so NOT sorted across cells (sort the appended range for index order).
  // Returns how many were appended.
  std::size_t features_in_area(double u, double v, double radius_px, int min_level, int max_level,
                               std::vector<int>& found) const;
  // features_in_area's features, offered in grid order as visit(index), without a list in between: the
  // entries of each slice are tested four at a time and only those in the area are visited. For callers
  // with work on few candidates. Inline (below).
  template <class Visit>
  void visit_area(double u, double v, double radius_px, int min_level, int max_level, Visit&& visit) const;
  // visit_area in two steps, for a caller with many queries: prepare_area finds a query's cells (false
  // where visit_area would visit nothing) and visit_prepared visits its features as visit_area does. A
  // caller that prepares all its queries first keeps the arithmetic of finding the cells apart from the
  // loads of visiting them. An Area holds cell indices of the grid that prepared it: visit it with that
  // grid only (unchanged since), never with another.
  struct Area {
    double u = 0.0, v = 0.0, r2 = 0.0;   // centre and squared radius (px)
    int lowest = 0, highest = 0;          // level window (int limits where unbounded)
    int x0 = 0, x1 = 0, y0 = 0, y1 = 0;   // cells x0..x1 by y0..y1
  };
  bool prepare_area(double u, double v, double radius_px, int min_level, int max_level, Area& area) const;
  template <class Visit>
  void visit_prepared(const Area& area, Visit&& visit) const;
  // Every indexed feature of the cells that the query square overlaps, offered in grid order as
  // visit(index, in_area), where in_area says whether it is one of features_in_area's (distance <=
  // radius_px, level within the bounds). For callers that fold the test into their own per-candidate work
  // without branching on it: which features pass is unpredictable, and a mispredicted branch costs more
  // than a little work on a feature that does not count. Nothing is visited when features_in_area would
  // return nothing for want of a valid query, level window or grid. Inline (below).
  // Each feature's position and level are read by its index from `uv` and `level`, the vectors the grid
  // was built from (`level` empty when it was built without levels), not from the grid's entries: its
  // reads then depend on the index alone, as its descriptor's do. Stage 1 of the projection matcher, the
  // caller, measured about 5 % slower reading the entries.
  template <class Visit>
  void scan_area(const std::vector<Eigen::Vector2d>& uv, const std::vector<int>& level, double u, double v,
                 double radius_px, int min_level, int max_level, Visit&& visit) const;
  bool empty() const { return cell_start_.empty(); }
  // How many features the grid was built from (indexed or not): its indices are below this.
  std::size_t features() const { return built_from_; }
  // Same cells, bounds and entries (map files are compared with it).
  bool operator==(const FeatureGrid& o) const {
    return cols_ == o.cols_ && rows_ == o.rows_ && std::memcmp(&min_u_, &o.min_u_, sizeof min_u_) == 0 &&
           std::memcmp(&min_v_, &o.min_v_, sizeof min_v_) == 0 && std::memcmp(&cell_w_, &o.cell_w_, sizeof cell_w_) == 0 &&
           std::memcmp(&cell_h_, &o.cell_h_, sizeof cell_h_) == 0 && has_levels_ == o.has_levels_ &&
           built_from_ == o.built_from_ &&
           cell_start_ == o.cell_start_ && index_ == o.index_ && level_ == o.level_ && same_bits(u_, o.u_) &&
           same_bits(v_, o.v_);
  }

 private:
  // The query's cells [x0, x1] x [y0, y1], as the constructor assigns features to cells, and its level
  // window [lowest, highest] (an unbounded side: the int limit); false when the grid is empty, the query
  // invalid (non-finite centre, negative radius), the level window empty or the square misses the grid.
  // Checks that level bounds come with a grid built with levels.
  struct Cells {
    int x0 = 0, x1 = 0, y0 = 0, y1 = 0;
    int lowest = 0, highest = 0;
  };
  bool query_cells(double u, double v, double radius_px, int min_level, int max_level, Cells& cells) const;
  // Cell range along one axis: the cells floor((lo - origin) / cell_size) .. floor((hi - origin) /
  // cell_size), clamped to [0, count - 1], as the constructor assigns features to cells; false when
  // [lo, hi] misses the grid. Multiplied by the reciprocal instead of divided (the divisions were a
  // measurable share of a small query): the product can differ from the quotient in the last bits, so
  // the range is widened by kCellSlack cells on each side, far more than that rounding and far less than
  // a cell. At worst a neighbouring cell is scanned whose features then fail the exact distance test.
  // Clamping makes floor unnecessary (truncation where the value is >= 0).
  static bool cell_range(double lo, double hi, double origin, double inv_cell_size, int count, int& first,
                         int& last) {
    const double from = (lo - origin) * inv_cell_size - kCellSlack;
    const double to = (hi - origin) * inv_cell_size + kCellSlack;
    if (!(to >= 0.0 && from < count)) return false;
    first = from > 0.0 ? static_cast<int>(from) : 0;
    last = to < count - 1.0 ? static_cast<int>(to) : count - 1;
    return true;
  }
  // scan_area's loop over the query's cells (kCheckLevel: a level bound was given).
  template <bool kCheckLevel, class Visit>
  void scan_cells(const std::vector<Eigen::Vector2d>& uv, const std::vector<int>& level, double u, double v,
                  double r2, unsigned lowest, unsigned span, const Cells& c, Visit&& visit) const;
  static bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
    return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), sizeof(double) * a.size()) == 0);
  }
  static constexpr double kCellSlack = 1e-9;

  int cols_ = 0;
  int rows_ = 0;
  double min_u_ = 0.0, min_v_ = 0.0;
  double cell_w_ = 1.0, cell_h_ = 1.0;
  double inv_cell_w_ = 1.0, inv_cell_h_ = 1.0;  // 1 / cell_w_, 1 / cell_h_ (queries)
  bool has_levels_ = false;
  std::size_t built_from_ = 0;  // features in the uv the grid was built from
  // Cell c (row-major, y * cols + x) holds entries [cell_start_[c], cell_start_[c + 1]); cols * rows + 1
  // starts once built, none for a default-constructed grid.
  std::vector<int> cell_start_;
  // The entries: feature index, u, v and level (0 without levels), each followed by kGatherSlice spare
  // entries (scan_area's gathering and visit_area's four-wide reads run into them).
  std::vector<int> index_;
  std::vector<double> u_;
  std::vector<double> v_;
  std::vector<int> level_;
  // scan_area gathers the entries of slices kGatherSlice at a time into a buffer of kGatherMax.
  static constexpr int kGatherSlice = 16;
  static constexpr int kGatherMax = 256;
};

inline bool FeatureGrid::query_cells(double u, double v, double radius_px, int min_level, int max_level,
                                     Cells& cells) const {
  if (cell_start_.empty() || !(std::isfinite(u) && std::isfinite(v) && radius_px >= 0.0)) return false;
  FLEETSLAM_CHECK((min_level < 0 && max_level < 0) || has_levels_,
                  "FeatureGrid: level bounds need a grid built with one level per feature");
  cells.lowest = min_level >= 0 ? min_level : std::numeric_limits<int>::min();
  cells.highest = max_level >= 0 ? max_level : std::numeric_limits<int>::max();
  if (cells.lowest > cells.highest) return false;
  return cell_range(u - radius_px, u + radius_px, min_u_, inv_cell_w_, cols_, cells.x0, cells.x1) &&
         cell_range(v - radius_px, v + radius_px, min_v_, inv_cell_h_, rows_, cells.y0, cells.y1);
}

inline bool FeatureGrid::prepare_area(double u, double v, double radius_px, int min_level, int max_level,
                                      Area& area) const {
  Cells c;
  if (!query_cells(u, v, radius_px, min_level, max_level, c)) return false;
  area = Area{u, v, radius_px * radius_px, c.lowest, c.highest, c.x0, c.x1, c.y0, c.y1};
  return true;
}

template <class Visit>
void FeatureGrid::visit_area(double u, double v, double radius_px, int min_level, int max_level, Visit&& visit) const {
  Area area;
  if (prepare_area(u, v, radius_px, min_level, max_level, area)) visit_prepared(area, visit);
}

template <class Visit>
void FeatureGrid::visit_prepared(const Area& a, Visit&& visit) const {
  const int* row = cell_start_.data() + static_cast<std::ptrdiff_t>(a.y0) * cols_;
  for (int y = a.y0; y <= a.y1; ++y, row += cols_) {
    const int end = row[a.x1 + 1];
    for (int first = row[a.x0]; first < end; first += 4) {
      const auto f = static_cast<std::size_t>(first);
      // Entries past the slice (the next cells', or the spare ones) are masked off.
      const int valid = end - first >= 4 ? 0xF : (1 << (end - first)) - 1;
      int mask = detail::in_area_mask4(&u_[f], &v_[f], &level_[f], a.u, a.v, a.r2, a.lowest, a.highest) & valid;
      while (mask != 0) {
        const int k = __builtin_ctz(static_cast<unsigned>(mask));
        mask &= mask - 1;
        visit(index_[f + static_cast<std::size_t>(k)]);
      }
    }
  }
}

template <class Visit>
void FeatureGrid::scan_area(const std::vector<Eigen::Vector2d>& uv, const std::vector<int>& level, double u, double v,
                            double radius_px, int min_level, int max_level, Visit&& visit) const {
  Cells c;
  if (!query_cells(u, v, radius_px, min_level, max_level, c)) return;
  FLEETSLAM_CHECK(uv.size() == built_from_ && level.size() == (has_levels_ ? built_from_ : 0),
                  "FeatureGrid::scan_area: uv and level must be the vectors the grid was built from");
  // The level window [lowest, highest] as one unsigned comparison: level - lowest <= span (modulo 2^32),
  // made only when a bound is given.
  const double r2 = radius_px * radius_px;
  const auto lowest = static_cast<unsigned>(c.lowest);
  const unsigned span = static_cast<unsigned>(c.highest) - lowest;
  if (min_level >= 0 || max_level >= 0) {  // the grid has levels (query_cells checked)
    scan_cells<true>(uv, level, u, v, r2, lowest, span, c, visit);
  } else {
    scan_cells<false>(uv, level, u, v, r2, lowest, span, c, visit);
  }
}

template <bool kCheckLevel, class Visit>
void FeatureGrid::scan_cells(const std::vector<Eigen::Vector2d>& uv, const std::vector<int>& level, double u, double v,
                             double r2, unsigned lowest, unsigned span, const Cells& c, Visit&& visit) const {
  const Eigen::Vector2d* const points = uv.data();
  const int* const levels = level.data();
  const auto visit_one = [&](int i) {
    const auto k = static_cast<std::size_t>(i);
    const double du = points[k].x() - u;
    const double dv = points[k].y() - v;
    bool in_area = du * du + dv * dv <= r2;
    if constexpr (kCheckLevel) in_area = in_area & (static_cast<unsigned>(levels[k]) - lowest <= span);
    visit(i, in_area);
  };
  // Cells x0 .. x1 of a row are one contiguous slice of entries. The slices' feature indices are copied
  // into one buffer, kGatherSlice each whatever their length (the entries end in kGatherSlice spare ones
  // for the copy to run into), and visited in one loop: nested loops would mispredict the end of every
  // slice, as their lengths vary from query to query. A longer slice, or more than the buffer holds,
  // takes the nested loops (nothing has been visited then).
  const int* const indices = index_.data();
  const int* const first_row = cell_start_.data() + static_cast<std::ptrdiff_t>(c.y0) * cols_;
  int gathered[kGatherMax];
  int count = 0;
  bool all_gathered = true;
  const int* row = first_row;
  for (int y = c.y0; y <= c.y1; ++y, row += cols_) {
    const int begin = row[c.x0];
    const int length = row[c.x1 + 1] - begin;
    if (length > kGatherSlice || count > kGatherMax - kGatherSlice) {
      all_gathered = false;
      break;
    }
    std::memcpy(gathered + count, indices + begin, sizeof(int) * kGatherSlice);
    count += length;
  }
  if (all_gathered) {
    for (int j = 0; j < count; ++j) visit_one(gathered[j]);
    return;
  }
  row = first_row;
  for (int y = c.y0; y <= c.y1; ++y, row += cols_) {
    const int* const end = indices + row[c.x1 + 1];
    for (const int* it = indices + row[c.x0]; it != end; ++it) visit_one(*it);
  }
}

struct Frame {
  std::int64_t id = -1;
  core::TimeNs t_ns = 0;
  core::PinholeCamera camera;  // distortion-free intrinsics the undistorted coordinates live in
  ScalePyramid pyramid;
  double bf = 0.0;             // baseline * fx (stereo: real; RGB-D: virtual); 0 monocular
  double close_depth_m = 0.0;  // features nearer than this are "close" (ORB-SLAM ThDepth in metres); 0: all are
  ImageBounds bounds;          // where uv can lie (empty: finalize() uses camera's image area)

  // As detected in the image features were extracted from: the raw image, or the rectified left image
  // of a stereo rig that needed rectification (octave = level, angle in degrees).
  std::vector<cv::KeyPoint> keypoints;
  std::vector<Eigen::Vector2d> uv;      // undistorted pixel coordinates
  std::vector<int> level;               // pyramid level of each feature
  cv::Mat descriptors;                  // N x 32, CV_8UC1 (rBRIEF)
  std::vector<double> depth_m;          // depth along the optical axis; <= 0 when unknown
  // Right-image u (stereo, or virtual for RGB-D: u - bf / depth), meaningful where has_right(i) and then
  // possibly negative (a close point near the left edge); -1 elsewhere, but never test its sign.
  std::vector<double> u_right;
  FeatureGrid grid;

  std::vector<MapPointId> map_points;   // per feature, kNoMapPoint when unmatched
  std::vector<bool> outlier;            // per feature, set by pose optimisation

  std::optional<Eigen::Isometry3d> T_world_cam;  // estimated pose, once known

  std::size_t size() const { return uv.size(); }
  bool has_depth(std::size_t i) const { return depth_m[i] > 0.0; }
  // Feature i has a (real or virtual) right coordinate: a depth and a baseline.
  bool has_right(std::size_t i) const { return bf > 0.0 && has_depth(i); }
  // Camera-frame point of feature i from its depth and uv; nullopt without depth. i < size() (checked).
  std::optional<Eigen::Vector3d> unproject(std::size_t i) const;
  // Makes the per-feature vectors consistent and builds the grid: depth_m left empty is filled with
  // "unknown" (-1), u_right left empty with u - bf / depth where has_right(i) and -1 elsewhere, map_points/outlier are reset to one unmatched inlier entry per feature,
  // and the grid covers `bounds` (or the camera's image area when bounds is empty, or the features'
  // bounding box when the camera has no size). Throws InvariantError when keypoints, uv, level,
  // descriptors rows, depth_m or u_right disagree in size.
  void finalize();
};

}  // namespace fleetslam::slam
