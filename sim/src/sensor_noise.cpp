#include "fleetslam/sim/sensor_noise.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace fleetslam::sim {
namespace {

constexpr int kTableBits = 16;
constexpr std::size_t kTableSize = std::size_t{1} << kTableBits;

// Standard normal quantile of p by Newton's method from x0 <= root, for p >= 0.5: Phi is concave
// there, so the iterates increase monotonically to the root without overshooting.
double normal_quantile_from_below(double p, double x0) {
  const double inv_sqrt2 = 1.0 / std::sqrt(2.0);
  const double inv_sqrt_2pi = 1.0 / std::sqrt(2.0 * 3.14159265358979323846);
  double x = x0;
  for (int i = 0; i < 100; ++i) {
    const double cdf = 0.5 * std::erfc(-x * inv_sqrt2);
    const double step = (p - cdf) / (inv_sqrt_2pi * std::exp(-0.5 * x * x));
    x += step;
    if (std::abs(step) < 1e-13) break;
  }
  return x;
}

// Quantiles of N(0, 1) at the centres of 2^16 equal-probability bins, rescaled to exactly unit
// variance: indexing it with 16 uniform bits gives a Gaussian sample (tails cut at ~4.3 sigma) four
// times per 64-bit draw, about ten times faster than std::normal_distribution, which matters at
// 640x480x3 samples per frame.
std::vector<float> build_unit_normal_table() {
  std::vector<double> upper(kTableSize / 2);
  double x = 0.0;
  for (std::size_t i = 0; i < upper.size(); ++i) {
    const double p = (static_cast<double>(kTableSize / 2 + i) + 0.5) / static_cast<double>(kTableSize);
    x = normal_quantile_from_below(p, x);
    upper[i] = x;
  }
  double sum_sq = 0.0;
  for (double q : upper) sum_sq += q * q;
  const double scale = 1.0 / std::sqrt(sum_sq / static_cast<double>(upper.size()));
  std::vector<float> table(kTableSize);
  for (std::size_t i = 0; i < upper.size(); ++i) {
    table[kTableSize / 2 + i] = static_cast<float>(upper[i] * scale);
    table[kTableSize / 2 - 1 - i] = static_cast<float>(-upper[i] * scale);
  }
  return table;
}

// A constant (computed once, never written), not state: every model draws its own samples from its rng.
const std::vector<float>& unit_normal_table() {
  static const std::vector<float> table = build_unit_normal_table();
  return table;
}

// Fast unit Gaussian and uniform samples from one model's generator; see build_unit_normal_table.
class Sampler {
 public:
  explicit Sampler(std::mt19937_64& rng) : rng_(rng), table_(unit_normal_table().data()) {}

  float normal() {
    if (bits_left_ == 0) {
      bits_ = rng_();
      bits_left_ = 64 / kTableBits;
    }
    const float x = table_[bits_ & (kTableSize - 1)];
    bits_ >>= kTableBits;
    --bits_left_;
    return x;
  }
  // Uniform in [0, 1) from the top 53 bits of one draw.
  double uniform() { return static_cast<double>(rng_() >> 11) * 0x1.0p-53; }

 private:
  std::mt19937_64& rng_;
  const float* table_;
  std::uint64_t bits_ = 0;
  int bits_left_ = 0;
};

bool valid_depth(float z) { return z > 0.0f && z < std::numeric_limits<float>::infinity(); }

// 255 where a 4-neighbour of a valid pixel is valid and differs by more than jump_m, else 0.
cv::Mat depth_edges(const cv::Mat& depth_m, float jump_m) {
  cv::Mat edges(depth_m.size(), CV_8UC1, cv::Scalar(0));
  for (int v = 0; v < depth_m.rows; ++v) {
    const float* row = depth_m.ptr<float>(v);
    const float* below = v + 1 < depth_m.rows ? depth_m.ptr<float>(v + 1) : nullptr;
    std::uint8_t* e = edges.ptr<std::uint8_t>(v);
    std::uint8_t* e_below = below != nullptr ? edges.ptr<std::uint8_t>(v + 1) : nullptr;
    for (int u = 0; u < depth_m.cols; ++u) {
      const float z = row[u];
      if (!valid_depth(z)) continue;
      if (u + 1 < depth_m.cols && valid_depth(row[u + 1]) && std::abs(row[u + 1] - z) > jump_m) {
        e[u] = e[u + 1] = 255;
      }
      if (below != nullptr && valid_depth(below[u]) && std::abs(below[u] - z) > jump_m) {
        e[u] = e_below[u] = 255;
      }
    }
  }
  return edges;
}

// Pixels within band_px (Chebyshev distance) of a depth edge.
cv::Mat edge_band(const cv::Mat& depth_m, float jump_m, int band_px) {
  cv::Mat edges = depth_edges(depth_m, jump_m);
  if (band_px <= 0) return edges;
  cv::Mat band;
  const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * band_px + 1, 2 * band_px + 1));
  cv::dilate(edges, band, kernel);
  return band;
}

// Incidence test: the angle between the surface normal and the viewing ray, from the depth image's
// gradient. With P(u, v) = z (x_n, y_n, 1) the back-projected point, dP/du x dP/dv is parallel to
//   n = (-fx z_u, -fy z_v, fx z_u x_n + fy z_v y_n + z),  with n . (x_n, y_n, 1) = z,
// so cos^2(angle) = z^2 / (|n|^2 |ray|^2) and no cross product is needed per pixel. The derivatives
// z_u, z_v are central differences where both neighbours continue the surface, else one-sided to the
// neighbour nearer in depth: across a depth edge that is the pixel's own surface, and on a far
// grazing surface, where even neighbours differ by more than edge_jump_m, it is still the surface.
class GrazingTest {
 public:
  GrazingTest(const core::PinholeCamera& camera, double max_angle_deg, float jump_m)
      : jump_m_(jump_m),
        fx_(static_cast<float>(camera.fx())),
        fy_(static_cast<float>(camera.fy())),
        xn_(static_cast<std::size_t>(camera.width())),
        yn_(static_cast<std::size_t>(camera.height())) {
    for (int u = 0; u < camera.width(); ++u) xn_[index(u)] = static_cast<float>((u - camera.cx()) / camera.fx());
    for (int v = 0; v < camera.height(); ++v) yn_[index(v)] = static_cast<float>((v - camera.cy()) / camera.fy());
    const double c = std::cos(max_angle_deg * 3.14159265358979323846 / 180.0);
    min_cos_sq_ = static_cast<float>(c * c);
  }

  // True when the surface at (u, v) is seen beyond the angle; false when no normal can be estimated.
  // up / down are the neighbouring rows of `row`, null at the image border.
  bool grazing(const float* up, const float* row, const float* down, int u, int v, int width) const {
    const float z = row[u];
    float z_u = 0.0f;
    float z_v = 0.0f;
    if (!slope(z, u > 0 ? row[u - 1] : 0.0f, u + 1 < width ? row[u + 1] : 0.0f, &z_u)) return false;
    if (!slope(z, up != nullptr ? up[u] : 0.0f, down != nullptr ? down[u] : 0.0f, &z_v)) return false;
    const float xn = xn_[index(u)];
    const float yn = yn_[index(v)];
    const float gx = fx_ * z_u;
    const float gy = fy_ * z_v;
    const float nz = gx * xn + gy * yn + z;
    const float normal_sq = gx * gx + gy * gy + nz * nz;
    const float ray_sq = xn * xn + yn * yn + 1.0f;
    return z * z < min_cos_sq_ * normal_sq * ray_sq;
  }

 private:
  static std::size_t index(int i) { return static_cast<std::size_t>(i); }

  // Depth change per pixel between z's neighbours z_prev and z_next (see the class comment);
  // false without a valid neighbour.
  bool slope(float z, float z_prev, float z_next, float* dz) const {
    const float inf = std::numeric_limits<float>::infinity();
    const float jump_prev = valid_depth(z_prev) ? std::abs(z_prev - z) : inf;
    const float jump_next = valid_depth(z_next) ? std::abs(z_next - z) : inf;
    if (jump_prev == inf && jump_next == inf) return false;
    if (jump_prev <= jump_m_ && jump_next <= jump_m_) {
      *dz = 0.5f * (z_next - z_prev);
    } else {
      *dz = jump_prev < jump_next ? z - z_prev : z_next - z;
    }
    return true;
  }

  float jump_m_;
  float fx_;
  float fy_;
  float min_cos_sq_ = 0.0f;
  std::vector<float> xn_;
  std::vector<float> yn_;
};

void check_image_matches_camera(const cv::Mat& depth_m, const core::PinholeCamera& camera) {
  if (depth_m.type() != CV_32FC1) {
    throw std::invalid_argument("DepthNoiseModel::apply: depth must be CV_32FC1 metres");
  }
  if (depth_m.cols != camera.width() || depth_m.rows != camera.height()) {
    throw std::invalid_argument("DepthNoiseModel::apply: depth is " + std::to_string(depth_m.cols) + "x" +
                                std::to_string(depth_m.rows) + " but the camera is " +
                                std::to_string(camera.width()) + "x" + std::to_string(camera.height()));
  }
}

}  // namespace

DepthNoiseModel::DepthNoiseModel(const DepthNoiseConfig& config, std::uint64_t seed)
    : config_(config), rng_(seed) {
  if (!(config.min_depth_m < config.max_depth_m)) {
    throw std::invalid_argument("DepthNoiseModel: min_depth_m (" + std::to_string(config.min_depth_m) +
                                ") must be below max_depth_m (" + std::to_string(config.max_depth_m) + ")");
  }
}

double DepthNoiseModel::axial_sigma_m(double depth_m) const {
  // Nguyen, Izadi & Lovell 2012, eq. 2: sigma_z(z) = 0.0012 + 0.0019 (z - 0.4)^2 (Kinect v1, 10-60 deg).
  const double d = depth_m - 0.4;
  return config_.sigma_base_m + config_.sigma_quadratic * d * d;
}

cv::Mat DepthNoiseModel::apply(const cv::Mat& depth_m, const core::PinholeCamera& camera) {
  check_image_matches_camera(depth_m, camera);
  if (!config_.enabled) return depth_m.clone();

  const auto jump_m = static_cast<float>(config_.edge_jump_m);
  const bool edge_dropout = config_.edge_dropout_probability > 0.0;
  const bool grazing_dropout = config_.grazing_dropout_deg < 90.0;
  const cv::Mat band = edge_dropout ? edge_band(depth_m, jump_m, config_.edge_band_px) : cv::Mat();
  const GrazingTest grazing(camera, config_.grazing_dropout_deg, jump_m);
  const auto min_m = static_cast<float>(config_.min_depth_m);
  const auto max_m = static_cast<float>(config_.max_depth_m);
  const auto sigma_base_m = static_cast<float>(config_.sigma_base_m);
  const auto sigma_quadratic = static_cast<float>(config_.sigma_quadratic);

  // Draw order, row-major: one uniform for each in-range pixel in the edge band, then one Gaussian
  // for each pixel kept.
  Sampler sampler(rng_);
  cv::Mat noisy(depth_m.size(), CV_32FC1);
  for (int v = 0; v < depth_m.rows; ++v) {
    const float* in = depth_m.ptr<float>(v);
    const float* up = v > 0 ? depth_m.ptr<float>(v - 1) : nullptr;
    const float* down = v + 1 < depth_m.rows ? depth_m.ptr<float>(v + 1) : nullptr;
    const std::uint8_t* near_edge = edge_dropout ? band.ptr<std::uint8_t>(v) : nullptr;
    float* out = noisy.ptr<float>(v);
    for (int u = 0; u < depth_m.cols; ++u) {
      const float z = in[u];
      out[u] = 0.0f;
      if (!(z >= min_m && z <= max_m)) continue;  // also NaN and holes (0)
      if (near_edge != nullptr && near_edge[u] != 0 && sampler.uniform() < config_.edge_dropout_probability) {
        continue;
      }
      if (grazing_dropout && grazing.grazing(up, in, down, u, v, depth_m.cols)) continue;
      const float sigma_m = sigma_base_m + sigma_quadratic * (z - 0.4f) * (z - 0.4f);  // axial_sigma_m in float
      const float z_noisy = z + sigma_m * sampler.normal();
      out[u] = z_noisy > 0.0f ? z_noisy : 0.0f;
    }
  }
  return noisy;
}

ImageNoiseModel::ImageNoiseModel(const ImageNoiseConfig& config, std::uint64_t seed)
    : config_(config), rng_(seed) {
  if (!(config.exposure_correlation_s > 0.0)) {
    throw std::invalid_argument("ImageNoiseModel: exposure_correlation_s must be positive, got " +
                                std::to_string(config.exposure_correlation_s));
  }
}

void ImageNoiseModel::advance_exposure(core::TimeNs t_ns) {
  if (has_last_ && t_ns < last_t_ns_) {
    throw std::invalid_argument("ImageNoiseModel::apply: time went backwards (" + std::to_string(t_ns) +
                                " ns after " + std::to_string(last_t_ns_) + " ns)");
  }
  const bool first = !has_last_;
  const double dt_s = first ? 0.0 : core::ns_to_seconds(t_ns - last_t_ns_);
  has_last_ = true;
  last_t_ns_ = t_ns;
  if (!config_.exposure_changes || first) return;
  // Exact discretisation of the Ornstein-Uhlenbeck process dx = -x/tau dt + sigma sqrt(2/tau) dW:
  // x' = rho x + sigma sqrt(1 - rho^2) n with rho = exp(-dt/tau); its stationary std is exposure_sigma.
  const double rho = std::exp(-dt_s / config_.exposure_correlation_s);
  std::normal_distribution<double> unit(0.0, 1.0);
  log_gain_ = rho * log_gain_ + config_.exposure_sigma * std::sqrt(1.0 - rho * rho) * unit(rng_);
  gain_ = std::exp(log_gain_);
}

cv::Mat ImageNoiseModel::apply(const cv::Mat& image, core::TimeNs t_ns) {
  if (image.type() != CV_8UC1 && image.type() != CV_8UC3) {
    throw std::invalid_argument("ImageNoiseModel::apply: image must be CV_8UC1 or CV_8UC3");
  }
  if (!config_.enabled) return image.clone();
  advance_exposure(t_ns);
  if (config_.sigma_intensity == 0.0 && gain_ == 1.0) return image.clone();

  // Gain is applied to the clean intensity, then noise, then rounding and saturation to [0, 255].
  float scaled[256];
  for (int i = 0; i < 256; ++i) scaled[i] = static_cast<float>(gain_ * i);
  const auto sigma = static_cast<float>(config_.sigma_intensity);
  Sampler sampler(rng_);
  cv::Mat noisy(image.size(), image.type());
  const int values_per_row = image.cols * image.channels();
  for (int v = 0; v < image.rows; ++v) {
    const std::uint8_t* in = image.ptr<std::uint8_t>(v);
    std::uint8_t* out = noisy.ptr<std::uint8_t>(v);
    for (int k = 0; k < values_per_row; ++k) {
      out[k] = cv::saturate_cast<std::uint8_t>(scaled[in[k]] + sigma * sampler.normal());
    }
  }
  return noisy;
}

}  // namespace fleetslam::sim
