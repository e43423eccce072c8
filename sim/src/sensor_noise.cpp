#include "fleetslam/sim/sensor_noise.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/core/utility.hpp>

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

constexpr float kInf = std::numeric_limits<float>::infinity();

// splitmix64 (Steele, Lea & Flood 2014): turns one draw of a model's generator into the seeds of an
// image's streams.
std::uint64_t splitmix64(std::uint64_t* state) {
  std::uint64_t z = (*state += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

// Images are drawn in a fixed partition into row bands, each band with its own streams, so that the
// bands run in parallel on OpenCV's thread pool and the draws depend neither on the thread count
// nor on the order the bands run in.
constexpr int kRowBands = 8;

// Seeds of `per_band` streams for each row band (band b's stream s: entry b * per_band + s), the
// first draws of a splitmix64 sequence from one draw of a model's generator.
std::vector<std::uint64_t> row_band_seeds(std::uint64_t image_seed, int per_band) {
  std::vector<std::uint64_t> seeds(static_cast<std::size_t>(kRowBands * per_band));
  for (std::uint64_t& seed : seeds) seed = splitmix64(&image_seed);
  return seeds;
}

// body(band, first_row, end_row) for each non-empty band of rows [first_row, end_row) of an image
// `height` rows high, in parallel (or, with parallel false, one after the other on the calling thread).
template <class Body>
void for_each_row_band(int height, const Body& body, bool parallel = true) {
  const int rows_per_band = (height + kRowBands - 1) / kRowBands;
  const int bands = rows_per_band > 0 ? (height + rows_per_band - 1) / rows_per_band : 0;
  const auto run = [&](const cv::Range& range) {
    for (int b = range.start; b < range.end; ++b) {
      body(b, b * rows_per_band, std::min(height, (b + 1) * rows_per_band));
    }
  };
  if (parallel) {
    cv::parallel_for_(cv::Range(0, bands), run);
  } else {
    run(cv::Range(0, bands));
  }
}

// High and low halves of the 128-bit product, xor-ed.
std::uint64_t multiply_mix(std::uint64_t a, std::uint64_t b) {
#if defined(__SIZEOF_INT128__)
  __extension__ using Uint128 = unsigned __int128;
  const Uint128 product = static_cast<Uint128>(a) * b;
  return static_cast<std::uint64_t>(product >> 64) ^ static_cast<std::uint64_t>(product);
#else
  const std::uint64_t a_lo = a & 0xffffffffULL, a_hi = a >> 32, b_lo = b & 0xffffffffULL, b_hi = b >> 32;
  const std::uint64_t lo_lo = a_lo * b_lo, hi_lo = a_hi * b_lo, lo_hi = a_lo * b_hi, hi_hi = a_hi * b_hi;
  const std::uint64_t cross = (lo_lo >> 32) + (hi_lo & 0xffffffffULL) + lo_hi;
  const std::uint64_t high = hi_hi + (hi_lo >> 32) + (cross >> 32);
  const std::uint64_t low = (cross << 32) | (lo_lo & 0xffffffffULL);
  return high ^ low;
#endif
}

// wyrand (Wang Yi 2019, the generator of Go's runtime and Zig's standard library): a Weyl sequence
// mixed by one 64x64 -> 128-bit multiply; passes BigCrush and PractRand. Draws do not wait on each
// other (only the counter is carried), about ten times faster than std::mt19937_64 here.
class WyRand {
 public:
  explicit WyRand(std::uint64_t seed) : state_(seed) {}
  std::uint64_t operator()() {
    state_ += kIncrement;
    return multiply_mix(state_, state_ ^ kMix);
  }
  // The next draw, consumed only `if_taken` (without a branch: only the counter is carried).
  std::uint64_t next_if(bool if_taken) {
    const std::uint64_t counter = state_ + kIncrement;
    state_ += kIncrement * static_cast<std::uint64_t>(if_taken);
    return multiply_mix(counter, counter ^ kMix);
  }

 private:
  static constexpr std::uint64_t kIncrement = 0xa0761d6478bd642fULL;
  static constexpr std::uint64_t kMix = 0xe7037ed1a0b428dbULL;
  std::uint64_t state_;
};

// 16-bit indices into the unit normal table, consumed in order, four per 64-bit draw (in memory
// order: the stream is for little-endian machines).
class NormalIndexStream {
 public:
  // max_take: the largest n of take().
  NormalIndexStream(std::uint64_t seed, std::size_t max_take) : rng_(seed), buffer_(max_take + 4) {}

  // The next n indices, valid until the next call.
  const std::uint16_t* take(std::size_t n) {
    if (end_ - pos_ < n) refill();
    const std::uint16_t* indices = buffer_.data() + pos_;
    pos_ += n;
    return indices;
  }

 private:
  // Keeps the unread indices and fills the rest of the buffer. Not inlined: in a caller's loop the
  // 128-bit products went through the stack.
  [[gnu::noinline]] void refill() {
    std::copy(buffer_.begin() + static_cast<std::ptrdiff_t>(pos_), buffer_.begin() + static_cast<std::ptrdiff_t>(end_),
              buffer_.begin());
    WyRand rng = rng_;
    std::uint16_t* out = buffer_.data();
    std::size_t end = end_ - pos_;
#if defined(__GNUC__)
#pragma GCC unroll 4
#endif
    for (const std::size_t size = buffer_.size(); end + 4 <= size; end += 4) {
      const std::uint64_t bits = rng();
      std::memcpy(out + end, &bits, sizeof bits);
    }
    rng_ = rng;
    pos_ = 0;
    end_ = end;
  }

  WyRand rng_;
  std::vector<std::uint16_t> buffer_;
  std::size_t pos_ = 0;
  std::size_t end_ = 0;
};

// a where c, else b, as a bitwise select: unlike ?:, it keeps a loop free of branches for the
// vectoriser (GCC will not evaluate a float operation that only one branch needs on both).
float select(bool c, float a, float b) {
  std::uint32_t a_bits, b_bits;
  std::memcpy(&a_bits, &a, sizeof a);
  std::memcpy(&b_bits, &b, sizeof b);
  const std::uint32_t mask = 0u - static_cast<std::uint32_t>(c);
  const std::uint32_t bits = (a_bits & mask) | (b_bits & ~mask);
  float r;
  std::memcpy(&r, &bits, sizeof r);
  return r;
}

// Row kernels (loops written to vectorise: selects, no branches) get an AVX2 clone beside the
// baseline SSE2 one where the toolchain dispatches at load time (GCC ifuncs on x86-64 Linux). Both
// compute the same values: IEEE additions, multiplications and comparisons only, and AVX2 brings
// no fused multiply-add, so images do not depend on the CPU.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define FLEETSLAM_ROW_KERNEL __attribute__((target_clones("avx2", "default")))
#else
#define FLEETSLAM_ROW_KERNEL
#endif

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// s[1 + u] = z[u] where valid (positive and finite), else NaN; s[0] = s[w + 1] = NaN. With NaN
// for invalid pixels, a jump |s[a] - s[b]| is NaN unless both are valid and fails every comparison.
FLEETSLAM_ROW_KERNEL void sanitize_row(const float* z, std::size_t w, float* s) {
  s[0] = s[w + 1] = kNaN;
  for (std::size_t u = 0; u < w; ++u) s[u + 1] = select((z[u] > 0.0f) & (z[u] < kInf), z[u], kNaN);
}

// left[u] = |s[u + 1] - s[u]| for u in [0, w] (pixels u - 1 and u; NaN at both ends), down[u] the jump
// from pixel u to the pixel below (s_down, a sanitised row; NaN without one).
FLEETSLAM_ROW_KERNEL void jumps_row(const float* s, const float* s_down, std::size_t w, float* left, float* down) {
  for (std::size_t u = 0; u <= w; ++u) left[u] = std::abs(s[u + 1] - s[u]);
  if (s_down == nullptr) {
    std::fill(down, down + w, kNaN);
    return;
  }
  for (std::size_t u = 0; u < w; ++u) down[u] = std::abs(s_down[u + 1] - s[u + 1]);
}

// edges[u] = 1 where a 4-neighbour jump of pixel u (left, right: left[u], left[u + 1]; up, down) is
// above jump_m, then widened along the row by band_px (scratch: w bytes).
FLEETSLAM_ROW_KERNEL void edges_row(const float* left, const float* up, const float* down, std::size_t w, float jump_m,
                                    std::size_t band_px, std::uint8_t* scratch, std::uint8_t* edges) {
  for (std::size_t u = 0; u < w; ++u) {
    edges[u] = static_cast<std::uint8_t>((left[u] > jump_m) | (left[u + 1] > jump_m) | (up[u] > jump_m) |
                                         (down[u] > jump_m));
  }
  if (band_px == 0) return;
  std::copy(edges, edges + w, scratch);
  for (std::size_t d = 1; d <= band_px && d < w; ++d) {
    for (std::size_t u = 0; u + d < w; ++u) edges[u] |= scratch[u + d];
    for (std::size_t u = d; u < w; ++u) edges[u] |= scratch[u - d];
  }
}

// band[u] = OR of edges[r][u] over the rows given.
FLEETSLAM_ROW_KERNEL void or_rows(const std::uint8_t* const* rows, std::size_t count, std::size_t w,
                                  std::uint8_t* band) {
  std::copy(rows[0], rows[0] + w, band);
  for (std::size_t r = 1; r < count; ++r) {
    const std::uint8_t* edges = rows[r];
    for (std::size_t u = 0; u < w; ++u) band[u] |= edges[u];
  }
}

// out[i] = table[index[i]] (AVX2 gathers in the AVX2 clone; __restrict lets GCC use them).
FLEETSLAM_ROW_KERNEL void gather_row(const float* __restrict table, const std::uint16_t* __restrict index,
                                     std::size_t n, float* __restrict out) {
#if defined(__GNUC__)
#pragma GCC unroll 8
#endif
  for (std::size_t i = 0; i < n; ++i) out[i] = table[index[i]];
}

// The rows around row v for the grazing test: sanitised depth (padded, see sanitize_row) of rows
// v - 1, v, v + 1, row v's left jumps and the down jumps of rows v - 1 and v.
struct GrazingInput {
  const float* s_up;
  const float* s;
  const float* s_down;
  const float* left;
  const float* up;
  const float* down;
};

struct GrazingCamera {
  const float* xn;     // (u - cx) / fx
  const float* xn_sq;  // xn^2
  float yn;            // (v - cy) / fy
  float fx;
  float fy;
  float min_cos_sq;    // cos^2 of the dropout angle
};

// Depth change per pixel from z's neighbours and the jumps to them (see grazing_keep_row): central
// 0.5 (z_next - z_prev) where both jumps are within jump_m, else one-sided to the nearer valid
// neighbour. NaN jumps (invalid neighbours) fail every comparison.
float slope(float z, float z_prev, float z_next, float jump_prev, float jump_next, float jump_m) {
  const bool central = (jump_prev <= jump_m) & (jump_next <= jump_m);
  const bool prev_nearer = !(jump_next <= jump_prev) & (jump_prev == jump_prev);
  const float one_sided = select(prev_nearer, z - z_prev, z_next - z);
  return select(central, 0.5f * (z_next - z_prev), one_sided);
}

// keep[u] = 1 where row v's depth (valid) is within [min_m, max_m] and not seen beyond the angle.
//
// Incidence test: the angle between the surface normal and the viewing ray, from the depth image's
// gradient. With P(u, v) = z (x_n, y_n, 1) the back-projected point, dP/du x dP/dv is parallel to
//   n = (-fx z_u, -fy z_v, fx z_u x_n + fy z_v y_n + z),  with n . (x_n, y_n, 1) = z,
// so cos^2(angle) = z^2 / (|n|^2 |ray|^2) and no cross product is needed per pixel. The derivatives
// z_u, z_v are central differences where both neighbours continue the surface (jumps within
// edge_jump_m), else one-sided to the neighbour nearer in depth: across a depth edge that is the
// pixel's own surface, and on a far grazing surface, where even neighbours differ by more than
// edge_jump_m, it is still the surface. Without a valid neighbour along u or along v there is no
// normal and no grazing dropout: the one-sided difference then takes an invalid (NaN) neighbour, and
// the NaN normal fails the comparison.
FLEETSLAM_ROW_KERNEL void grazing_keep_row(const GrazingInput& in, const GrazingCamera& cam, std::size_t w,
                                           float jump_m, float min_m, float max_m, std::int32_t* mask,
                                           std::uint8_t* keep) {
  const float yn = cam.yn;
  const float yn_sq = yn * yn;
  for (std::size_t u = 0; u < w; ++u) {
    const float z = in.s[u + 1];
    const float jl = in.left[u], jr = in.left[u + 1], ju = in.up[u], jd = in.down[u];
    const float z_u = slope(z, in.s[u], in.s[u + 2], jl, jr, jump_m);
    const float z_v = slope(z, in.s_up[u + 1], in.s_down[u + 1], ju, jd, jump_m);
    const float xn = cam.xn[u];
    const float gx = cam.fx * z_u;
    const float gy = cam.fy * z_v;
    const float nz = gx * xn + gy * yn + z;
    const float normal_sq = gx * gx + gy * gy + nz * nz;
    const float ray_sq = cam.xn_sq[u] + yn_sq + 1.0f;
    const bool beyond = z * z < cam.min_cos_sq * normal_sq * ray_sq;  // false for a NaN normal
    mask[u] = static_cast<std::int32_t>((z >= min_m) & (z <= max_m) & !beyond);
  }
  // Narrowed in a loop of its own: in the one above, bytes made GCC's vector code three times longer.
  for (std::size_t u = 0; u < w; ++u) keep[u] = static_cast<std::uint8_t>(mask[u]);
}

// Without the grazing test: keep[u] = 1 where s[u + 1] is within [min_m, max_m] (so valid).
FLEETSLAM_ROW_KERNEL void range_keep_row(const float* s, std::size_t w, float min_m, float max_m, std::uint8_t* keep) {
  for (std::size_t u = 0; u < w; ++u) keep[u] = static_cast<std::uint8_t>((s[u + 1] >= min_m) & (s[u + 1] <= max_m));
}

// out[u] = max(z + sigma(z) noise[u], 0) where kept, else 0, with sigma(z) = base + quadratic (z - 0.4)^2.
FLEETSLAM_ROW_KERNEL void noisy_depth_row(const float* s, const std::uint8_t* keep, const float* noise, std::size_t w,
                                          float sigma_base_m, float sigma_quadratic, float* out) {
  for (std::size_t u = 0; u < w; ++u) {
    const float z = s[u + 1];
    const float sigma_m = sigma_base_m + sigma_quadratic * (z - 0.4f) * (z - 0.4f);  // axial_sigma_m in float
    const float z_noisy = z + sigma_m * noise[u];
    out[u] = select((keep[u] != 0) & (z_noisy > 0.0f), z_noisy, 0.0f);
  }
}

// The depth model's rows, one pass over the image with rings of row buffers (row r in slot r mod the
// ring's size): sanitised rows, jumps, and edge rows (edge pixels widened along the row). Row v's
// band is the OR of edge rows v - band_px .. v + band_px, so those must be ready, which needs jumps
// up to row v + band_px and sanitised rows up to v + band_px + 1; the grazing test of row v needs
// sanitised rows v - 1 .. v + 1 and jumps of rows v - 1 and v.
class DepthRows {
 public:
  DepthRows(const cv::Mat& depth_m, const core::PinholeCamera& camera, float jump_m, int band_px, double max_angle_deg)
      : depth_(depth_m),
        width_(static_cast<std::size_t>(depth_m.cols)),
        jump_m_(jump_m),
        band_px_(static_cast<std::size_t>(band_px)),
        row_ring_(band_px_ + 3),
        jump_ring_(band_px_ + 2),
        edge_ring_(2 * band_px_ + 1),
        sanitized_(row_ring_ * (width_ + 2)),
        left_(jump_ring_ * (width_ + 1)),
        down_(jump_ring_ * width_),
        edges_(edge_ring_ * width_),
        scratch_(width_),
        mask_(width_),
        nan_row_(width_ + 2, kNaN),
        xn_(width_),
        xn_sq_(width_) {
    for (std::size_t u = 0; u < width_; ++u) {
      xn_[u] = static_cast<float>((static_cast<double>(u) - camera.cx()) / camera.fx());
      xn_sq_[u] = xn_[u] * xn_[u];
    }
    const double c = std::cos(max_angle_deg * 3.14159265358979323846 / 180.0);
    camera_ = {xn_.data(), xn_sq_.data(), 0.0f, static_cast<float>(camera.fx()), static_cast<float>(camera.fy()),
               static_cast<float>(c * c)};
    cy_ = camera.cy();
    fy_ = camera.fy();
  }

  int rows() const { return depth_.rows; }

  void sanitize(int r) { sanitize_row(depth_.ptr<float>(r), width_, sanitized(r)); }

  // Rows r and r + 1 sanitised.
  void jumps(int r) {
    jumps_row(sanitized(r), r + 1 < rows() ? sanitized(r + 1) : nullptr, width_, left(r), down(r));
  }

  // Jumps of rows r - 1 and r computed.
  void edges(int r) {
    edges_row(left(r), r > 0 ? down(r - 1) : nan_row_.data(), down(r), width_, jump_m_, band_px_, scratch_.data(),
              edge_row(r));
  }

  // Edge rows v - band_px .. v + band_px (within the image) computed.
  void band(int v, std::uint8_t* band) {
    const int band_px = static_cast<int>(band_px_);
    const int first = std::max(0, v - band_px);
    const int last = std::min(rows() - 1, v + band_px);
    band_rows_.clear();
    for (int r = first; r <= last; ++r) band_rows_.push_back(edge_row(r));
    or_rows(band_rows_.data(), band_rows_.size(), width_, band);
  }

  void keep(int v, bool grazing, float min_m, float max_m, std::uint8_t* keep) {
    if (!grazing) {
      range_keep_row(sanitized(v), width_, min_m, max_m, keep);
      return;
    }
    const GrazingInput in{v > 0 ? sanitized(v - 1) : nan_row_.data(),
                          sanitized(v),
                          v + 1 < rows() ? sanitized(v + 1) : nan_row_.data(),
                          left(v),
                          v > 0 ? down(v - 1) : nan_row_.data(),
                          down(v)};
    camera_.yn = static_cast<float>((v - cy_) / fy_);
    grazing_keep_row(in, camera_, width_, jump_m_, min_m, max_m, mask_.data(), keep);
  }

  // Sanitised row r, padded (see sanitize_row).
  const float* sanitized_row(int r) const {
    return &sanitized_[static_cast<std::size_t>(r) % row_ring_ * (width_ + 2)];
  }

 private:
  float* sanitized(int r) { return &sanitized_[static_cast<std::size_t>(r) % row_ring_ * (width_ + 2)]; }
  float* left(int r) { return &left_[static_cast<std::size_t>(r) % jump_ring_ * (width_ + 1)]; }
  float* down(int r) { return &down_[static_cast<std::size_t>(r) % jump_ring_ * width_]; }
  std::uint8_t* edge_row(int r) { return &edges_[static_cast<std::size_t>(r) % edge_ring_ * width_]; }

  const cv::Mat& depth_;
  std::size_t width_;
  float jump_m_;
  std::size_t band_px_;
  std::size_t row_ring_;
  std::size_t jump_ring_;
  std::size_t edge_ring_;
  std::vector<float> sanitized_;
  std::vector<float> left_;
  std::vector<float> down_;
  std::vector<std::uint8_t> edges_;
  std::vector<std::uint8_t> scratch_;
  std::vector<std::int32_t> mask_;
  std::vector<float> nan_row_;
  std::vector<float> xn_;
  std::vector<float> xn_sq_;
  std::vector<const std::uint8_t*> band_rows_;
  GrazingCamera camera_{};
  double cy_ = 0.0;
  double fy_ = 1.0;
};

// out[k] = in[k] + noise[k] saturated to [0, 255].
FLEETSLAM_ROW_KERNEL void add_rounded_noise_row(const std::uint8_t* in, const std::int8_t* noise, std::size_t n,
                                                std::uint8_t* out) {
  for (std::size_t k = 0; k < n; ++k) {
    const int sum = in[k] + noise[k];
    out[k] = static_cast<std::uint8_t>(std::min(std::max(sum, 0), 255));
  }
}

// out[k] = saturate_cast<uchar>(b + sigma * noise[k]) with b = base[k], or in[k] without base.
void add_noise_row(const std::uint8_t* in, const float* base, const float* noise, float sigma, std::size_t n,
                   std::uint8_t* out) {
  std::size_t k = 0;
#if CV_SIMD128
  // v_round rounds to nearest even like cvRound; the packs saturate like saturate_cast.
  const cv::v_float32x4 s = cv::v_setall_f32(sigma);
  for (; k + 16 <= n; k += 16) {
    cv::v_float32x4 b[4];
    if (base != nullptr) {
      for (std::size_t i = 0; i < 4; ++i) b[i] = cv::v_load(base + k + 4 * i);
    } else {
      cv::v_uint16x8 lo, hi;
      cv::v_expand(cv::v_load(in + k), lo, hi);
      cv::v_uint32x4 q0, q1, q2, q3;
      cv::v_expand(lo, q0, q1);
      cv::v_expand(hi, q2, q3);
      b[0] = cv::v_cvt_f32(cv::v_reinterpret_as_s32(q0));
      b[1] = cv::v_cvt_f32(cv::v_reinterpret_as_s32(q1));
      b[2] = cv::v_cvt_f32(cv::v_reinterpret_as_s32(q2));
      b[3] = cv::v_cvt_f32(cv::v_reinterpret_as_s32(q3));
    }
    cv::v_int32x4 r[4];
    for (std::size_t i = 0; i < 4; ++i) r[i] = cv::v_round(b[i] + s * cv::v_load(noise + k + 4 * i));
    cv::v_store(out + k, cv::v_pack_u(cv::v_pack(r[0], r[1]), cv::v_pack(r[2], r[3])));
  }
#endif
  for (; k < n; ++k) {
    const float b = base != nullptr ? base[k] : static_cast<float>(in[k]);
    out[k] = cv::saturate_cast<std::uint8_t>(b + sigma * noise[k]);
  }
}

void check_image_type(const cv::Mat& image) {
  if (image.type() != CV_8UC1 && image.type() != CV_8UC3) {
    throw std::invalid_argument("ImageNoiseModel::apply: image must be CV_8UC1 or CV_8UC3");
  }
}

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

DepthNoiseDraw DepthNoiseModel::next() {
  DepthNoiseDraw draw;
  if (!config_.enabled) return draw;
  draw.enabled = true;
  draw.seed = rng_();
  return draw;
}

// Draws: the image's seed, expanded into two streams per row band (see for_each_row_band): Gaussian
// table indices, one per pixel row-major (expand: they do not depend on the image), and uniforms, one
// for each in-range band pixel not dropped at grazing incidence, row-major (none when the probability
// is 1).
DepthNoiseField DepthNoiseModel::expand(const DepthNoiseDraw& draw, cv::Size size, bool parallel) const {
  DepthNoiseField field;
  field.draw = draw;
  if (!draw.enabled) return field;
  const std::vector<std::uint64_t> seeds = row_band_seeds(draw.seed, 2);
  const float* table = unit_normal_table().data();
  const auto width = static_cast<std::size_t>(size.width);
  field.noise.create(size, CV_32FC1);
  for_each_row_band(size.height, [&](int band, int first_row, int end_row) {
    NormalIndexStream indices(seeds[2 * static_cast<std::size_t>(band)], width);
    for (int v = first_row; v < end_row; ++v) gather_row(table, indices.take(width), width, field.noise.ptr<float>(v));
  }, parallel);
  return field;
}

cv::Mat DepthNoiseModel::apply(const cv::Mat& depth_m, const core::PinholeCamera& camera) {
  check_image_matches_camera(depth_m, camera);
  return apply(depth_m, camera, expand(next(), depth_m.size()));
}

cv::Mat DepthNoiseModel::apply(const cv::Mat& depth_m, const core::PinholeCamera& camera,
                               const DepthNoiseField& field) const {
  check_image_matches_camera(depth_m, camera);
  if (!config_.enabled || !field.draw.enabled) return depth_m.clone();
  if (field.noise.type() != CV_32FC1 || field.noise.size() != depth_m.size()) {
    throw std::invalid_argument("DepthNoiseModel::apply: the noise field is " + std::to_string(field.noise.cols) +
                                "x" + std::to_string(field.noise.rows) + " but the depth image " +
                                std::to_string(depth_m.cols) + "x" + std::to_string(depth_m.rows));
  }

  const double p_edge = config_.edge_dropout_probability;
  const bool edge_dropout = p_edge > 0.0;
  const bool grazing_dropout = config_.grazing_dropout_deg < 90.0;
  // A band wider than the image covers all of it, as does one as wide.
  const int band_px = edge_dropout ? std::clamp(config_.edge_band_px, 0, std::max(depth_m.cols, depth_m.rows)) : 0;
  const auto min_m = static_cast<float>(config_.min_depth_m);
  const auto max_m = static_cast<float>(config_.max_depth_m);
  const auto sigma_base_m = static_cast<float>(config_.sigma_base_m);
  const auto sigma_quadratic = static_cast<float>(config_.sigma_quadratic);
  const auto width = static_cast<std::size_t>(depth_m.cols);
  const int height = depth_m.rows;

  // The uniforms' streams (see expand).
  const std::vector<std::uint64_t> seeds = row_band_seeds(field.draw.seed, 2);
  const auto drop_below = static_cast<std::uint64_t>(std::ceil(p_edge * 0x1.0p53));
  const auto jump_m = static_cast<float>(config_.edge_jump_m);
  const double grazing_dropout_deg = config_.grazing_dropout_deg;
  cv::Mat noisy(depth_m.size(), CV_32FC1);

  for_each_row_band(height, [&](int band_index, int first_row, int end_row) {
    DepthRows rows(depth_m, camera, jump_m, band_px, grazing_dropout_deg);
    WyRand uniforms(seeds[2 * static_cast<std::size_t>(band_index) + 1]);
    std::vector<std::uint8_t> keep(width + sizeof(std::uint64_t), 0);
    std::vector<std::uint8_t> band(edge_dropout ? width + sizeof(std::uint64_t) : 0, 0);

    // Row v needs sanitised rows up to v + ahead + 1 and back to v - 1, jumps of rows v - 1 .. v + ahead
    // and edges of rows v - ahead .. v + ahead. Rows come in in order (row r: sanitised row r + 1,
    // jumps and edges of row r), from far enough above the band's first row.
    const int ahead = band_px;
    const bool pairs = edge_dropout || grazing_dropout;
    const int first_edge = std::max(0, first_row - ahead);
    int next = std::max(0, first_row - ahead - 1);
    rows.sanitize(next);
    for (int v = first_row; v < end_row; ++v) {
      for (const int need = std::min(height - 1, v + ahead); next <= need; ++next) {
        if (next + 1 < height) rows.sanitize(next + 1);
        if (pairs) rows.jumps(next);
        if (edge_dropout && next >= first_edge) rows.edges(next);
      }
      rows.keep(v, grazing_dropout, min_m, max_m, keep.data());
      if (edge_dropout) {
        rows.band(v, band.data());
        if (p_edge >= 1.0) {
          for (std::size_t u = 0; u < width; ++u) keep[u] &= band[u] ^ 1;
        } else {
          // Kept band pixels, eight at a time: most words have none. A uniform u = (x >> 11) 2^-53 is
          // below p exactly when x >> 11 is below ceil(p 2^53).
          for (std::size_t u0 = 0; u0 < width; u0 += 8) {
            std::uint64_t b8, k8;
            std::memcpy(&b8, band.data() + u0, sizeof b8);
            std::memcpy(&k8, keep.data() + u0, sizeof k8);
            if ((b8 & k8) == 0) continue;
            for (std::size_t u = u0; u < std::min(u0 + 8, width); ++u) {
              const bool candidate = (band[u] & keep[u]) != 0;
              const bool drop = candidate & ((uniforms.next_if(candidate) >> 11) < drop_below);
              keep[u] &= static_cast<std::uint8_t>(!drop);
            }
          }
        }
      }
      noisy_depth_row(rows.sanitized_row(v), keep.data(), field.noise.ptr<float>(v), width, sigma_base_m,
                      sigma_quadratic, noisy.ptr<float>(v));
    }
  });
  return noisy;
}

ImageNoiseModel::ImageNoiseModel(const ImageNoiseConfig& config, std::uint64_t seed)
    : config_(config), rng_(seed) {
  if (!(config.exposure_correlation_s > 0.0)) {
    throw std::invalid_argument("ImageNoiseModel: exposure_correlation_s must be positive, got " +
                                std::to_string(config.exposure_correlation_s));
  }
  // At unit gain an integer intensity plus noise rounds like the intensity plus the rounded noise,
  // so a table of round(sigma n) (in float, like the general path) turns the noise into one byte
  // lookup and a saturating add, where it fits in a byte (sigma up to about 29).
  const auto sigma = static_cast<float>(config.sigma_intensity);
  if (config.enabled && sigma != 0.0f) {
    const std::vector<float>& table = unit_normal_table();
    if (std::abs(sigma * table.back()) < 127.0f) {
      rounded_noise_.resize(table.size());
      for (std::size_t i = 0; i < table.size(); ++i) {
        rounded_noise_[i] = static_cast<std::int8_t>(std::lrint(sigma * table[i]));
      }
    }
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

ImageNoiseDraw ImageNoiseModel::next(core::TimeNs t_ns) {
  ImageNoiseDraw draw;
  if (!config_.enabled) return draw;
  advance_exposure(t_ns);
  draw.gain = gain_;
  draw.pixel_noise = config_.sigma_intensity != 0.0;
  if (draw.pixel_noise) draw.seed = rng_();
  return draw;
}

// One seed per image (none without noise), expanded into one stream per row band (see
// for_each_row_band) of table indices, one per value, row-major. At unit gain with the rounded table
// the noise is round(sigma n) in bytes (see the constructor), else n in floats.
ImageNoiseField ImageNoiseModel::expand(const ImageNoiseDraw& draw, cv::Size size, int channels, bool parallel) const {
  ImageNoiseField field;
  field.draw = draw;
  if (!draw.pixel_noise) return field;
  const auto values_per_row = static_cast<std::size_t>(size.width) * static_cast<std::size_t>(channels);
  const std::vector<std::uint64_t> seeds = row_band_seeds(draw.seed, 1);
  if (draw.gain == 1.0 && !rounded_noise_.empty()) {
    field.noise.create(size.height, static_cast<int>(values_per_row), CV_8SC1);
    const std::int8_t* table = rounded_noise_.data();
    for_each_row_band(size.height, [&](int band, int first_row, int end_row) {
      NormalIndexStream indices(seeds[static_cast<std::size_t>(band)], values_per_row);
      for (int v = first_row; v < end_row; ++v) {
        const std::uint16_t* index = indices.take(values_per_row);
        std::int8_t* noise = field.noise.ptr<std::int8_t>(v);
#if defined(__GNUC__)
#pragma GCC unroll 8
#endif
        for (std::size_t k = 0; k < values_per_row; ++k) noise[k] = table[index[k]];
      }
    }, parallel);
    return field;
  }
  field.noise.create(size.height, static_cast<int>(values_per_row), CV_32FC1);
  const float* table = unit_normal_table().data();
  for_each_row_band(size.height, [&](int band, int first_row, int end_row) {
    NormalIndexStream indices(seeds[static_cast<std::size_t>(band)], values_per_row);
    for (int v = first_row; v < end_row; ++v) {
      gather_row(table, indices.take(values_per_row), values_per_row, field.noise.ptr<float>(v));
    }
  }, parallel);
  return field;
}

cv::Mat ImageNoiseModel::apply(const cv::Mat& image, core::TimeNs t_ns) {
  check_image_type(image);
  return apply(image, expand(next(t_ns), image.size(), image.channels()));
}

// Gain is applied to the clean intensity, then noise, then rounding and saturation to [0, 255]:
// out = saturate_cast<uchar>(scaled[in] + sigma * n) with scaled[i] = float(gain i), or at unit gain
// in + round(sigma n) saturated (the same but for exact ties, see the constructor), per row in SIMD.
cv::Mat ImageNoiseModel::apply(const cv::Mat& image, const ImageNoiseField& field) const {
  check_image_type(image);
  const double gain = field.draw.gain;
  if (!config_.enabled || (field.noise.empty() && gain == 1.0)) return image.clone();
  const auto values_per_row = static_cast<std::size_t>(image.cols) * static_cast<std::size_t>(image.channels());
  if (!field.noise.empty() &&
      (field.noise.rows != image.rows || static_cast<std::size_t>(field.noise.cols) != values_per_row)) {
    throw std::invalid_argument("ImageNoiseModel::apply: the noise field has " + std::to_string(field.noise.rows) +
                                " rows of " + std::to_string(field.noise.cols) + " values but the image " +
                                std::to_string(image.rows) + " of " + std::to_string(values_per_row));
  }
  cv::Mat noisy(image.size(), image.type());
  if (field.noise.type() == CV_8SC1) {
    for_each_row_band(image.rows, [&](int, int first_row, int end_row) {
      for (int v = first_row; v < end_row; ++v) {
        add_rounded_noise_row(image.ptr<std::uint8_t>(v), field.noise.ptr<std::int8_t>(v), values_per_row,
                              noisy.ptr<std::uint8_t>(v));
      }
    });
    return noisy;
  }
  const bool unit_gain = gain == 1.0;
  const auto sigma = static_cast<float>(config_.sigma_intensity);
  float scaled[256];
  for (int i = 0; i < 256; ++i) scaled[i] = static_cast<float>(gain * i);
  for_each_row_band(image.rows, [&](int, int first_row, int end_row) {
    const std::vector<float> zeros(field.noise.empty() ? values_per_row : 0, 0.0f);
    std::vector<float> base(unit_gain ? 0 : values_per_row);
    for (int v = first_row; v < end_row; ++v) {
      const std::uint8_t* in = image.ptr<std::uint8_t>(v);
      if (!unit_gain) {
        for (std::size_t k = 0; k < values_per_row; ++k) base[k] = scaled[in[k]];
      }
      add_noise_row(in, unit_gain ? nullptr : base.data(), field.noise.empty() ? zeros.data() : field.noise.ptr<float>(v),
                    sigma, values_per_row, noisy.ptr<std::uint8_t>(v));
    }
  });
  return noisy;
}

}  // namespace fleetslam::sim
