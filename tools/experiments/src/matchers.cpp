#include "fleetslam/experiments/matchers.hpp"

#include <cstdlib>
#include <limits>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/flann.hpp>

namespace fleetslam::experiments {
namespace {

// B's descriptors against A's, two nearest neighbours, Lowe's ratio (a lone neighbour is kept).
std::vector<slam::Match> ratio_matches(const std::vector<std::vector<cv::DMatch>>& knn, float ratio) {
  std::vector<slam::Match> matches;
  for (const auto& nn : knn) {
    if (nn.empty()) continue;
    if (nn.size() >= 2 && nn[0].distance > ratio * nn[1].distance) continue;
    matches.push_back({nn[0].trainIdx, nn[0].queryIdx, static_cast<int>(nn[0].distance)});
  }
  return matches;
}

std::vector<slam::Match> run_opencv(cv::DescriptorMatcher& matcher, const MatchPair& pair, float ratio) {
  if (pair.a.descriptors.empty() || pair.b.descriptors.empty()) return {};
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(pair.b.descriptors, pair.a.descriptors, knn, 2);
  return ratio_matches(knn, ratio);
}

// Where B's point i lands in A (or A's point in B), when it has a point and lands in front.
std::optional<Eigen::Vector2d> transfer(const slam::FeaturePoints& points, std::size_t i, const Eigen::Isometry3d& T,
                                        const core::PinholeCamera& camera) {
  if (i >= points.size() || !points[i]) return std::nullopt;
  const Eigen::Vector3d p = T * *points[i];
  if (p.z() <= 0.0) return std::nullopt;
  return camera.project(p);
}

}  // namespace

std::string to_string(MatcherKind kind) {
  switch (kind) {
    case MatcherKind::kBruteForce: return "brute_force";
    case MatcherKind::kBruteForceOpenCv: return "brute_force_opencv";
    case MatcherKind::kFlannLsh: return "flann_lsh";
    case MatcherKind::kGrid: return "grid";
    case MatcherKind::kCrossValidation: return "cross_validation";
  }
  return "unknown";
}

std::vector<MatcherKind> all_matchers() {
  return {MatcherKind::kBruteForce, MatcherKind::kBruteForceOpenCv, MatcherKind::kFlannLsh, MatcherKind::kGrid,
          MatcherKind::kCrossValidation};
}

std::optional<MatcherKind> matcher_from_string(const std::string& name) {
  for (const MatcherKind kind : all_matchers()) {
    if (to_string(kind) == name) return kind;
  }
  return std::nullopt;
}

std::vector<slam::Match> run_matcher(MatcherKind kind, const MatchPair& pair, const MatchSettings& settings) {
  switch (kind) {
    case MatcherKind::kBruteForce:
      return slam::match_brute_force(pair.a, pair.b, settings.projection).matches;
    case MatcherKind::kBruteForceOpenCv: {
      cv::BFMatcher matcher(cv::NORM_HAMMING);
      return run_opencv(matcher, pair, settings.lowe_ratio);
    }
    case MatcherKind::kFlannLsh: {
      std::srand(settings.lsh_seed);  // the LSH tables' hash bits come from rand()
      cv::FlannBasedMatcher matcher(
          cv::makePtr<cv::flann::LshIndexParams>(settings.lsh_tables, settings.lsh_key_bits, settings.lsh_multi_probe));
      return run_opencv(matcher, pair, settings.lowe_ratio);
    }
    case MatcherKind::kGrid:
    case MatcherKind::kCrossValidation: {
      slam::MatcherConfig config = settings.projection;
      config.cross_validation = kind == MatcherKind::kCrossValidation;
      return slam::match_by_projection(pair.a, pair.p_a, pair.b, pair.p_b, pair.T_a_b_predicted, config).matches;
    }
  }
  return {};
}

double MatchQuality::precision() const {
  return verifiable > 0 ? static_cast<double>(correct) / verifiable : std::numeric_limits<double>::quiet_NaN();
}

double MatchQuality::recall() const {
  return with_partner > 0 ? static_cast<double>(correct_with_partner) / with_partner
                          : std::numeric_limits<double>::quiet_NaN();
}

MatchQuality& MatchQuality::operator+=(const MatchQuality& o) {
  matches += o.matches;
  verifiable += o.verifiable;
  correct += o.correct;
  with_partner += o.with_partner;
  correct_with_partner += o.correct_with_partner;
  return *this;
}

MatchQuality evaluate_matches(const MatchPair& pair, const std::vector<slam::Match>& matches, double correct_px) {
  MatchQuality q;
  const Eigen::Isometry3d T_b_a = pair.T_a_b_true.inverse();
  std::vector<bool> has_partner(pair.b.uv.size(), false);
  for (std::size_t i = 0; i < pair.b.uv.size(); ++i) {
    const auto uv = transfer(pair.p_b, i, pair.T_a_b_true, pair.a.camera);
    if (!uv) continue;
    for (const Eigen::Vector2d& uv_a : pair.a.uv) {
      if ((uv_a - *uv).norm() <= correct_px) {
        has_partner[i] = true;
        ++q.with_partner;
        break;
      }
    }
  }
  q.matches = static_cast<int>(matches.size());
  for (const slam::Match& m : matches) {
    const auto ia = static_cast<std::size_t>(m.a), ib = static_cast<std::size_t>(m.b);
    if (const auto uv = transfer(pair.p_b, ib, pair.T_a_b_true, pair.a.camera); pair.p_b.size() > ib && pair.p_b[ib]) {
      ++q.verifiable;
      const bool good = uv && (*uv - pair.a.uv[ia]).norm() <= correct_px;
      q.correct += good ? 1 : 0;
      q.correct_with_partner += good && has_partner[ib] ? 1 : 0;
    } else if (pair.p_a.size() > ia && pair.p_a[ia]) {
      ++q.verifiable;
      const auto back = transfer(pair.p_a, ia, T_b_a, pair.b.camera);
      q.correct += back && (*back - pair.b.uv[ib]).norm() <= correct_px ? 1 : 0;
    }
  }
  return q;
}

}  // namespace fleetslam::experiments
