#pragma once
// Noise models for rendered images, each with its own seeded generator.
//  - Depth (Kinect-like, after Nguyen, Izadi & Lovell 2012): axial noise growing with distance,
//    sigma_z = sigma_base_m + sigma_quadratic * (z - 0.4)^2, dropout at grazing incidence (angle between
//    the surface normal, estimated from the depth image, and the viewing ray) and near depth edges,
//    and a valid range. Invalid depth is 0.
//    Normals come from the clean input depth back-projected with the camera (its gradient by central
//    differences, one-sided towards the neighbour nearer in depth beside holes and depth edges); edges
//    are 4-neighbour jumps above edge_jump_m between valid pixels, widened by edge_band_px (square
//    neighbourhood). The range applies to the true depth; invalid input (0, NaN, infinite, negative)
//    is never kept. Draws, row-major within a row band: one Gaussian for each pixel (kept or not, so
//    that they do not depend on the image), and one uniform for each in-range band pixel not dropped
//    at grazing incidence (none when the edge probability is 1).
//  - Image: additive Gaussian noise on 8-bit intensities, and optional slow exposure (gain) changes:
//    out = saturate(round(gain * in + sigma_intensity * n)), log gain an Ornstein-Uhlenbeck process
//    (stationary std exposure_sigma, time constant exposure_correlation_s) starting at 0. The noise is
//    per channel of a colour image: a gray image made from it afterwards (the EuRoC export) sees about
//    0.67 sigma_intensity (camera.gray applies it to the gray image itself). World gives a stereo
//    pair's right image the left image's gain (one exposure per head) and pixel noise of its own.
// Gaussian pixel noise is drawn from a 2^16-entry quantile table of N(0, 1) (tails cut at ~4.3 sigma),
// indexed by 16-bit pieces of fast streams (wyrand) that one draw of the model's generator seeds, so a
// model's generator advances one draw per image (plus the exposure process's). An image is drawn in
// a fixed partition into eight bands of whole rows, each with its own streams, in parallel on
// OpenCV's thread pool: the same seed gives the same images with any thread count, with or without
// AVX2. A 640x480 frame takes about a millisecond on one core. The Gaussian draws do not depend on the
// image: each model's work splits into next() (the draws, in order), expand() (the pixel noise, most of
// the work) and apply(), so the simulator expands an image's noise while it renders the image.
// Disabled models return an unchanged deep copy and draw nothing.

#include <cstdint>
#include <random>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "fleetslam/core/camera.hpp"
#include "fleetslam/core/config.hpp"
#include "fleetslam/core/time.hpp"

namespace fleetslam::sim {

struct DepthNoiseConfig {
  bool enabled = true;
  double sigma_base_m = 0.0012;
  double sigma_quadratic = 0.0019;     // metres per metre^2
  double min_depth_m = 0.3;
  double max_depth_m = 8.0;
  double grazing_dropout_deg = 78.0;   // incidence angles beyond this are dropped
  double edge_jump_m = 0.1;            // a neighbour this much farther or nearer marks a depth edge
  int edge_band_px = 1;                // pixels within this distance of an edge ...
  double edge_dropout_probability = 0.5;  // ... are dropped with this probability

  template <class V>
  void visit(V& v) {
    v("enabled", enabled);
    v("sigma_base_m", sigma_base_m, core::Limits<double>{0.0, 1.0});
    v("sigma_quadratic", sigma_quadratic, core::Limits<double>{0.0, 1.0});
    v("min_depth_m", min_depth_m, core::Limits<double>{0.0, 100.0});
    v("max_depth_m", max_depth_m, core::Limits<double>{0.01, 1000.0});
    v("grazing_dropout_deg", grazing_dropout_deg, core::Limits<double>{0.0, 90.0});
    v("edge_jump_m", edge_jump_m, core::Limits<double>{0.0, 100.0});
    v("edge_band_px", edge_band_px, core::Limits<int>{0, 20});
    v("edge_dropout_probability", edge_dropout_probability, core::Limits<double>{0.0, 1.0});
  }
};

// One depth image's draw from its model's generator (DepthNoiseModel::next): what its noise depends
// on besides the image. None from a disabled model.
struct DepthNoiseDraw {
  bool enabled = false;
  std::uint64_t seed = 0;
};

// A depth image's Gaussian noise expanded from its draw (DepthNoiseModel::expand), the part of the
// model's work that does not need the image.
struct DepthNoiseField {
  DepthNoiseDraw draw;
  cv::Mat noise;  // CV_32FC1 unit normals, one per pixel; empty without a draw
};

class DepthNoiseModel {
 public:
  // Throws std::invalid_argument when min_depth_m >= max_depth_m.
  DepthNoiseModel(const DepthNoiseConfig& config, std::uint64_t seed);
  // depth_m: CV_32FC1 metres (0 = none) seen by `camera` (undistorted pinhole). Returns a new image:
  // apply(depth_m, camera, expand(next(), depth_m.size())). Throws std::invalid_argument on another
  // type or a size other than the camera's.
  cv::Mat apply(const cv::Mat& depth_m, const core::PinholeCamera& camera);

  // The same in three steps, so that the image-independent work runs while the image is rendered:
  // next() draws the image's seed (in image order, on one thread); expand() is a pure function of the
  // draw and the model's config, safe on any thread (parallel: its row bands on OpenCV's pool);
  // apply() also throws when the field is not of the image's size.
  DepthNoiseDraw next();
  DepthNoiseField expand(const DepthNoiseDraw& draw, cv::Size size, bool parallel = true) const;
  cv::Mat apply(const cv::Mat& depth_m, const core::PinholeCamera& camera, const DepthNoiseField& field) const;
  // Standard deviation of the axial noise at a depth (the model's sigma_z).
  double axial_sigma_m(double depth_m) const;

 private:
  DepthNoiseConfig config_;
  std::mt19937_64 rng_;
};

struct ImageNoiseConfig {
  bool enabled = true;
  double sigma_intensity = 2.0;       // Gaussian noise, 8-bit levels
  bool exposure_changes = false;
  double exposure_sigma = 0.15;       // std of the log gain
  double exposure_correlation_s = 2.0;  // time constant of the gain's random process

  template <class V>
  void visit(V& v) {
    v("enabled", enabled);
    v("sigma_intensity", sigma_intensity, core::Limits<double>{0.0, 64.0});
    v("exposure_changes", exposure_changes);
    v("exposure_sigma", exposure_sigma, core::Limits<double>{0.0, 2.0});
    v("exposure_correlation_s", exposure_correlation_s, core::Limits<double>{0.01, 1000.0});
  }
};

// One image's draws from its model's generator (ImageNoiseModel::next): the exposure gain at its time
// and the seed of its pixel noise. Gain 1 and no pixel noise from a disabled model.
struct ImageNoiseDraw {
  double gain = 1.0;
  bool pixel_noise = false;  // sigma_intensity != 0
  std::uint64_t seed = 0;
};

// An image's pixel noise expanded from its draw (ImageNoiseModel::expand): nearly all of the model's
// work, none of which needs the image.
struct ImageNoiseField {
  ImageNoiseDraw draw;
  // rows x (cols * channels) values: CV_8SC1 round(sigma_intensity n) at unit gain (where that fits in
  // a byte), else CV_32FC1 unit normals n; empty without pixel noise.
  cv::Mat noise;
};

class ImageNoiseModel {
 public:
  // Throws std::invalid_argument when exposure_correlation_s is not positive.
  ImageNoiseModel(const ImageNoiseConfig& config, std::uint64_t seed);
  // image: CV_8UC1 or CV_8UC3. Returns a new image: apply(image, expand(next(t_ns), size, channels)).
  // t_ns drives the exposure process (call in time order; an earlier t_ns than the previous call's
  // throws std::invalid_argument, as does another image type).
  cv::Mat apply(const cv::Mat& image, core::TimeNs t_ns);

  // The same in three steps, so that the image-independent work runs while the image is rendered:
  // next() advances the exposure process and draws the image's seed (in time order, on one thread);
  // expand() is a pure function of the draw and the model's config, safe on any thread (parallel: its
  // row bands on OpenCV's pool); apply() also throws when the field is not of the image's size.
  ImageNoiseDraw next(core::TimeNs t_ns);
  ImageNoiseField expand(const ImageNoiseDraw& draw, cv::Size size, int channels, bool parallel = true) const;
  cv::Mat apply(const cv::Mat& image, const ImageNoiseField& field) const;
  double current_gain() const { return gain_; }

 private:
  void advance_exposure(core::TimeNs t_ns);

  ImageNoiseConfig config_;
  std::mt19937_64 rng_;
  double log_gain_ = 0.0;
  double gain_ = 1.0;
  core::TimeNs last_t_ns_ = 0;
  bool has_last_ = false;
  std::vector<std::int8_t> rounded_noise_;  // round(sigma_intensity n) per Gaussian table entry, or empty
};

}  // namespace fleetslam::sim
