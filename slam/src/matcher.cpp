// Descriptor matching between two frames (matcher.hpp): brute force, projection on A's feature grid and
// the paper's two-stage cross-validation (PAPER.md section 2, paper section 3.2). match_stereo and
// assign_rgbd_depth live with the front end.
#include "fleetslam/slam/matcher.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "fleetslam/core/error.hpp"

// Hamming distances are the inner loop of every matcher. Without -mpopcnt (never forced here, DESIGN.md)
// GCC turns __builtin_popcountll into a libgcc call; the functions that loop over descriptors are
// therefore cloned for CPUs with POPCNT and picked at load time (ifunc), with a portable default.
#if defined(__x86_64__) && defined(__linux__) && !defined(__POPCNT__) && defined(__has_attribute)
#if __has_attribute(target_clones)
#define FLEETSLAM_POPCNT_CLONES __attribute__((target_clones("popcnt", "default")))
#endif
#endif
#ifndef FLEETSLAM_POPCNT_CLONES
#define FLEETSLAM_POPCNT_CLONES
#endif
// The grid searches below pass their per-candidate work to FeatureGrid::scan_area or visit_area as a
// lambda: flattened
// into the POPCNT clones, or the lambda would be compiled on its own for the default CPU (a libgcc call
// per popcount).
#if defined(__has_attribute)
#if __has_attribute(flatten)
#define FLEETSLAM_FLATTEN __attribute__((flatten))
#endif
#endif
#ifndef FLEETSLAM_FLATTEN
#define FLEETSLAM_FLATTEN
#endif

namespace fleetslam::slam {
namespace {

constexpr int kDescriptorBytes = 32;
constexpr int kNoDistance = std::numeric_limits<int>::max();
constexpr int kHistogramBins = 30;
// A rotation bin far smaller than the largest one is noise, not a second consistent rotation.
constexpr double kMinBinShare = 0.1;
// Half-width of the pyramid-level window around the predicted level. 1.5 keeps ORB-SLAM's "predicted
// level +-1" for integer predictions and makes the window symmetric: when both frames' depths agree,
// stage 2's window (predicted from A's level) contains the level of the B feature stage 1 paired.
constexpr double kLevelWindow = 1.5;
// Distance ratios within scale_factor^+-kSameScaleShift predict less than half a level of change (with a
// wide margin for rounding), so the window is the feature's own level +-1: no square root, division or
// logarithm needed. Tested on squared distances within [kSquaredMin, kSquaredMax] (ratios stay finite).
constexpr double kSameScaleShift = 0.45;
constexpr double kSquaredMin = 1e-300;
constexpr double kSquaredMax = 1e300;

// Inlined into the POPCNT clones below, where the builtin becomes one instruction per word.
inline int descriptor_distance(const std::uint8_t* a, const std::uint8_t* b) {
  int distance = 0;
  for (int offset = 0; offset < kDescriptorBytes; offset += 8) {
    std::uint64_t wa = 0;
    std::uint64_t wb = 0;
    std::memcpy(&wa, a + offset, sizeof wa);  // memcpy: rows need not be 8-byte aligned
    std::memcpy(&wb, b + offset, sizeof wb);
    distance += __builtin_popcountll(wa ^ wb);
  }
  return distance;
}

// The closest and second-closest descriptor (on different features) among candidates.
struct Nearest {
  int index = -1;
  int distance = kNoDistance;
  int second_distance = kNoDistance;
};

// Ties keep the first candidate, so results do not depend on anything but the candidate order.
inline void offer(Nearest& nearest, int index, int distance) {
  if (distance < nearest.distance) {
    nearest.second_distance = nearest.distance;
    nearest.distance = distance;
    nearest.index = index;
  } else if (distance < nearest.second_distance) {
    nearest.second_distance = distance;
  }
}

FLEETSLAM_POPCNT_CLONES
Nearest nearest_of_all(const std::uint8_t* query, const cv::Mat& descriptors) {
  Nearest nearest;
  for (int i = 0; i < descriptors.rows; ++i) offer(nearest, i, descriptor_distance(query, descriptors.ptr<std::uint8_t>(i)));
  return nearest;
}

// ORB-SLAM's thresholds: an absolute distance bound, then best < nn_ratio * second best.
bool passes_thresholds(const Nearest& nearest, const MatcherConfig& config) {
  if (nearest.index < 0 || nearest.distance > config.max_distance) return false;
  if (nearest.second_distance == kNoDistance) return true;
  return static_cast<double>(nearest.distance) <= config.nn_ratio * static_cast<double>(nearest.second_distance);
}

void check_frame(const Frame& frame, const char* name, bool needs_angles) {
  const auto n = frame.size();
  const std::string which(name);
  FLEETSLAM_CHECK(frame.level.size() == n, "frame " + which + ": one level per feature");
  FLEETSLAM_CHECK(n == 0 || (frame.descriptors.rows == static_cast<int>(n) && frame.descriptors.cols == kDescriptorBytes &&
                             frame.descriptors.type() == CV_8UC1),
                  "frame " + which + ": descriptors must be N x 32 CV_8UC1");
  FLEETSLAM_CHECK(!needs_angles || frame.keypoints.size() == n,
                  "frame " + which + ": the rotation check needs one keypoint (angle) per feature");
  FLEETSLAM_CHECK(frame.grid.empty() || frame.grid.features() == n,
                  "frame " + which + ": its grid was built from another set of features (call finalize() again)");
  for (const int l : frame.level) {
    FLEETSLAM_CHECK(l >= 0 && static_cast<std::size_t>(l) < frame.pyramid.scale.size(),
                    "frame " + which + ": feature level outside the scale pyramid");
  }
}

// A frame being searched, with what every query into it needs computed once per call.
class SearchedFrame {
 public:
  // Where a camera-frame point projects and the pyramid levels its candidates may have.
  struct Query {
    double u = 0.0;
    double v = 0.0;
    int min_level = 0;
    int max_level = 0;
  };

  explicit SearchedFrame(const Frame& frame)
      : frame_(frame),
        area_(frame.bounds.empty() ? ImageBounds::of_image(frame.camera.width(), frame.camera.height())
                                   : frame.bounds),
        fx_(frame.camera.fx()),
        fy_(frame.camera.fy()),
        cx_(frame.camera.cx()),
        cy_(frame.camera.cy()),
        top_level_(static_cast<int>(frame.pyramid.scale.size()) - 1),
        inv_log_scale_(top_level_ > 0 && frame.pyramid.scale_factor > 1.0 ? 1.0 / std::log(frame.pyramid.scale_factor)
                                                                          : 0.0),
        // Without a scale step every positive finite ratio predicts no change (log(ratio) * 0).
        same_scale_min2_(inv_log_scale_ > 0.0 ? std::pow(frame.pyramid.scale_factor, -2.0 * kSameScaleShift) : 0.0),
        same_scale_max2_(inv_log_scale_ > 0.0 ? std::pow(frame.pyramid.scale_factor, 2.0 * kSameScaleShift)
                                              : std::numeric_limits<double>::infinity()) {
    // uv are undistorted coordinates, so projecting with the plain pinhole is exact (frame.hpp).
    FLEETSLAM_CHECK(frame.size() == 0 || frame.camera.distortion().is_zero(),
                    "matcher: Frame::camera must be the distortion-free camera of the undistorted uv");
  }

  // The query for camera-frame point p_cam of a feature seen at `level` as p_seen (the point in the
  // camera that saw it; distance_seen = |p_seen|): its projection and the levels predicted for it. False
  // (no candidates) when p_cam is behind the camera or projects outside the frame's area (Frame::bounds,
  // or the image).
  bool query(const Eigen::Vector3d& p_cam, int level, const Eigen::Vector3d& p_seen, Query& q) const {
    if (!(p_cam.z() > core::PinholeCamera::min_depth)) return false;
    const double inv_z = 1.0 / p_cam.z();
    q.u = fx_ * p_cam.x() * inv_z + cx_;
    q.v = fy_ * p_cam.y() * inv_z + cy_;
    if (!(q.u >= area_.min_u && q.u < area_.max_u && q.v >= area_.min_v && q.v < area_.max_v)) return false;
    level_window(level, p_seen.squaredNorm(), p_cam.squaredNorm(), q);
    return true;
  }

  const Frame& frame() const { return frame_; }

  // Whether feature i passes the query's level and distance tests, with the grid's arithmetic: a feature
  // failing them is not among the query's candidates within radius_px (one that passes is, when the grid
  // indexes it).
  bool level_and_distance_pass(const Query& q, double radius_px, std::size_t i) const {
    const int l = frame_.level[i];
    if ((q.min_level >= 0 && l < q.min_level) || (q.max_level >= 0 && l > q.max_level)) return false;
    const double du = frame_.uv[i].x() - q.u;
    const double dv = frame_.uv[i].y() - q.v;
    return du * du + dv * dv <= radius_px * radius_px;
  }

 private:
  // Levels within kLevelWindow of the predicted level: max(0, ceil(predicted - window)) ..
  // min(top, floor(predicted + window)), from the squared distances (norm() is the square root of
  // squaredNorm()).
  void level_window(int level, double distance_seen2, double distance_now2, Query& q) const {
    // Shortcut, the same levels: with level in [0, top] and |predicted - level| <= kSameScaleShift + rounding
    // < 0.5, predicted - 1.5 lies in (level - 2, level - 1) and predicted + 1.5 in (level + 1, level + 2).
    // Without a positive distance on either side nothing is predicted (predicted == level).
    if (level <= top_level_) {
      const bool no_ratio = !(distance_seen2 > 0.0 && distance_now2 > 0.0);
      const bool same_scale = distance_seen2 >= kSquaredMin && distance_seen2 <= kSquaredMax &&
                              distance_now2 >= kSquaredMin && distance_now2 <= kSquaredMax &&
                              distance_seen2 >= same_scale_min2_ * distance_now2 &&
                              distance_seen2 <= same_scale_max2_ * distance_now2;
      if (no_ratio || same_scale) {
        q.min_level = std::max(0, level - 1);
        q.max_level = std::min(top_level_, level + 1);
        return;
      }
    }
    // predicted is in [0, top]: ceil only matters above 0, and floor is truncation.
    const double predicted = predicted_level(level, std::sqrt(distance_seen2), std::sqrt(distance_now2));
    const double lowest = predicted - kLevelWindow;
    q.min_level = 0;
    if (lowest > 0.0) {
      q.min_level = static_cast<int>(lowest);
      if (q.min_level < lowest) ++q.min_level;
    }
    q.max_level = std::min(top_level_, static_cast<int>(predicted + kLevelWindow));
  }

  // ORB-SLAM's scale prediction, from the feature's own level instead of a map point's distance range:
  // a patch's image size scales with 1 / distance, so seen at `level` from distance_seen it appears
  // log(distance_seen / distance_now) / log(scale_factor) levels higher from distance_now.
  double predicted_level(int level, double distance_seen, double distance_now) const {
    double predicted = level;
    if (distance_seen > 0.0 && distance_now > 0.0) predicted += std::log(distance_seen / distance_now) * inv_log_scale_;
    return std::clamp(predicted, 0.0, static_cast<double>(top_level_));
  }

  const Frame& frame_;
  ImageBounds area_;
  double fx_, fy_, cx_, cy_;
  int top_level_;
  double inv_log_scale_;
  double same_scale_min2_;  // squared distance ratios in [same_scale_min2_, same_scale_max2_] take the shortcut
  double same_scale_max2_;
};

// The candidates of a query are the features FeatureGrid::features_in_area finds around (q.u, q.v) within
// radius_px at levels q.min_level .. q.max_level. Both searches below take them from the grid as it scans
// (FeatureGrid::scan_area, visit_area), no candidate list in between, and give what the straightforward
// loop over the sorted candidates gives.

// The closest and second-closest candidate descriptors to `query` (ties: the lower index, as when
// offering the sorted candidates). Without branches on the in-area flag (which features pass is
// unpredictable): every scanned feature's distance is computed and a non-candidate's made kOutside. Keys
// (distance << 32 | index) order by distance, then index.
inline Nearest nearest_in_area(const std::uint8_t* query, const SearchedFrame& searched,
                               const SearchedFrame::Query& q, double radius_px) {
  constexpr std::uint32_t kOutside = std::numeric_limits<std::uint32_t>::max();  // "distance" of a non-candidate
  const Frame& frame = searched.frame();
  const std::uint8_t* const rows = frame.descriptors.data;
  const std::size_t step = frame.descriptors.step[0];
  std::uint64_t best = std::numeric_limits<std::uint64_t>::max();
  std::uint32_t second = kOutside;
  frame.grid.scan_area(frame.uv, frame.level, q.u, q.v, radius_px, q.min_level, q.max_level, [&](int i, bool in_area) {
    const auto distance = static_cast<std::uint32_t>(descriptor_distance(query, rows + static_cast<std::size_t>(i) * step));
    const std::uint32_t d = distance | (0U - static_cast<std::uint32_t>(!in_area));  // kOutside unless in the area
    const auto best_distance = static_cast<std::uint32_t>(best >> 32);
    second = std::min(second, std::max(best_distance, d));  // the second smallest distance so far
    best = std::min(best, (std::uint64_t{d} << 32) | static_cast<std::uint32_t>(i));
  });
  Nearest nearest;
  if (static_cast<std::uint32_t>(best >> 32) != kOutside) {
    nearest.index = static_cast<int>(best & 0xFFFFFFFFU);
    nearest.distance = static_cast<int>(best >> 32);
  }
  if (second != kOutside) nearest.second_distance = static_cast<int>(second);
  return nearest;
}

// Stage 2's test: `expected` is a candidate and no other candidate is strictly closer to the query (a tie
// cannot tell the two apart, so it does not overrule stage 1). Unlike stage 1, descriptors are compared
// only for the other candidates, which are few: the grid filters the scanned features four at a time
// (FeatureGrid::visit_prepared) and offers only the candidates, so stage 2 spends little on each feature
// it scans. (Stage 1 computes every scanned feature's distance instead: with that filter it was no faster.)
inline bool is_nearest_in_area(const std::uint8_t* query, const Frame& searched, const FeatureGrid::Area& area,
                               int expected, int expected_distance) {
  const std::uint8_t* const rows = searched.descriptors.data;
  const std::size_t step = searched.descriptors.step[0];
  bool found = false;
  bool closer = false;
  searched.grid.visit_prepared(area, [&](int i) {
    if (i == expected) {
      found = true;
    } else {
      closer = closer || descriptor_distance(query, rows + static_cast<std::size_t>(i) * step) < expected_distance;
    }
  });
  return found && !closer;
}

// factor * scale[l] for every level l of the pyramid: a search radius per level, computed once per call.
std::vector<double> radius_per_level(double factor, const ScalePyramid& pyramid) {
  std::vector<double> radius(pyramid.scale.size());
  for (std::size_t l = 0; l < radius.size(); ++l) radius[l] = factor * pyramid.scale[l];
  return radius;
}

// One-to-one: when several B features pick the same A feature, the closest descriptor wins (the first
// in B order on ties). Returns the matches sorted by A index.
std::vector<Match> keep_best_per_a(const std::vector<Match>& proposals, std::size_t size_a) {
  std::vector<Match> best(size_a);
  for (const Match& m : proposals) {
    Match& slot = best[static_cast<std::size_t>(m.a)];
    if (slot.a < 0 || m.distance < slot.distance) slot = m;
  }
  best.erase(std::remove_if(best.begin(), best.end(), [](const Match& m) { return m.a < 0; }), best.end());
  return best;
}

// Bin of the keypoint angle difference (degrees), centred so that "no rotation" falls in bin 0.
int rotation_bin(float angle_a_deg, float angle_b_deg) {
  double diff = std::fmod(static_cast<double>(angle_a_deg) - static_cast<double>(angle_b_deg), 360.0);
  if (!std::isfinite(diff)) return 0;  // a NaN angle must not index outside the histogram
  if (diff < 0.0) diff += 360.0;
  const int bin = static_cast<int>(std::lround(diff * kHistogramBins / 360.0));
  return bin % kHistogramBins;
}

// ORB-SLAM's rotation consistency: a rigid motion turns every keypoint by about the same in-plane
// angle, so only matches in the three most populated bins of the angle difference survive (the second
// and third only when they hold at least kMinBinShare of the first).
std::vector<Match> keep_consistent_rotation(const std::vector<Match>& matches, const Frame& a, const Frame& b) {
  std::vector<int> bins(matches.size());
  std::array<int, kHistogramBins> count{};
  for (std::size_t i = 0; i < matches.size(); ++i) {
    bins[i] = rotation_bin(a.keypoints[static_cast<std::size_t>(matches[i].a)].angle,
                           b.keypoints[static_cast<std::size_t>(matches[i].b)].angle);
    ++count[static_cast<std::size_t>(bins[i])];
  }
  std::array<int, kHistogramBins> order{};
  for (int i = 0; i < kHistogramBins; ++i) order[static_cast<std::size_t>(i)] = i;
  std::stable_sort(order.begin(), order.end(), [&](int x, int y) {
    return count[static_cast<std::size_t>(x)] > count[static_cast<std::size_t>(y)];
  });
  std::array<bool, kHistogramBins> keep{};
  const int largest = count[static_cast<std::size_t>(order[0])];
  for (std::size_t rank = 0; rank < 3; ++rank) {
    const int c = count[static_cast<std::size_t>(order[rank])];
    if (c > 0 && (rank == 0 || c >= kMinBinShare * largest)) keep[static_cast<std::size_t>(order[rank])] = true;
  }
  std::vector<Match> kept;
  kept.reserve(matches.size());
  for (std::size_t i = 0; i < matches.size(); ++i) {
    if (keep[static_cast<std::size_t>(bins[i])]) kept.push_back(matches[i]);
  }
  return kept;
}

// The shared tail of both matchers: one-to-one, then the rotation check.
std::vector<Match> finish(const std::vector<Match>& proposals, const Frame& a, const Frame& b,
                          const MatcherConfig& config) {
  std::vector<Match> matches = keep_best_per_a(proposals, a.size());
  if (config.check_orientation && !matches.empty()) matches = keep_consistent_rotation(matches, a, b);
  return matches;
}

// Stage 1 (the single-stage matcher): each B feature with a 3D point, projected into A with T_a_b,
// against A's features (the searched frame) within radius_px * scale[level of the B feature]. The whole
// loop is cloned and flattened: the search inlined into it, rather than a call through the clones'
// dispatch per feature, made stage 1 about 7 % faster on TUM and office pairs (experiment matching).
FLEETSLAM_POPCNT_CLONES FLEETSLAM_FLATTEN
void propose_b_into_a(const Frame& b, const FeaturePoints& p_b, const Eigen::Isometry3d& T_a_b,
                      const SearchedFrame& searched, const std::vector<double>& radius, const MatcherConfig& config,
                      std::vector<Match>& proposals) {
  SearchedFrame::Query query;
  for (std::size_t ib = 0; ib < b.size(); ++ib) {
    if (!p_b[ib]) continue;
    const Eigen::Vector3d& point = *p_b[ib];
    const int level_b = b.level[ib];
    if (!searched.query(T_a_b * point, level_b, point, query)) continue;
    const Nearest nearest = nearest_in_area(b.descriptors.ptr<std::uint8_t>(static_cast<int>(ib)), searched, query,
                                            radius[static_cast<std::size_t>(level_b)]);
    if (passes_thresholds(nearest, config)) proposals.push_back({nearest.index, static_cast<int>(ib), nearest.distance});
  }
}

std::vector<Match> project_b_into_a(const Frame& a, const Frame& b, const FeaturePoints& p_b,
                                    const Eigen::Isometry3d& T_a_b, const MatcherConfig& config) {
  const SearchedFrame searched(a);
  const std::vector<double> radius = radius_per_level(config.radius_px, b.pyramid);
  std::vector<Match> proposals;
  proposals.reserve(b.size());
  propose_b_into_a(b, p_b, T_a_b, searched, radius, config, proposals);
  return finish(proposals, a, b, config);
}

// Stage 2: A's own 3D point of each stage-1 match, projected into B with T_b_a, searched within
// r2 = r2_over_r1 * radius_px * scale[level of the A feature]; the pair stays only when the stage-1 B
// feature is the closest candidate. A point of A behind B or outside B's image cannot confirm the pair.
// The stage-1 B feature is tested first (its level and distance, without the grid): when it is no
// candidate the pair is rejected without a search.
// Two passes: the first projects every point and finds its cells, the second searches them. Apart, the
// first pass's arithmetic (a division per point) and the second's loads overlap better across matches
// than in one loop: stage 2 measured about 8 % faster (experiment matching, 1000 features). Cloned and
// flattened as stage 1's loop is.
FLEETSLAM_POPCNT_CLONES FLEETSLAM_FLATTEN
void cross_validate(MatchResult& result, const Frame& a, const FeaturePoints& p_a, const Frame& b,
                    const Eigen::Isometry3d& T_a_b, const MatcherConfig& config) {
  const Eigen::Isometry3d T_b_a = T_a_b.inverse();
  const SearchedFrame searched(b);
  const std::vector<double> radius = radius_per_level(config.r2_over_r1 * config.radius_px, a.pyramid);
  struct Search {
    FeatureGrid::Area area;
    std::size_t match = 0;  // index in result.matches
    bool confirmed = false;
  };
  std::vector<Search> searches;
  searches.reserve(result.matches.size());
  SearchedFrame::Query query;
  for (std::size_t k = 0; k < result.matches.size(); ++k) {
    const Match& m = result.matches[k];
    const auto ia = static_cast<std::size_t>(m.a);
    if (!p_a[ia]) continue;  // monocular A feature: nothing to check with (kept below)
    const Eigen::Vector3d& point = *p_a[ia];
    const int level_a = a.level[ia];
    const double r2_px = radius[static_cast<std::size_t>(level_a)];
    // Built in place: a Search built aside was copied in with wider loads than the stores that had just
    // written it, which the CPU cannot forward from its store buffer (the loop's hottest spot in a profile).
    Search& search = searches.emplace_back();
    search.match = k;
    if (!(searched.query(T_b_a * point, level_a, point, query) &&
          searched.level_and_distance_pass(query, r2_px, static_cast<std::size_t>(m.b)) &&
          b.grid.prepare_area(query.u, query.v, r2_px, query.min_level, query.max_level, search.area))) {
      searches.pop_back();
    }
  }
  for (Search& search : searches) {
    const Match& m = result.matches[search.match];
    search.confirmed = is_nearest_in_area(a.descriptors.ptr<std::uint8_t>(m.a), b, search.area, m.b, m.distance);
  }
  // Both lists are in match order: a checked match without a confirmed search is rejected.
  std::size_t kept = 0;
  auto next = searches.begin();
  for (std::size_t k = 0; k < result.matches.size(); ++k) {
    bool keep = false;
    if (!p_a[static_cast<std::size_t>(result.matches[k].a)]) {
      ++result.unchecked;
      keep = true;
    } else if (next != searches.end() && next->match == k) {
      keep = next->confirmed;
      ++next;
    }
    if (keep) {
      result.matches[kept++] = result.matches[k];
    } else {
      ++result.rejected_by_cross_check;
    }
  }
  result.matches.resize(kept);
}

}  // namespace

FLEETSLAM_POPCNT_CLONES
int hamming_distance(const std::uint8_t* a, const std::uint8_t* b) { return descriptor_distance(a, b); }

FeaturePoints points_from_depth(const Frame& frame) {
  FeaturePoints points(frame.size());
  for (std::size_t i = 0; i < frame.size(); ++i) points[i] = frame.unproject(i);
  return points;
}

MatchResult match_brute_force(const Frame& a, const Frame& b, const MatcherConfig& config) {
  check_frame(a, "A", false);
  check_frame(b, "B", false);
  MatchResult result;
  if (a.size() == 0 || b.size() == 0) return result;
  std::vector<Match> proposals;
  for (int ib = 0; ib < b.descriptors.rows; ++ib) {
    const Nearest nearest = nearest_of_all(b.descriptors.ptr<std::uint8_t>(ib), a.descriptors);
    if (passes_thresholds(nearest, config)) proposals.push_back({nearest.index, ib, nearest.distance});
  }
  result.matches = keep_best_per_a(proposals, a.size());
  result.stage1_matches = static_cast<int>(result.matches.size());
  return result;
}

MatchResult match_by_projection(const Frame& a, const FeaturePoints& p_a, const Frame& b, const FeaturePoints& p_b,
                                const Eigen::Isometry3d& T_a_b, const MatcherConfig& config) {
  check_frame(a, "A", config.check_orientation);
  check_frame(b, "B", config.check_orientation);
  FLEETSLAM_CHECK(p_b.size() == b.size(), "p_b needs one entry per feature of B");
  FLEETSLAM_CHECK(!config.cross_validation || p_a.size() == a.size(), "p_a needs one entry per feature of A");
  FLEETSLAM_CHECK(a.size() == 0 || !a.grid.empty(), "frame A has no feature grid (call finalize())");
  FLEETSLAM_CHECK(!config.cross_validation || b.size() == 0 || !b.grid.empty(),
                  "frame B has no feature grid (call finalize())");
  MatchResult result;
  if (a.size() == 0 || b.size() == 0) return result;
  result.matches = project_b_into_a(a, b, p_b, T_a_b, config);
  result.stage1_matches = static_cast<int>(result.matches.size());
  if (config.cross_validation) cross_validate(result, a, p_a, b, T_a_b, config);
  return result;
}

}  // namespace fleetslam::slam

namespace fleetslam::slam {

std::vector<Match> search_by_bow(const Frame& a, const FeatureVector& words_a, const std::vector<bool>& usable_a,
                                 const Frame& b, const FeatureVector& words_b, const std::vector<bool>& usable_b,
                                 const BowMatchConfig& config) {
  FLEETSLAM_CHECK(usable_a.empty() || usable_a.size() == a.size(), "search_by_bow: usable_a needs one entry per feature");
  FLEETSLAM_CHECK(usable_b.empty() || usable_b.size() == b.size(), "search_by_bow: usable_b needs one entry per feature");
  check_frame(a, "A", config.check_orientation);
  check_frame(b, "B", config.check_orientation);
  const auto ok_a = [&](int i) { return i >= 0 && static_cast<std::size_t>(i) < a.size() && (usable_a.empty() || usable_a[static_cast<std::size_t>(i)]); };
  const auto ok_b = [&](int i) { return i >= 0 && static_cast<std::size_t>(i) < b.size() && (usable_b.empty() || usable_b[static_cast<std::size_t>(i)]); };
  std::vector<Match> proposals;
  auto ia = words_a.nodes.begin();
  auto ib = words_b.nodes.begin();
  while (ia != words_a.nodes.end() && ib != words_b.nodes.end()) {
    if (ia->node < ib->node) { ++ia; continue; }
    if (ib->node < ia->node) { ++ib; continue; }
    for (int i : ia->features) {
      if (!ok_a(i)) continue;
      const std::uint8_t* query = a.descriptors.ptr<std::uint8_t>(i);
      Nearest nearest;
      for (int j : ib->features) {
        if (ok_b(j)) offer(nearest, j, descriptor_distance(query, b.descriptors.ptr<std::uint8_t>(j)));
      }
      if (nearest.index < 0 || nearest.distance > config.max_distance) continue;
      if (nearest.second_distance != kNoDistance &&
          static_cast<double>(nearest.distance) > config.nn_ratio * static_cast<double>(nearest.second_distance)) {
        continue;
      }
      proposals.push_back(Match{i, nearest.index, nearest.distance});
    }
    ++ia;
    ++ib;
  }
  // One-to-one on B: the closest A feature wins (proposals come in node order, ties to the lower A index).
  std::vector<Match> best_per_b(b.size());
  for (const Match& m : proposals) {
    Match& slot = best_per_b[static_cast<std::size_t>(m.b)];
    if (slot.a < 0 || m.distance < slot.distance || (m.distance == slot.distance && m.a < slot.a)) slot = m;
  }
  std::vector<Match> matches;
  for (const Match& m : best_per_b) {
    if (m.a >= 0) matches.push_back(m);
  }
  std::sort(matches.begin(), matches.end(), [](const Match& x, const Match& y) { return x.a < y.a; });
  if (config.check_orientation && !matches.empty()) matches = keep_consistent_rotation(matches, a, b);
  return matches;
}

}  // namespace fleetslam::slam
