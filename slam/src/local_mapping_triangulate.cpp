// New map points from features of the current keyframe that no point holds, matched with covisible
// keyframes along the epipolar line and triangulated (or taken from the depth of the view with the
// larger stereo parallax). Without a bag of words the candidate search is brute force over the free
// features of both keyframes, pruned by the epipolar distance before any descriptor comparison.

#include <cmath>
#include <limits>
#include <map>

#include <Eigen/SVD>

#include "fleetslam/core/se3.hpp"
#include "fleetslam/slam/local_mapping.hpp"
#include "fleetslam/slam/matcher.hpp"

namespace fleetslam::slam {
namespace {

constexpr double kChi2Mono = 5.991;    // 95 %, 2 dof
constexpr double kChi2Stereo = 7.815;  // 95 %, 3 dof
constexpr double kEpipolarChi2 = 3.84;  // 95 %, 1 dof

struct View {
  const Keyframe& kf;
  Eigen::Isometry3d T_cw;
};

Eigen::Vector3d normalized_ray(const Frame& f, std::size_t i) {
  return {(f.uv[i].x() - f.camera.cx()) / f.camera.fx(), (f.uv[i].y() - f.camera.cy()) / f.camera.fy(), 1.0};
}

// Fundamental matrix mapping a pixel of view 1 to its epipolar line in view 2.
Eigen::Matrix3d fundamental_21(const View& v1, const View& v2) {
  const Eigen::Isometry3d T_21 = v2.T_cw * v1.kf.T_world_cam;
  const Eigen::Matrix3d E = core::hat(T_21.translation()) * T_21.linear();
  return v2.kf.frame.camera.K().transpose().inverse() * E * v1.kf.frame.camera.K().inverse();
}

std::vector<std::size_t> free_features(const Frame& f) {
  std::vector<std::size_t> free;
  for (std::size_t i = 0; i < f.size(); ++i) {
    if (f.map_points[i] == kNoMapPoint) free.push_back(i);
  }
  return free;
}

struct EpipolarMatch {
  std::size_t i1 = 0;
  int distance = std::numeric_limits<int>::max();
};

// Best free feature of view 2 for each free feature of view 1 (each feature of view 2 used once).
std::map<std::size_t, EpipolarMatch> epipolar_matches(const View& v1, const View& v2, const LocalMappingConfig& config) {
  const Frame& f1 = v1.kf.frame;
  const Frame& f2 = v2.kf.frame;
  const Eigen::Matrix3d F21 = fundamental_21(v1, v2);
  const Eigen::Vector3d epipole = f2.camera.K() * (v2.T_cw * v1.kf.center());
  // Projective: view 1's centre behind view 2 (moving backwards) meets the image at the same point.
  const bool epipole_valid = epipole.z() != 0.0;
  const Eigen::Vector2d e2 = epipole_valid ? Eigen::Vector2d(epipole.head<2>() / epipole.z()) : Eigen::Vector2d::Zero();
  const std::vector<std::size_t> free2 = free_features(f2);
  std::map<std::size_t, EpipolarMatch> best_for_2;
  for (std::size_t i1 : free_features(f1)) {
    const Eigen::Vector3d line = F21 * Eigen::Vector3d(f1.uv[i1].x(), f1.uv[i1].y(), 1.0);
    const double norm2 = line.head<2>().squaredNorm();
    if (!(norm2 > 0.0)) continue;
    int best = std::numeric_limits<int>::max(), second = best;
    std::size_t best_i2 = 0;
    for (std::size_t i2 : free2) {
      const double sigma2 = f2.pyramid.sigma2[static_cast<std::size_t>(f2.level[i2])];
      const double d = line.dot(Eigen::Vector3d(f2.uv[i2].x(), f2.uv[i2].y(), 1.0));
      if (d * d / norm2 > kEpipolarChi2 * sigma2) continue;
      // Near the epipole the line direction is ill-defined (unless depth pins the point down): ORB-SLAM's
      // squared distance below 100 * scale, a radius of 10 * sqrt(scale) px.
      const double scale = f2.pyramid.scale[static_cast<std::size_t>(f2.level[i2])];
      if (epipole_valid && !f1.has_depth(i1) && !f2.has_depth(i2) && (f2.uv[i2] - e2).squaredNorm() < 100.0 * scale) {
        continue;
      }
      const int distance = hamming_distance(f1.descriptors.ptr<std::uint8_t>(static_cast<int>(i1)),
                                            f2.descriptors.ptr<std::uint8_t>(static_cast<int>(i2)));
      if (distance < best) {
        second = best, best = distance, best_i2 = i2;
      } else if (distance < second) {
        second = distance;
      }
    }
    if (best > config.triangulation_max_distance) continue;
    if (second < std::numeric_limits<int>::max() && best > config.triangulation_nn_ratio * second) continue;
    auto [it, inserted] = best_for_2.try_emplace(best_i2, EpipolarMatch{i1, best});
    if (!inserted && best < it->second.distance) it->second = EpipolarMatch{i1, best};
  }
  return best_for_2;
}

// Linear (DLT) triangulation from two normalised rays and camera-from-world poses.
std::optional<Eigen::Vector3d> triangulate_dlt(const Eigen::Vector3d& x1, const Eigen::Isometry3d& T1,
                                               const Eigen::Vector3d& x2, const Eigen::Isometry3d& T2) {
  Eigen::Matrix4d A;
  const Eigen::Matrix<double, 3, 4> P1 = T1.matrix().topRows<3>(), P2 = T2.matrix().topRows<3>();
  A.row(0) = x1.x() * P1.row(2) - P1.row(0);
  A.row(1) = x1.y() * P1.row(2) - P1.row(1);
  A.row(2) = x2.x() * P2.row(2) - P2.row(0);
  A.row(3) = x2.y() * P2.row(2) - P2.row(1);
  const Eigen::JacobiSVD<Eigen::Matrix4d> svd(A, Eigen::ComputeFullV);
  const Eigen::Vector4d X = svd.matrixV().col(3);
  if (std::abs(X(3)) < 1e-12) return std::nullopt;
  return Eigen::Vector3d(X.head<3>() / X(3));
}

// Cosine of the parallax a feature's stereo (or virtual) baseline gives at its depth; 2 without depth.
double stereo_parallax_cos(const Frame& f, std::size_t i) {
  if (!f.has_depth(i) || !(f.bf > 0.0)) return 2.0;
  const double baseline = f.bf / f.camera.fx();
  return std::cos(2.0 * std::atan2(baseline / 2.0, f.depth_m[i]));
}

// The reprojection in view v of point p_world agrees with feature i (chi-square at 95 %).
bool reprojects(const View& v, std::size_t i, const Eigen::Vector3d& p_world) {
  const Frame& f = v.kf.frame;
  const Eigen::Vector3d p = v.T_cw * p_world;
  if (p.z() <= 0.0) return false;
  const double u = f.camera.fx() * p.x() / p.z() + f.camera.cx();
  const double w = f.camera.fy() * p.y() / p.z() + f.camera.cy();
  double e2 = (u - f.uv[i].x()) * (u - f.uv[i].x()) + (w - f.uv[i].y()) * (w - f.uv[i].y());
  const double sigma2 = f.pyramid.sigma2[static_cast<std::size_t>(f.level[i])];
  if (!f.has_right(i)) return e2 <= kChi2Mono * sigma2;
  const double u_right = u - f.bf / p.z();
  e2 += (u_right - f.u_right[i]) * (u_right - f.u_right[i]);
  return e2 <= kChi2Stereo * sigma2;
}

std::optional<Eigen::Vector3d> point_from_pair(const View& v1, std::size_t i1, const View& v2, std::size_t i2,
                                               const LocalMappingConfig& config) {
  const Frame& f1 = v1.kf.frame;
  const Frame& f2 = v2.kf.frame;
  const Eigen::Vector3d x1 = normalized_ray(f1, i1), x2 = normalized_ray(f2, i2);
  const Eigen::Vector3d ray1 = v1.kf.T_world_cam.linear() * x1, ray2 = v2.kf.T_world_cam.linear() * x2;
  const double cos_rays = ray1.dot(ray2) / (ray1.norm() * ray2.norm());
  const double cos_stereo1 = stereo_parallax_cos(f1, i1), cos_stereo2 = stereo_parallax_cos(f2, i2);
  const double cos_stereo = std::min(cos_stereo1, cos_stereo2);
  std::optional<Eigen::Vector3d> p;
  if (cos_rays > 0.0 && cos_rays < cos_stereo && (cos_stereo < 2.0 || cos_rays < config.min_parallax_cos)) {
    p = triangulate_dlt(x1, v1.T_cw, x2, v2.T_cw);
  } else if (cos_stereo1 < cos_stereo2) {
    if (auto p_cam = f1.unproject(i1)) p = v1.kf.T_world_cam * *p_cam;
  } else if (cos_stereo2 < cos_stereo1) {
    if (auto p_cam = f2.unproject(i2)) p = v2.kf.T_world_cam * *p_cam;
  }
  if (!p || !p->allFinite() || !reprojects(v1, i1, *p) || !reprojects(v2, i2, *p)) return std::nullopt;
  // Scale consistency: the distance ratio must agree with the pyramid levels the features came from.
  const double d1 = (*p - v1.kf.center()).norm(), d2 = (*p - v2.kf.center()).norm();
  if (!(d1 > 0.0) || !(d2 > 0.0)) return std::nullopt;
  const double ratio_distance = d2 / d1;
  const double ratio_octave = f1.pyramid.scale[static_cast<std::size_t>(f1.level[i1])] /
                              f2.pyramid.scale[static_cast<std::size_t>(f2.level[i2])];
  const double factor = 1.5 * f1.pyramid.scale_factor;
  if (ratio_distance * factor < ratio_octave || ratio_distance > ratio_octave * factor) return std::nullopt;
  return p;
}

// Too short a baseline gives no depth: below the stereo baseline (depth sensors), or 1 % of the scene.
bool baseline_too_short(const Keyframe& kf1, const Keyframe& kf2, const Map& map) {
  const double baseline = (kf1.center() - kf2.center()).norm();
  if (kf2.frame.bf > 0.0) return baseline < kf2.frame.bf / kf2.frame.camera.fx();
  return baseline / kf2.median_depth(map) < 0.01;
}

}  // namespace

int LocalMapper::triangulate(KeyframeId current, Map& map) {
  const Keyframe* kf1 = map.keyframe(current);
  if (kf1 == nullptr) return 0;
  int created = 0;
  for (KeyframeId neighbour : kf1->best_covisible(config_.triangulation_neighbours)) {
    const Keyframe* kf2 = map.keyframe(neighbour);
    if (kf2 == nullptr || baseline_too_short(*kf1, *kf2, map)) continue;
    const View v1{*kf1, kf1->T_cam_world()}, v2{*kf2, kf2->T_cam_world()};
    for (const auto& [i2, match] : epipolar_matches(v1, v2, config_)) {
      // Earlier pairs of this loop may have taken either feature.
      if (kf1->frame.map_points[match.i1] != kNoMapPoint || kf2->frame.map_points[i2] != kNoMapPoint) continue;
      const std::optional<Eigen::Vector3d> p = point_from_pair(v1, match.i1, v2, i2, config_);
      if (!p) continue;
      const MapPointId id = map.add_map_point(*p, current, static_cast<int>(match.i1));
      map.add_observation(id, neighbour, static_cast<int>(i2));
      map.update_point_statistics(id);
      recent_points_.push_back(id);
      ++created;
    }
  }
  return created;
}

}  // namespace fleetslam::slam
