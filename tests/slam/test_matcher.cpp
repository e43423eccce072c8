// Matchers against synthetic ground truth: random 3D points seen by two cameras with a known relative
// pose; features are the projections plus pixel noise; each point has a random 256-bit descriptor with a
// few bits flipped independently in each view, so true pairs are close in Hamming distance (~10 bits)
// and unrelated features far (~128). Injected mismatches (swapped descriptors, decoys with a wrong 3D
// point) show what the paper's cross-validation removes and the single-stage matcher keeps.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bitset>
#include <cmath>
#include <cstdint>
#include <map>
#include <random>
#include <set>
#include <vector>

#include <opencv2/core.hpp>

#include "fleetslam/core/error.hpp"
#include "fleetslam/core/se3.hpp"
#include "fleetslam/slam/matcher.hpp"

namespace fleetslam::slam {
namespace {

using Descriptor = std::array<std::uint8_t, 32>;
constexpr int kLevels = 8;
constexpr double kScaleFactor = 1.2;
constexpr int kDecoyId = -2;
constexpr double kPi = 3.14159265358979323846;

core::PinholeCamera test_camera() { return core::PinholeCamera(640, 480, 500.0, 500.0, 319.5, 239.5); }

// One feature as the tests describe it, before it becomes part of a Frame.
struct Feature {
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();
  int level = 0;
  float angle_deg = 0.0F;
  Descriptor descriptor{};
  double depth_m = -1.0;
  int id = kDecoyId;  // ground-truth point
};

Frame make_frame(const std::vector<Feature>& features) {
  Frame frame;
  frame.camera = test_camera();
  frame.pyramid = ScalePyramid::make(kLevels, kScaleFactor);
  frame.descriptors = cv::Mat(static_cast<int>(features.size()), 32, CV_8UC1);
  for (std::size_t i = 0; i < features.size(); ++i) {
    const Feature& f = features[i];
    const auto size = static_cast<float>(31.0 * frame.pyramid.scale[static_cast<std::size_t>(f.level)]);
    frame.uv.push_back(f.uv);
    frame.level.push_back(f.level);
    frame.keypoints.emplace_back(static_cast<float>(f.uv.x()), static_cast<float>(f.uv.y()), size, f.angle_deg, 0.0F,
                                 f.level);
    std::copy(f.descriptor.begin(), f.descriptor.end(), frame.descriptors.ptr<std::uint8_t>(static_cast<int>(i)));
    frame.depth_m.push_back(f.depth_m);
    frame.u_right.push_back(-1.0);
  }
  frame.finalize();
  return frame;
}

Descriptor random_descriptor(std::mt19937& rng) {
  Descriptor d{};
  std::uniform_int_distribution<int> byte(0, 255);
  for (auto& x : d) x = static_cast<std::uint8_t>(byte(rng));
  return d;
}

// Flips `count` distinct bits.
Descriptor flipped(Descriptor d, int count, std::mt19937& rng) {
  std::array<int, 256> bits{};
  for (int i = 0; i < 256; ++i) bits[static_cast<std::size_t>(i)] = i;
  std::shuffle(bits.begin(), bits.end(), rng);
  for (int i = 0; i < count; ++i) {
    const int bit = bits[static_cast<std::size_t>(i)];
    d[static_cast<std::size_t>(bit / 8)] ^= static_cast<std::uint8_t>(1U << (bit % 8));
  }
  return d;
}

int oracle_distance(const Descriptor& a, const Descriptor& b) {
  int d = 0;
  for (std::size_t i = 0; i < a.size(); ++i) d += static_cast<int>(std::bitset<8>(a[i] ^ b[i]).count());
  return d;
}

Eigen::Vector3d unproject(const Eigen::Vector2d& uv, double depth_m) {
  const auto camera = test_camera();
  return {(uv.x() - camera.cx()) / camera.fx() * depth_m, (uv.y() - camera.cy()) / camera.fy() * depth_m, depth_m};
}

// B moved a few centimetres and about two degrees from A: adjacent frames.
Eigen::Isometry3d adjacent_motion() {
  return core::make_pose(Eigen::Vector3d(0.05, -0.02, 0.03),
                         Eigen::Quaterniond(Eigen::AngleAxisd(0.035, Eigen::Vector3d(0.2, 1.0, 0.1).normalized())));
}

struct SceneOptions {
  unsigned seed = 1;
  int points = 400;
  Eigen::Isometry3d T_a_b = adjacent_motion();
  double pixel_noise_px = 0.5;
  int min_flips = 2;  // bits flipped per view, uniform in [min_flips, max_flips]
  int max_flips = 8;
  double depth_noise = 0.01;        // relative, per view
  double level_change = 0.15;       // chance that B sees a point one level up or down
  double missed_detection = 0.1;    // chance per view that a point has no feature
  double angle_noise_deg = 2.0;
  double repeated_texture = 0.0;  // share of points that reuse an earlier point's descriptor (+ a few flips)
};

SceneOptions seeded(unsigned seed) {
  SceneOptions options;
  options.seed = seed;
  return options;
}

// A scene: both frames' features (editable), then frames and 3D points built from them.
struct Scene {
  std::vector<Feature> fa;
  std::vector<Feature> fb;
  Eigen::Isometry3d T_a_b = Eigen::Isometry3d::Identity();
  Frame a;
  Frame b;
  FeaturePoints p_a;
  FeaturePoints p_b;

  void build() {
    a = make_frame(fa);
    b = make_frame(fb);
    p_a = points_from_depth(a);
    p_b = points_from_depth(b);
  }
  // Points with a feature in both frames (and a 3D point in B): what a perfect matcher finds.
  int true_pairs() const {
    std::set<int> in_a;
    for (const auto& f : fa) {
      if (f.id >= 0) in_a.insert(f.id);
    }
    int pairs = 0;
    for (const auto& f : fb) pairs += (f.id >= 0 && f.depth_m > 0.0 && in_a.count(f.id) > 0) ? 1 : 0;
    return pairs;
  }
  bool correct(const Match& m) const {
    const int id = fa[static_cast<std::size_t>(m.a)].id;
    return id >= 0 && id == fb[static_cast<std::size_t>(m.b)].id;
  }
};

int sample_level(std::mt19937& rng) {
  // ORB spreads features over levels in proportion to 1 / scale.
  std::discrete_distribution<int> level({1.0, 0.83, 0.69, 0.58, 0.48});
  return level(rng);
}

Scene make_scene(const SceneOptions& options) {
  std::mt19937 rng(options.seed);
  std::uniform_real_distribution<double> u(10.0, 630.0), v(10.0, 470.0), depth(1.0, 6.0), unit(0.0, 1.0);
  std::uniform_real_distribution<double> angle(0.0, 360.0);
  std::normal_distribution<double> pixel(0.0, options.pixel_noise_px), depth_noise(0.0, options.depth_noise);
  std::normal_distribution<double> angle_noise(0.0, options.angle_noise_deg);
  std::uniform_int_distribution<int> flips(options.min_flips, options.max_flips);
  const auto camera = test_camera();
  const Eigen::Isometry3d T_b_a = options.T_a_b.inverse();
  Scene scene;
  scene.T_a_b = options.T_a_b;
  std::vector<Descriptor> bases;
  for (int id = 0; id < options.points; ++id) {
    const Eigen::Vector2d uv_a(u(rng), v(rng));
    const double z_a = depth(rng);
    const Eigen::Vector3d p_b = T_b_a * unproject(uv_a, z_a);
    const auto uv_b = camera.project(p_b);
    Descriptor base = random_descriptor(rng);
    if (!bases.empty() && unit(rng) < options.repeated_texture) {
      base = flipped(bases[std::uniform_int_distribution<std::size_t>(0, bases.size() - 1)(rng)], 4, rng);
    }
    bases.push_back(base);
    const int level = sample_level(rng);
    const auto angle_deg = static_cast<float>(angle(rng));
    const bool in_a = unit(rng) >= options.missed_detection;
    const bool in_b = uv_b && camera.in_image(*uv_b, 5.0) && unit(rng) >= options.missed_detection;
    if (in_a) {
      scene.fa.push_back({uv_a + Eigen::Vector2d(pixel(rng), pixel(rng)), level, angle_deg,
                          flipped(base, flips(rng), rng), z_a * (1.0 + depth_noise(rng)), id});
    }
    if (in_b) {
      int level_b = level;
      if (unit(rng) < options.level_change) level_b = std::clamp(level + (unit(rng) < 0.5 ? -1 : 1), 0, kLevels - 1);
      scene.fb.push_back({*uv_b + Eigen::Vector2d(pixel(rng), pixel(rng)), level_b,
                          static_cast<float>(static_cast<double>(angle_deg) + angle_noise(rng)), flipped(base, flips(rng), rng),
                          p_b.z() * (1.0 + depth_noise(rng)), id});
    }
  }
  std::shuffle(scene.fb.begin(), scene.fb.end(), rng);  // B's order says nothing about A's
  scene.build();
  return scene;
}

struct Quality {
  int matches = 0;
  int correct = 0;
  double precision = 0.0;
  double recall = 0.0;
};

Quality quality(const Scene& scene, const MatchResult& result) {
  Quality q;
  q.matches = static_cast<int>(result.matches.size());
  for (const auto& m : result.matches) q.correct += scene.correct(m) ? 1 : 0;
  q.precision = q.matches > 0 ? static_cast<double>(q.correct) / q.matches : 1.0;
  q.recall = static_cast<double>(q.correct) / std::max(1, scene.true_pairs());
  return q;
}

MatcherConfig single_stage() {
  MatcherConfig config;
  config.cross_validation = false;
  return config;
}

MatchResult project(const Scene& scene, const MatcherConfig& config) {
  return match_by_projection(scene.a, scene.p_a, scene.b, scene.p_b, scene.T_a_b, config);
}

void expect_one_to_one(const MatchResult& result) {
  std::set<int> a, b;
  for (const auto& m : result.matches) {
    EXPECT_TRUE(a.insert(m.a).second) << "A feature " << m.a << " matched twice";
    EXPECT_TRUE(b.insert(m.b).second) << "B feature " << m.b << " matched twice";
  }
}

bool contains(const MatchResult& result, int a, int b) {
  return std::any_of(result.matches.begin(), result.matches.end(), [&](const Match& m) { return m.a == a && m.b == b; });
}

// --- A straightforward reference of the projection matcher ---
// matcher.hpp's rules written out plainly: candidates by scanning every feature of the searched frame in
// index order (no grid), fresh vectors everywhere. The optimised matcher must give exactly its results.

struct ReferenceNearest {
  int index = -1;
  int distance = 1 << 30;
  int second_distance = 1 << 30;
};

// Features of `searched` around where p_cam projects: inside the frame's area (the grid's), at a level
// within 1.5 of the predicted one, at distance <= radius; ascending.
std::vector<int> reference_candidates(const Frame& searched, const Eigen::Vector3d& p_cam, double radius, int level,
                                      double distance_seen) {
  if (!(p_cam.z() > core::PinholeCamera::min_depth)) return {};
  const auto& camera = searched.camera;
  const double u = camera.fx() * p_cam.x() / p_cam.z() + camera.cx();
  const double v = camera.fy() * p_cam.y() / p_cam.z() + camera.cy();
  const ImageBounds area =
      searched.bounds.empty() ? ImageBounds::of_image(camera.width(), camera.height()) : searched.bounds;
  const auto inside = [&](double x, double y) { return x >= area.min_u && x < area.max_u && y >= area.min_v && y < area.max_v; };
  if (!inside(u, v)) return {};
  const int top = static_cast<int>(searched.pyramid.scale.size()) - 1;
  const double inv_log_scale = top > 0 && searched.pyramid.scale_factor > 1.0 ? 1.0 / std::log(searched.pyramid.scale_factor) : 0.0;
  double predicted = level;
  const double distance_now = p_cam.norm();
  if (distance_seen > 0.0 && distance_now > 0.0) predicted += std::log(distance_seen / distance_now) * inv_log_scale;
  predicted = std::clamp(predicted, 0.0, static_cast<double>(top));
  const int min_level = std::max(0, static_cast<int>(std::ceil(predicted - 1.5)));
  const int max_level = std::min(top, static_cast<int>(std::floor(predicted + 1.5)));
  std::vector<int> found;
  for (std::size_t i = 0; i < searched.size(); ++i) {
    const Eigen::Vector2d& p = searched.uv[i];
    if (!inside(p.x(), p.y()) || searched.level[i] < min_level || searched.level[i] > max_level) continue;
    if ((p - Eigen::Vector2d(u, v)).squaredNorm() <= radius * radius) found.push_back(static_cast<int>(i));
  }
  return found;
}

int reference_distance(const Frame& x, int i, const Frame& y, int j) {
  return hamming_distance(x.descriptors.ptr<std::uint8_t>(i), y.descriptors.ptr<std::uint8_t>(j));
}

int reference_rotation_bin(float a_deg, float b_deg) {
  double diff = std::fmod(static_cast<double>(a_deg) - static_cast<double>(b_deg), 360.0);
  if (!std::isfinite(diff)) return 0;
  if (diff < 0.0) diff += 360.0;
  return static_cast<int>(std::lround(diff * 30.0 / 360.0)) % 30;
}

MatchResult reference_match(const Frame& a, const FeaturePoints& p_a, const Frame& b, const FeaturePoints& p_b,
                            const Eigen::Isometry3d& T_a_b, const MatcherConfig& config) {
  MatchResult result;
  if (a.size() == 0 || b.size() == 0) return result;
  // Stage 1: nearest in index order (ties: the first), threshold, ratio.
  std::vector<Match> proposals;
  for (std::size_t ib = 0; ib < b.size(); ++ib) {
    if (!p_b[ib]) continue;
    const double radius = config.radius_px * b.pyramid.scale[static_cast<std::size_t>(b.level[ib])];
    ReferenceNearest nearest;
    for (const int ia : reference_candidates(a, T_a_b * *p_b[ib], radius, b.level[ib], p_b[ib]->norm())) {
      const int d = reference_distance(b, static_cast<int>(ib), a, ia);
      if (d < nearest.distance) {
        nearest.second_distance = nearest.distance;
        nearest.distance = d;
        nearest.index = ia;
      } else if (d < nearest.second_distance) {
        nearest.second_distance = d;
      }
    }
    if (nearest.index < 0 || nearest.distance > config.max_distance) continue;
    if (nearest.second_distance != 1 << 30 &&
        !(static_cast<double>(nearest.distance) <= config.nn_ratio * static_cast<double>(nearest.second_distance))) {
      continue;
    }
    proposals.push_back({nearest.index, static_cast<int>(ib), nearest.distance});
  }
  // One-to-one: the closest per A feature, the first in B order on ties; by A index.
  std::map<int, Match> best;
  for (const Match& m : proposals) {
    const auto it = best.find(m.a);
    if (it == best.end() || m.distance < it->second.distance) best[m.a] = m;
  }
  std::vector<Match> matches;
  for (const auto& [ia, m] : best) matches.push_back(m);
  // Rotation: the three fullest bins (ties: the lower bin), the 2nd and 3rd with >= 10 % of the 1st.
  if (config.check_orientation && !matches.empty()) {
    std::vector<int> count(30, 0);
    for (const Match& m : matches) {
      ++count[static_cast<std::size_t>(reference_rotation_bin(a.keypoints[static_cast<std::size_t>(m.a)].angle,
                                                               b.keypoints[static_cast<std::size_t>(m.b)].angle))];
    }
    std::vector<int> order(30);
    for (int i = 0; i < 30; ++i) order[static_cast<std::size_t>(i)] = i;
    std::stable_sort(order.begin(), order.end(), [&](int x, int y) { return count[static_cast<std::size_t>(x)] > count[static_cast<std::size_t>(y)]; });
    std::set<int> keep;
    for (std::size_t rank = 0; rank < 3; ++rank) {
      const int c = count[static_cast<std::size_t>(order[rank])];
      if (c > 0 && (rank == 0 || c >= 0.1 * count[static_cast<std::size_t>(order[0])])) keep.insert(order[rank]);
    }
    std::vector<Match> kept;
    for (const Match& m : matches) {
      if (keep.count(reference_rotation_bin(a.keypoints[static_cast<std::size_t>(m.a)].angle,
                                            b.keypoints[static_cast<std::size_t>(m.b)].angle)) > 0) {
        kept.push_back(m);
      }
    }
    matches = kept;
  }
  result.stage1_matches = static_cast<int>(matches.size());
  if (!config.cross_validation) {
    result.matches = matches;
    return result;
  }
  // Stage 2: A's point into B within r2; the B feature must be a candidate with none strictly closer.
  const Eigen::Isometry3d T_b_a = T_a_b.inverse();
  for (const Match& m : matches) {
    const auto ia = static_cast<std::size_t>(m.a);
    if (!p_a[ia]) {
      ++result.unchecked;
      result.matches.push_back(m);
      continue;
    }
    const double radius = config.r2_over_r1 * config.radius_px * a.pyramid.scale[static_cast<std::size_t>(a.level[ia])];
    const auto candidates = reference_candidates(b, T_b_a * *p_a[ia], radius, a.level[ia], p_a[ia]->norm());
    bool keep = std::find(candidates.begin(), candidates.end(), m.b) != candidates.end();
    for (const int ib : candidates) keep = keep && reference_distance(a, m.a, b, ib) >= m.distance;
    if (keep) {
      result.matches.push_back(m);
    } else {
      ++result.rejected_by_cross_check;
    }
  }
  return result;
}

void expect_same_result(const MatchResult& expected, const MatchResult& actual) {
  EXPECT_EQ(actual.stage1_matches, expected.stage1_matches);
  EXPECT_EQ(actual.rejected_by_cross_check, expected.rejected_by_cross_check);
  EXPECT_EQ(actual.unchecked, expected.unchecked);
  ASSERT_EQ(actual.matches.size(), expected.matches.size());
  for (std::size_t i = 0; i < expected.matches.size(); ++i) {
    EXPECT_EQ(actual.matches[i].a, expected.matches[i].a) << "match " << i;
    EXPECT_EQ(actual.matches[i].b, expected.matches[i].b) << "match " << i;
    EXPECT_EQ(actual.matches[i].distance, expected.matches[i].distance) << "match " << i;
  }
}

// --- Hamming distance and 3D points ---

TEST(HammingDistance, MatchesBitCountOracleOnUnalignedRows) {
  std::mt19937 rng(7);
  std::array<std::uint8_t, 33> buffer_a{}, buffer_b{};  // offset 1: rows need not be aligned
  for (int trial = 0; trial < 500; ++trial) {
    const Descriptor a = random_descriptor(rng);
    const Descriptor b = trial % 5 == 0 ? flipped(a, trial % 257, rng) : random_descriptor(rng);
    std::copy(a.begin(), a.end(), buffer_a.begin() + 1);
    std::copy(b.begin(), b.end(), buffer_b.begin() + 1);
    EXPECT_EQ(hamming_distance(buffer_a.data() + 1, buffer_b.data() + 1), oracle_distance(a, b));
  }
  Descriptor zeros{}, ones{};
  ones.fill(0xFF);
  EXPECT_EQ(hamming_distance(zeros.data(), zeros.data()), 0);
  EXPECT_EQ(hamming_distance(zeros.data(), ones.data()), 256);
}

TEST(PointsFromDepth, UnprojectsFeaturesWithDepthOnly) {
  std::mt19937 rng(3);
  std::vector<Feature> features(3);
  features[0].uv = {100.0, 50.0};
  features[0].depth_m = 2.0;
  features[1].uv = {400.0, 300.0};
  features[1].depth_m = 0.0;
  features[2].uv = {319.5, 239.5};
  features[2].depth_m = 5.0;
  for (auto& f : features) f.descriptor = random_descriptor(rng);
  const auto points = points_from_depth(make_frame(features));
  ASSERT_EQ(points.size(), 3U);
  ASSERT_TRUE(points[0] && points[2]);
  EXPECT_FALSE(points[1]);
  EXPECT_TRUE(points[0]->isApprox(unproject({100.0, 50.0}, 2.0), 1e-12));
  EXPECT_TRUE(points[2]->isApprox(Eigen::Vector3d(0.0, 0.0, 5.0), 1e-12));
}

// --- Precision and recall on clean scenes ---

TEST(Matchers, PrecisionAndRecallOnACleanScene) {
  const Scene scene = make_scene({});
  const Quality brute = quality(scene, match_brute_force(scene.a, scene.b, MatcherConfig{}));
  const MatchResult single_result = project(scene, single_stage());
  const MatchResult cross_result = project(scene, MatcherConfig{});
  const Quality single = quality(scene, single_result);
  const Quality cross = quality(scene, cross_result);
  ASSERT_GT(scene.true_pairs(), 250);
  EXPECT_GE(brute.precision, 0.99);
  EXPECT_GE(brute.recall, 0.95);
  EXPECT_GE(single.precision, 0.99);
  EXPECT_GE(single.recall, 0.95);
  EXPECT_GE(cross.precision, 0.99);
  EXPECT_GE(cross.recall, 0.93);
  // A correct pose and agreeing depths leave almost nothing for stage 2 to reject.
  EXPECT_LE(cross_result.rejected_by_cross_check, cross_result.stage1_matches / 50);
  EXPECT_EQ(cross_result.stage1_matches, static_cast<int>(single_result.matches.size()));
  EXPECT_EQ(cross_result.unchecked, 0);
}

TEST(Matchers, SwitchOffCrossValidationGivesStageOneOnly) {
  const Scene scene = make_scene(seeded(5));
  const MatchResult single = project(scene, single_stage());
  const MatchResult cross = project(scene, MatcherConfig{});
  EXPECT_EQ(single.stage1_matches, static_cast<int>(single.matches.size()));
  EXPECT_EQ(single.rejected_by_cross_check, 0);
  EXPECT_EQ(single.unchecked, 0);
  EXPECT_EQ(cross.stage1_matches, single.stage1_matches);
  EXPECT_EQ(static_cast<int>(cross.matches.size()) + cross.rejected_by_cross_check, cross.stage1_matches);
  for (const auto& m : cross.matches) EXPECT_TRUE(contains(single, m.a, m.b));
}

// --- Injected mismatches ---

// For `count` points seen at level 0 in both frames, a twin point 11 px away in A at the same depth (both
// views); then B's descriptors of each pair are swapped. Between r2 (7.5 px) and r1 (15 px): stage 1 pairs
// each B feature with the other point's A feature, stage 2 cannot find the B feature within r2.
Scene scene_with_swapped_twins(unsigned seed, int count) {
  SceneOptions options;
  options.seed = seed;
  options.level_change = 0.0;
  Scene scene = make_scene(options);
  std::mt19937 rng(seed + 100);
  std::uniform_real_distribution<double> direction(0.0, 2.0 * kPi);
  const auto camera = test_camera();
  int next_id = 100000;
  int added = 0;
  for (std::size_t ia = 0; ia < scene.fa.size() && added < count; ++ia) {
    const Feature fa = scene.fa[ia];
    auto in_b = std::find_if(scene.fb.begin(), scene.fb.end(), [&](const Feature& f) { return f.id == fa.id; });
    if (fa.level != 0 || in_b == scene.fb.end() || in_b->level != 0) continue;
    const double theta = direction(rng);
    const Eigen::Vector2d uv_twin = fa.uv + 11.0 * Eigen::Vector2d(std::cos(theta), std::sin(theta));
    const auto uv_twin_b = camera.project(scene.T_a_b.inverse() * unproject(uv_twin, fa.depth_m));
    if (!camera.in_image(uv_twin, 5.0) || !uv_twin_b || !camera.in_image(*uv_twin_b, 5.0)) continue;
    const Descriptor base = random_descriptor(rng);
    Feature twin_b = *in_b;
    twin_b.uv = *uv_twin_b;
    twin_b.descriptor = in_b->descriptor;  // swapped: B's twin looks like the original point...
    twin_b.id = next_id;
    in_b->descriptor = flipped(base, 3, rng);  // ...and the original like the twin
    scene.fb.push_back(twin_b);
    scene.fa.push_back({uv_twin, 0, fa.angle_deg, flipped(base, 3, rng), fa.depth_m, next_id});
    ++next_id;
    ++added;
  }
  EXPECT_EQ(added, count);
  scene.build();
  return scene;
}

int wrong_matches(const Scene& scene, const MatchResult& result) {
  return static_cast<int>(std::count_if(result.matches.begin(), result.matches.end(),
                                        [&](const Match& m) { return !scene.correct(m); }));
}

TEST(CrossValidation, RejectsSwappedDescriptorsThatSingleStageAccepts) {
  const int twins = 30;
  const Scene scene = scene_with_swapped_twins(11, twins);
  const MatchResult single = project(scene, single_stage());
  const MatchResult cross = project(scene, MatcherConfig{});
  // Both features of each pair go to the wrong partner in the single-stage matcher.
  EXPECT_GE(wrong_matches(scene, single), 2 * twins - 4);
  EXPECT_LE(wrong_matches(scene, cross), 1);
  EXPECT_GE(cross.rejected_by_cross_check, 2 * twins - 4);
  const int untouched_pairs = scene.true_pairs() - 2 * twins;  // the swapped points themselves are lost
  EXPECT_GE(quality(scene, cross).correct, untouched_pairs * 95 / 100);
}

// For `count` points, a decoy feature in A 4 px from the point's A feature, carrying exactly B's
// descriptor (closer than the true A feature) but a depth at which its own 3D point projects into B far
// from the B feature (> 2 r2). Needs parallax: B is 30 cm beside A.
Scene scene_with_decoys(unsigned seed, int count, int* added) {
  SceneOptions options;
  options.seed = seed;
  options.T_a_b = core::make_pose(Eigen::Vector3d(0.3, 0.0, 0.0), Eigen::Quaterniond::Identity());
  Scene scene = make_scene(options);
  std::mt19937 rng(seed + 200);
  std::uniform_real_distribution<double> direction(0.0, 2.0 * kPi);
  const auto camera = test_camera();
  const Eigen::Isometry3d T_b_a = scene.T_a_b.inverse();
  *added = 0;
  const std::size_t original = scene.fa.size();
  for (std::size_t ia = 0; ia < original && *added < count; ++ia) {
    const Feature fa = scene.fa[ia];
    const auto in_b = std::find_if(scene.fb.begin(), scene.fb.end(), [&](const Feature& f) { return f.id == fa.id; });
    if (fa.level != 0 || in_b == scene.fb.end() || in_b->depth_m <= 0.0) continue;
    const double theta = direction(rng);
    const Eigen::Vector2d uv_decoy = fa.uv + 4.0 * Eigen::Vector2d(std::cos(theta), std::sin(theta));
    for (const double factor : {0.3, 3.0}) {
      const auto uv_b = camera.project(T_b_a * unproject(uv_decoy, fa.depth_m * factor));
      if (uv_b && (*uv_b - in_b->uv).norm() < 15.0) continue;  // not far enough from the B feature
      scene.fa.push_back({uv_decoy, 0, fa.angle_deg, in_b->descriptor, fa.depth_m * factor, kDecoyId});
      ++*added;
      break;
    }
  }
  scene.build();
  return scene;
}

int decoy_matches(const Scene& scene, const MatchResult& result) {
  return static_cast<int>(std::count_if(result.matches.begin(), result.matches.end(), [&](const Match& m) {
    return scene.fa[static_cast<std::size_t>(m.a)].id == kDecoyId;
  }));
}

TEST(CrossValidation, RejectsDecoysWhose3DPointProjectsElsewhere) {
  int added = 0;
  const Scene scene = scene_with_decoys(21, 40, &added);
  ASSERT_GE(added, 30);
  const MatchResult single = project(scene, single_stage());
  const MatchResult cross = project(scene, MatcherConfig{});
  EXPECT_GE(decoy_matches(scene, single), added - 3);
  EXPECT_EQ(decoy_matches(scene, cross), 0);
  EXPECT_GE(cross.rejected_by_cross_check, added - 3);
  EXPECT_GE(quality(scene, cross).precision, 0.99);
}

TEST(CrossValidation, WrongPredictedPoseMakesStageTwoRejectMore) {
  const Scene scene = make_scene(seeded(31));
  // About 10 px of prediction error: inside r1 (15 px) at every level, outside r2 (7.5 px * scale) at the
  // lower levels.
  const Eigen::Isometry3d wrong =
      scene.T_a_b * core::make_pose(Eigen::Vector3d::Zero(), Eigen::Quaterniond(Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitY())));
  const MatchResult right_pose = project(scene, MatcherConfig{});
  const MatchResult wrong_pose = match_by_projection(scene.a, scene.p_a, scene.b, scene.p_b, wrong, MatcherConfig{});
  EXPECT_GE(wrong_pose.stage1_matches, right_pose.stage1_matches * 9 / 10);  // stage 1 still finds them
  EXPECT_LE(right_pose.rejected_by_cross_check, right_pose.stage1_matches / 50);
  EXPECT_GE(wrong_pose.rejected_by_cross_check, wrong_pose.stage1_matches / 2);
}

// --- One-to-one, rotation check, thresholds ---

TEST(Projection, TwoBFeaturesOnOneAFeatureKeepTheCloser) {
  Scene scene = make_scene(seeded(41));
  std::mt19937 rng(42);
  const std::size_t original = scene.fb.size();
  for (std::size_t ib = 0; ib < original; ib += 4) {  // a near-duplicate of every fourth B feature
    Feature duplicate = scene.fb[ib];
    duplicate.uv += Eigen::Vector2d(1.0, 0.0);
    duplicate.descriptor = flipped(duplicate.descriptor, 6, rng);
    scene.fb.push_back(duplicate);
  }
  scene.build();
  for (const bool cross : {false, true}) {
    MatcherConfig config;
    config.cross_validation = cross;
    const MatchResult result = project(scene, config);
    expect_one_to_one(result);
    for (const auto& m : result.matches) {  // no other B feature of the same point is closer to A's
      const Descriptor& da = scene.fa[static_cast<std::size_t>(m.a)].descriptor;
      for (const auto& fb : scene.fb) {
        if (fb.id >= 0 && fb.id == scene.fb[static_cast<std::size_t>(m.b)].id) {
          EXPECT_LE(m.distance, oracle_distance(da, fb.descriptor));
        }
      }
    }
    EXPECT_GE(quality(scene, result).precision, 0.99);
  }
}

TEST(Projection, RotationHistogramRemovesInconsistentMatches) {
  Scene scene = make_scene(seeded(51));
  std::set<int> turned;  // ids of B features turned by 100 degrees
  for (std::size_t ib = 0; ib < scene.fb.size(); ib += 10) {
    scene.fb[ib].angle_deg += 100.0F;
    turned.insert(scene.fb[ib].id);
  }
  scene.build();
  const auto turned_matches = [&](const MatchResult& result) {
    return std::count_if(result.matches.begin(), result.matches.end(), [&](const Match& m) {
      return turned.count(scene.fb[static_cast<std::size_t>(m.b)].id) > 0;
    });
  };
  MatcherConfig unchecked = single_stage();
  unchecked.check_orientation = false;
  EXPECT_GE(turned_matches(project(scene, unchecked)), static_cast<long>(turned.size()) * 8 / 10);
  EXPECT_EQ(turned_matches(project(scene, single_stage())), 0);
  EXPECT_EQ(turned_matches(project(scene, MatcherConfig{})), 0);
}

// Matches per in-plane turn of B's keypoints, for scenes where B feature i is turned by turn_of(i).
template <class TurnOf>
std::map<int, int> matches_per_turn(Scene scene, TurnOf turn_of) {
  std::map<int, int> turn_by_id;
  for (std::size_t ib = 0; ib < scene.fb.size(); ++ib) {
    const int turn = turn_of(ib);
    scene.fb[ib].angle_deg += static_cast<float>(turn);
    turn_by_id[scene.fb[ib].id] = turn;
  }
  scene.build();
  std::map<int, int> count;
  for (const auto& m : project(scene, single_stage()).matches) ++count[turn_by_id[scene.fb[static_cast<std::size_t>(m.b)].id]];
  return count;
}

TEST(Projection, RotationHistogramKeepsTheThreeFullestBins) {
  const Scene scene = make_scene(seeded(52));
  // 45 % unturned, 20 % by 60 degrees, 15 % by 120, 10 % each by 180 and 240: the last two go.
  auto count = matches_per_turn(scene, [](std::size_t i) {
    const std::size_t k = i % 20;
    return k < 9 ? 0 : k < 13 ? 60 : k < 16 ? 120 : k < 18 ? 180 : 240;
  });
  EXPECT_GT(count[0], 100);
  EXPECT_GT(count[60], 40);
  EXPECT_GT(count[120], 30);
  EXPECT_EQ(count[180], 0);
  EXPECT_EQ(count[240], 0);
  // A second bin below 10 % of the first is noise, not a second rotation.
  count = matches_per_turn(scene, [](std::size_t i) { return i % 20 == 0 ? 90 : 0; });
  EXPECT_GT(count[0], 200);
  EXPECT_EQ(count[90], 0);
}

// Two hand-made frames: B's features at depth 2 m with an identity pose, so each projects onto its own uv.
Scene hand_scene(const std::vector<Feature>& fa, const std::vector<Feature>& fb) {
  Scene scene;
  scene.fa = fa;
  scene.fb = fb;
  scene.build();
  return scene;
}

Feature feature_at(double u, double v, int level, const Descriptor& d, int id) {
  return {Eigen::Vector2d(u, v), level, 30.0F, d, 2.0, id};
}

TEST(Projection, RadiusScalesWithTheBFeatureLevel) {
  std::mt19937 rng(61);
  const Descriptor d = random_descriptor(rng);
  for (const int level : {0, 3}) {  // r = 15 px and 15 * 1.2^3 = 25.9 px; the A feature is 20 px away
    const Scene scene = hand_scene({feature_at(320.0, 200.0, level, d, 0)}, {feature_at(300.0, 200.0, level, d, 0)});
    EXPECT_EQ(project(scene, single_stage()).matches.size(), level == 0 ? 0U : 1U) << "level " << level;
  }
}

TEST(Projection, CandidatesOnlyNearThePredictedLevel) {
  std::mt19937 rng(62);
  const Descriptor d = random_descriptor(rng);
  for (const int level_a : {0, 1, 2, 3}) {  // B's feature at level 1, same distance: levels 0..2 qualify
    const Scene scene = hand_scene({feature_at(302.0, 200.0, level_a, d, 0)}, {feature_at(300.0, 200.0, 1, d, 0)});
    EXPECT_EQ(project(scene, single_stage()).matches.size(), level_a <= 2 ? 1U : 0U) << "level " << level_a;
  }
}

TEST(Projection, LevelPredictedFromTheDistanceRatio) {
  std::mt19937 rng(64);
  const Descriptor d = random_descriptor(rng);
  // B sees the point at level 0 from 2 m; A is 1 m closer, so the patch is twice as large there:
  // predicted level log(2) / log(1.2) = 3.8, candidates at levels 3 and 4 (and 5).
  for (const int level_a : {0, 2, 4}) {
    Scene scene = hand_scene({{Eigen::Vector2d(320.0, 240.0), level_a, 30.0F, d, 1.0, 0}},
                             {{Eigen::Vector2d(319.5, 239.5), 0, 30.0F, d, 2.0, 0}});
    scene.T_a_b = core::make_pose(Eigen::Vector3d(0.0, 0.0, -1.0), Eigen::Quaterniond::Identity());
    EXPECT_EQ(project(scene, MatcherConfig{}).matches.size(), level_a == 4 ? 1U : 0U) << "level " << level_a;
  }
}

TEST(CrossValidation, KeepsAPairOneLevelApart) {
  std::mt19937 rng(65);
  const Descriptor d = random_descriptor(rng);
  for (const int level_a : {2, 3}) {  // B at level 2, same distance: the window is symmetric
    const Scene scene = hand_scene({feature_at(301.0, 200.0, level_a, d, 0)}, {feature_at(300.0, 200.0, 2, d, 0)});
    const MatchResult result = project(scene, MatcherConfig{});
    EXPECT_EQ(result.matches.size(), 1U) << "level " << level_a;
    EXPECT_EQ(result.rejected_by_cross_check, 0);
  }
}

TEST(Matchers, InconsistentInputIsAnInvariantError) {
  const Scene scene = make_scene(seeded(66));
  EXPECT_THROW(match_by_projection(scene.a, scene.p_a, scene.b, FeaturePoints(3), scene.T_a_b, MatcherConfig{}),
               InvariantError);
  EXPECT_THROW(match_by_projection(scene.a, FeaturePoints(3), scene.b, scene.p_b, scene.T_a_b, MatcherConfig{}),
               InvariantError);
  Frame no_angles = scene.b;
  no_angles.keypoints.clear();
  EXPECT_THROW(match_by_projection(scene.a, scene.p_a, no_angles, scene.p_b, scene.T_a_b, MatcherConfig{}),
               InvariantError);
  MatcherConfig no_rotation_check = single_stage();
  no_rotation_check.check_orientation = false;
  EXPECT_NO_THROW(match_by_projection(scene.a, FeaturePoints(3), no_angles, scene.p_b, scene.T_a_b, no_rotation_check));
  // A frame whose features changed after finalize() has a stale grid: caught, not read out of range.
  Frame grown = scene.a;
  grown.uv.push_back(grown.uv.front());
  grown.level.push_back(grown.level.front());
  grown.keypoints.push_back(grown.keypoints.front());
  grown.depth_m.push_back(grown.depth_m.front());
  grown.u_right.push_back(grown.u_right.front());
  cv::vconcat(grown.descriptors, grown.descriptors.row(0), grown.descriptors);
  FeaturePoints grown_points = scene.p_a;
  grown_points.push_back(grown_points.front());
  EXPECT_THROW(match_by_projection(grown, grown_points, scene.b, scene.p_b, scene.T_a_b, MatcherConfig{}), InvariantError);
  grown.finalize();
  EXPECT_NO_THROW(match_by_projection(grown, grown_points, scene.b, scene.p_b, scene.T_a_b, MatcherConfig{}));
}

TEST(Projection, RatioTestAndDistanceThreshold) {
  std::mt19937 rng(63);
  const Descriptor d = random_descriptor(rng);
  const Scene ambiguous = hand_scene({feature_at(302.0, 200.0, 0, flipped(d, 20, rng), 0),
                                      feature_at(298.0, 200.0, 0, flipped(d, 21, rng), 1)},
                                     {feature_at(300.0, 200.0, 0, d, 0)});
  MatcherConfig config = single_stage();
  EXPECT_TRUE(project(ambiguous, config).matches.empty());  // 20 > 0.9 * 21
  config.nn_ratio = 1.0;
  const MatchResult accepted = project(ambiguous, config);
  ASSERT_EQ(accepted.matches.size(), 1U);
  EXPECT_EQ(accepted.matches[0].a, 0);
  EXPECT_EQ(accepted.matches[0].distance, 20);

  const Scene far = hand_scene({feature_at(302.0, 200.0, 0, flipped(d, 60, rng), 0)}, {feature_at(300.0, 200.0, 0, d, 0)});
  config.max_distance = 50;
  EXPECT_TRUE(project(far, config).matches.empty());
  config.max_distance = 60;
  EXPECT_EQ(project(far, config).matches.size(), 1U);
}

// --- Unchecked pairs and empty input ---

TEST(CrossValidation, PairsWithoutAPointInAAreKeptAndCounted) {
  const Scene scene = make_scene(seeded(71));
  const MatchResult single = project(scene, single_stage());
  FeaturePoints none(scene.a.size());
  const MatchResult all_unchecked = match_by_projection(scene.a, none, scene.b, scene.p_b, scene.T_a_b, MatcherConfig{});
  EXPECT_EQ(all_unchecked.matches.size(), single.matches.size());
  EXPECT_EQ(all_unchecked.unchecked, static_cast<int>(single.matches.size()));
  EXPECT_EQ(all_unchecked.rejected_by_cross_check, 0);

  FeaturePoints half = scene.p_a;
  for (std::size_t i = 0; i < half.size(); i += 2) half[i].reset();
  const MatchResult mixed = match_by_projection(scene.a, half, scene.b, scene.p_b, scene.T_a_b, MatcherConfig{});
  const auto without_point = std::count_if(single.matches.begin(), single.matches.end(), [](const Match& m) { return m.a % 2 == 0; });
  EXPECT_EQ(mixed.unchecked, static_cast<int>(without_point));
  EXPECT_EQ(static_cast<int>(mixed.matches.size()) + mixed.rejected_by_cross_check, mixed.stage1_matches);
}

TEST(Matchers, EmptyFramesGiveNoMatches) {
  const Scene scene = make_scene(seeded(81));
  const Frame empty = make_frame({});
  const FeaturePoints no_points;
  for (const auto& config : {single_stage(), MatcherConfig{}}) {
    EXPECT_TRUE(match_by_projection(empty, no_points, scene.b, scene.p_b, scene.T_a_b, config).matches.empty());
    EXPECT_TRUE(match_by_projection(scene.a, scene.p_a, empty, no_points, scene.T_a_b, config).matches.empty());
    EXPECT_TRUE(match_by_projection(empty, no_points, empty, no_points, scene.T_a_b, config).matches.empty());
    const MatchResult no_depth_in_b =
        match_by_projection(scene.a, scene.p_a, scene.b, FeaturePoints(scene.b.size()), scene.T_a_b, config);
    EXPECT_TRUE(no_depth_in_b.matches.empty());
    EXPECT_EQ(no_depth_in_b.stage1_matches, 0);
  }
  EXPECT_TRUE(match_brute_force(empty, scene.b, MatcherConfig{}).matches.empty());
  EXPECT_TRUE(match_brute_force(scene.a, empty, MatcherConfig{}).matches.empty());
}

// --- Properties over seeds ---

void expect_invariants(const Scene& scene, const MatchResult& result, const MatcherConfig& config) {
  expect_one_to_one(result);
  for (const auto& m : result.matches) {
    const Descriptor& da = scene.fa[static_cast<std::size_t>(m.a)].descriptor;
    const Descriptor& db = scene.fb[static_cast<std::size_t>(m.b)].descriptor;
    EXPECT_EQ(m.distance, oracle_distance(da, db));
    EXPECT_LE(m.distance, config.max_distance);
  }
  EXPECT_EQ(static_cast<int>(result.matches.size()) + result.rejected_by_cross_check, result.stage1_matches);
  EXPECT_LE(result.unchecked, static_cast<int>(result.matches.size()));
}

// Exactly the reference's matches and counters, over scenes with repeated texture (close distances and
// ties), features at identical spots with identical descriptors (exact ties, which the lower index wins),
// wrong poses, forward motion (distance ratios that move the predicted level), A features without
// points, and radii, ratios and switches other than the defaults.
TEST(Projection, SameResultsAsTheStraightforwardReference) {
  int compared = 0, with_rejections = 0;
  for (unsigned seed = 200; seed < 220; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> angle(0.0, 0.05), shift(-0.08, 0.08), unit(0.0, 1.0);
    SceneOptions options;
    options.seed = seed;
    options.points = 100 + static_cast<int>(seed % 7) * 80;
    options.repeated_texture = 0.6 * unit(rng);
    options.max_flips = 6 + static_cast<int>(seed % 9);
    options.level_change = 0.3;
    // Every fourth scene B is 0.3-0.6 m ahead of or behind A.
    const double forward = seed % 4 == 3 ? (seed % 8 == 3 ? 1.0 : -1.0) * (0.3 + 0.3 * unit(rng)) : 0.0;
    options.T_a_b = core::make_pose(Eigen::Vector3d(shift(rng), shift(rng), shift(rng) + forward),
                                    Eigen::Quaterniond(Eigen::AngleAxisd(angle(rng), Eigen::Vector3d(0.3, 1.0, 0.2).normalized())));
    Scene scene = make_scene(options);
    for (std::size_t i = 0; i < scene.fa.size(); i += 9) scene.fa.push_back(scene.fa[i]);  // exact twins in A
    for (std::size_t i = 0; i < scene.fb.size(); i += 11) scene.fb.push_back(scene.fb[i]);  // and in B
    scene.build();
    const Eigen::Isometry3d off = scene.T_a_b * core::make_pose(Eigen::Vector3d(0.01, 0.0, 0.0),
                                                                Eigen::Quaterniond(Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitY())));
    FeaturePoints some_a = scene.p_a;
    for (std::size_t i = 0; i < some_a.size(); i += 4) some_a[i].reset();
    for (int variant = 0; variant < 10; ++variant) {
      MatcherConfig config;
      config.cross_validation = variant % 2 == 1;
      if (variant / 2 == 1) {
        config.radius_px = 30.0;
        config.r2_over_r1 = 0.3;
      } else if (variant / 2 == 2) {
        config.nn_ratio = 1.0;  // exact ties pass: the lower index must win
        config.check_orientation = false;
        config.r2_over_r1 = 1.0;
      } else if (variant / 2 == 3) {
        config.radius_px = 5.0;
        config.max_distance = 50;
      } else if (variant / 2 == 4) {
        config.nn_ratio = 1.0;
        config.radius_px = 40.0;
      }
      const Eigen::Isometry3d& pose = variant % 4 < 2 ? scene.T_a_b : off;
      const FeaturePoints& p_a = seed % 3 == 0 ? some_a : scene.p_a;
      SCOPED_TRACE("variant " + std::to_string(variant));
      const MatchResult expected = reference_match(scene.a, p_a, scene.b, scene.p_b, pose, config);
      expect_same_result(expected, match_by_projection(scene.a, p_a, scene.b, scene.p_b, pose, config));
      ++compared;
      with_rejections += expected.rejected_by_cross_check > 0 ? 1 : 0;
    }
  }
  EXPECT_EQ(compared, 200);
  EXPECT_GE(with_rejections, 30);  // of 100 runs with stage 2: it had work to do
}

TEST(Matchers, PropertiesOverSeeds) {
  for (unsigned seed = 100; seed < 125; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> angle(0.0, 0.06), shift(-0.1, 0.1);
    std::uniform_int_distribution<int> points(0, 600), flips(4, 14);
    std::uniform_real_distribution<double> repeated(0.0, 0.3);
    SceneOptions options;
    options.seed = seed;
    options.points = points(rng);
    options.max_flips = flips(rng);
    options.repeated_texture = repeated(rng);
    options.T_a_b = core::make_pose(Eigen::Vector3d(shift(rng), shift(rng), shift(rng)),
                                    Eigen::Quaterniond(Eigen::AngleAxisd(angle(rng), Eigen::Vector3d(0.3, 1.0, 0.2).normalized())));
    const Scene scene = make_scene(options);
    const MatchResult brute = match_brute_force(scene.a, scene.b, MatcherConfig{});
    const MatchResult single = project(scene, single_stage());
    const MatchResult cross = project(scene, MatcherConfig{});
    expect_invariants(scene, brute, MatcherConfig{});
    expect_invariants(scene, single, single_stage());
    expect_invariants(scene, cross, MatcherConfig{});
    EXPECT_EQ(cross.stage1_matches, static_cast<int>(single.matches.size()));
    for (const auto& m : cross.matches) EXPECT_TRUE(contains(single, m.a, m.b));
    // Repeated texture fools brute force now and then; projection only where copies lie within r1.
    EXPECT_GE(quality(scene, brute).precision, 0.9);
    EXPECT_GE(quality(scene, single).precision, 0.97);
    EXPECT_GE(quality(scene, cross).precision, std::max(0.98, quality(scene, single).precision - 1e-9));
    if (scene.true_pairs() >= 50) {
      EXPECT_GE(quality(scene, cross).recall, 0.85);
    }
    const MatchResult again = project(scene, MatcherConfig{});  // deterministic
    ASSERT_EQ(again.matches.size(), cross.matches.size());
    for (std::size_t i = 0; i < again.matches.size(); ++i) {
      EXPECT_EQ(again.matches[i].a, cross.matches[i].a);
      EXPECT_EQ(again.matches[i].b, cross.matches[i].b);
    }
  }
}

}  // namespace
}  // namespace fleetslam::slam
