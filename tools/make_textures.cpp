// fleetslam_make_textures: writes the PNG textures of the simulator's scenes (scenes/textures/).
//
//   fleetslam_make_textures [output_dir]        (default: scenes/textures)
//   fleetslam_make_textures --list              (names and sizes, writes nothing)
//   fleetslam_make_textures [output_dir] --only=SUBSTRING   (only the textures whose name contains it)
//
// Every texture is drawn from its own seeded generator (SplitMix64 seeded from the texture's name), with
// no std:: distributions (their output differs between standard libraries), so a run reproduces the
// committed files pixel for pixel. The patterns are meant for feature-based visual SLAM: dense, varied,
// high-frequency detail with no regular repetition (repeats alias in matching), built mostly from flat
// shapes and lines, which PNG compresses far better than per-pixel noise.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace {

constexpr double kPi = 3.14159265358979323846;

// ---------------------------------------------------------------------------------------------------
// Deterministic randomness.

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
  }
  double uniform() { return static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0); }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  int integer(int lo, int hi) {  // inclusive
    return lo + static_cast<int>(next() % static_cast<std::uint64_t>(hi - lo + 1));
  }
  bool chance(double p) { return uniform() < p; }
  template <class T>
  const T& pick(const std::vector<T>& items) {
    return items[static_cast<std::size_t>(next() % items.size())];
  }

 private:
  std::uint64_t state_;
};

std::uint64_t hash_name(const std::string& name) {
  std::uint64_t h = 1469598103934665603ULL;  // FNV-1a
  for (unsigned char c : name) {
    h ^= c;
    h *= 1099511628211ULL;
  }
  return h;
}

// Lattice value noise and its fractal sum, from an integer hash (no tables, no global state).
double lattice(int x, int y, std::uint32_t seed) {
  std::uint32_t h = static_cast<std::uint32_t>(x) * 374761393U + static_cast<std::uint32_t>(y) * 668265263U +
                    seed * 2246822519U;
  h = (h ^ (h >> 13)) * 1274126177U;
  h ^= h >> 16;
  return static_cast<double>(h & 0xFFFFFFU) / 16777215.0;
}

double value_noise(double x, double y, std::uint32_t seed) {
  const int x0 = static_cast<int>(std::floor(x));
  const int y0 = static_cast<int>(std::floor(y));
  double fx = x - x0;
  double fy = y - y0;
  fx = fx * fx * (3.0 - 2.0 * fx);
  fy = fy * fy * (3.0 - 2.0 * fy);
  const double a = lattice(x0, y0, seed), b = lattice(x0 + 1, y0, seed);
  const double c = lattice(x0, y0 + 1, seed), d = lattice(x0 + 1, y0 + 1, seed);
  return (a + (b - a) * fx) * (1.0 - fy) + (c + (d - c) * fx) * fy;
}

double fbm(double x, double y, std::uint32_t seed, int octaves, double persistence = 0.5) {
  double sum = 0.0, amplitude = 1.0, norm = 0.0;
  for (int o = 0; o < octaves; ++o) {
    sum += amplitude * value_noise(x, y, seed + static_cast<std::uint32_t>(o) * 101U);
    norm += amplitude;
    amplitude *= persistence;
    x *= 2.03;
    y *= 2.03;
  }
  return sum / norm;
}

// ---------------------------------------------------------------------------------------------------
// Colour and drawing helpers (images are 8-bit BGR).

cv::Scalar hsv(double h_deg, double s, double v) {
  h_deg = std::fmod(std::fmod(h_deg, 360.0) + 360.0, 360.0);
  const double c = v * s, x = c * (1.0 - std::fabs(std::fmod(h_deg / 60.0, 2.0) - 1.0)), m = v - c;
  double r = 0, g = 0, b = 0;
  if (h_deg < 60) { r = c; g = x; } else if (h_deg < 120) { r = x; g = c; } else if (h_deg < 180) { g = c; b = x; }
  else if (h_deg < 240) { g = x; b = c; } else if (h_deg < 300) { r = x; b = c; } else { r = c; b = x; }
  return {255.0 * (b + m), 255.0 * (g + m), 255.0 * (r + m)};
}

cv::Scalar jitter(Rng& rng, const cv::Scalar& c, double amount) {
  return {std::clamp(c[0] + rng.uniform(-amount, amount), 0.0, 255.0),
          std::clamp(c[1] + rng.uniform(-amount, amount), 0.0, 255.0),
          std::clamp(c[2] + rng.uniform(-amount, amount), 0.0, 255.0)};
}

cv::Scalar scale(const cv::Scalar& c, double f) {
  return {std::clamp(c[0] * f, 0.0, 255.0), std::clamp(c[1] * f, 0.0, 255.0), std::clamp(c[2] * f, 0.0, 255.0)};
}

cv::Scalar mix(const cv::Scalar& a, const cv::Scalar& b, double t) { return a * (1.0 - t) + b * t; }

// Multiplies the image by (1 + amplitude * (fbm - 0.5) * 2) per pixel: smooth shading variation.
void shade(cv::Mat& img, std::uint32_t seed, double cell_px, double amplitude, int octaves = 4) {
  for (int y = 0; y < img.rows; ++y) {
    auto* row = img.ptr<cv::Vec3b>(y);
    for (int x = 0; x < img.cols; ++x) {
      const double f = 1.0 + amplitude * 2.0 * (fbm(x / cell_px, y / cell_px, seed, octaves) - 0.5);
      for (int k = 0; k < 3; ++k) row[x][k] = cv::saturate_cast<uchar>(row[x][k] * f);
    }
  }
}

// Sparse dots: cheap to compress, good corners.
void speckle(cv::Mat& img, Rng& rng, int count, int max_radius, const cv::Scalar& dark, const cv::Scalar& light) {
  for (int i = 0; i < count; ++i) {
    const cv::Point p(rng.integer(0, img.cols - 1), rng.integer(0, img.rows - 1));
    const int r = rng.integer(0, max_radius);
    cv::circle(img, p, r, rng.chance(0.5) ? dark : light, cv::FILLED, cv::LINE_8);
  }
}

std::string random_word(Rng& rng, int min_len, int max_len, bool upper) {
  static const char* kLower = "etaoinshrdlcumwfgypbvkjxqz";
  const int n = rng.integer(min_len, max_len);
  std::string w;
  for (int i = 0; i < n; ++i) {
    // Letters by rough English frequency: earlier letters are more likely.
    const double u = rng.uniform();
    const int idx = std::min(25, static_cast<int>(u * u * 26.0));
    char c = kLower[idx];
    if (upper || (i == 0 && rng.chance(0.3))) c = static_cast<char>(c - 'a' + 'A');
    w.push_back(c);
  }
  return w;
}

std::string random_code(Rng& rng, int letters, int digits) {
  std::string s;
  for (int i = 0; i < letters; ++i) s.push_back(static_cast<char>('A' + rng.integer(0, 25)));
  if (letters > 0 && digits > 0) s.push_back('-');
  for (int i = 0; i < digits; ++i) s.push_back(static_cast<char>('0' + rng.integer(0, 9)));
  return s;
}

int random_font(Rng& rng) {
  static const std::vector<int> kFonts = {cv::FONT_HERSHEY_SIMPLEX, cv::FONT_HERSHEY_DUPLEX,
                                          cv::FONT_HERSHEY_COMPLEX, cv::FONT_HERSHEY_TRIPLEX,
                                          cv::FONT_HERSHEY_PLAIN,   cv::FONT_HERSHEY_COMPLEX_SMALL};
  return rng.pick(kFonts);
}

// Lines of random words inside a rectangle ("text-like glyph clutter").
void text_block(cv::Mat& img, Rng& rng, cv::Rect area, double scale_px, const cv::Scalar& colour,
                int font = -1, bool ragged = true) {
  const int f = font < 0 ? random_font(rng) : font;
  const double font_scale = scale_px / 22.0;
  const int thickness = std::max(1, static_cast<int>(std::lround(scale_px / 14.0)));
  const int line_h = static_cast<int>(scale_px * 1.5);
  for (int y = area.y + line_h; y <= area.y + area.height; y += line_h) {
    int x = area.x + (ragged && rng.chance(0.15) ? static_cast<int>(scale_px * 2) : 0);
    const int right = area.x + area.width - (ragged ? rng.integer(0, area.width / 3) : 0);
    while (x < right) {
      const std::string w = random_word(rng, 1, 9, false);
      int base = 0;
      const cv::Size s = cv::getTextSize(w, f, font_scale, thickness, &base);
      if (x + s.width > right) break;
      cv::putText(img, w, {x, y}, f, font_scale, colour, thickness, cv::LINE_AA);
      x += s.width + static_cast<int>(scale_px * 0.6);
    }
    if (rng.chance(0.12)) y += line_h / 2;  // paragraph break
  }
}

void barcode(cv::Mat& img, Rng& rng, cv::Rect r, const cv::Scalar& ink = {20, 20, 20}) {
  int x = r.x;
  while (x < r.x + r.width) {
    const int w = rng.integer(1, 4);
    if (rng.chance(0.55)) cv::rectangle(img, {x, r.y}, {std::min(x + w, r.x + r.width) - 1, r.y + r.height - 1}, ink,
                                        cv::FILLED);
    x += w + rng.integer(1, 3);
  }
}

// A random 2D code (QR-like block grid with three finder squares).
void block_code(cv::Mat& img, Rng& rng, cv::Point tl, int cells, int cell_px) {
  const cv::Scalar ink(15, 15, 15), paper(245, 245, 245);
  cv::rectangle(img, tl, tl + cv::Point(cells * cell_px - 1, cells * cell_px - 1), paper, cv::FILLED);
  for (int j = 0; j < cells; ++j)
    for (int i = 0; i < cells; ++i)
      if (rng.chance(0.5))
        cv::rectangle(img, tl + cv::Point(i * cell_px, j * cell_px),
                      tl + cv::Point((i + 1) * cell_px - 1, (j + 1) * cell_px - 1), ink, cv::FILLED);
  for (const cv::Point corner : {cv::Point(0, 0), cv::Point(cells - 3, 0), cv::Point(0, cells - 3)}) {
    const cv::Point p = tl + corner * cell_px;
    cv::rectangle(img, p, p + cv::Point(3 * cell_px - 1, 3 * cell_px - 1), ink, cv::FILLED);
    cv::rectangle(img, p + cv::Point(cell_px / 2, cell_px / 2), p + cv::Point(3 * cell_px - 1 - cell_px / 2, 3 * cell_px - 1 - cell_px / 2), paper, cv::FILLED);
    cv::rectangle(img, p + cv::Point(cell_px, cell_px), p + cv::Point(2 * cell_px - 1, 2 * cell_px - 1), ink, cv::FILLED);
  }
}

std::vector<cv::Point> random_polygon(Rng& rng, cv::Point2d c, double r, int n, double irregularity) {
  std::vector<cv::Point> pts;
  const double a0 = rng.uniform(0, 2 * kPi);
  for (int i = 0; i < n; ++i) {
    const double a = a0 + 2 * kPi * i / n + rng.uniform(-0.3, 0.3) * irregularity;
    const double rr = r * (1.0 + rng.uniform(-0.5, 0.5) * irregularity);
    pts.emplace_back(static_cast<int>(c.x + rr * std::cos(a)), static_cast<int>(c.y + rr * std::sin(a)));
  }
  return pts;
}

// Blends a filled shape with the given opacity.
template <class Draw>
void blend(cv::Mat& img, double alpha, Draw draw) {
  cv::Mat layer = img.clone();
  draw(layer);
  cv::addWeighted(layer, alpha, img, 1.0 - alpha, 0.0, img);
}

void vertical_gradient(cv::Mat& img, const cv::Scalar& top, const cv::Scalar& bottom) {
  for (int y = 0; y < img.rows; ++y) {
    const cv::Scalar c = mix(top, bottom, static_cast<double>(y) / std::max(1, img.rows - 1));
    img.row(y).setTo(c);
  }
}

void random_shape(cv::Mat& img, Rng& rng, double size, const cv::Scalar& colour) {
  const cv::Point2d c(rng.uniform(-0.1, 1.1) * img.cols, rng.uniform(-0.1, 1.1) * img.rows);
  const double r = size * rng.uniform(0.3, 1.0);
  switch (rng.integer(0, 5)) {
    case 0: cv::circle(img, c, static_cast<int>(r), colour, cv::FILLED, cv::LINE_AA); break;
    case 1: {
      cv::RotatedRect rr(c, cv::Size2f(static_cast<float>(r * 2), static_cast<float>(r * rng.uniform(0.3, 1.5))),
                         static_cast<float>(rng.uniform(0, 180)));
      cv::Point2f p[4];
      rr.points(p);
      std::vector<cv::Point> q(p, p + 4);
      cv::fillConvexPoly(img, q, colour, cv::LINE_AA);
      break;
    }
    case 2: cv::fillPoly(img, std::vector<std::vector<cv::Point>>{random_polygon(rng, c, r, 3, 0.6)}, colour, cv::LINE_AA); break;
    case 3: cv::fillPoly(img, std::vector<std::vector<cv::Point>>{random_polygon(rng, c, r, rng.integer(5, 9), 1.0)}, colour, cv::LINE_AA); break;
    case 4: cv::ellipse(img, c, cv::Size(static_cast<int>(r), static_cast<int>(r * rng.uniform(0.3, 0.9))), rng.uniform(0, 180), 0, 360, colour, cv::FILLED, cv::LINE_AA); break;
    default: cv::circle(img, c, static_cast<int>(r), colour, std::max(2, static_cast<int>(r / 6)), cv::LINE_AA); break;
  }
}

// ---------------------------------------------------------------------------------------------------
// Floors and ceilings.

cv::Mat wood_planks(Rng& rng, int size, const cv::Scalar& base, int planks_across, double seam_dark) {
  cv::Mat img(size, size, CV_8UC3);
  const std::uint32_t seed = static_cast<std::uint32_t>(rng.next());
  const int plank_h = size / planks_across;
  for (int row = 0; row < planks_across; ++row) {
    int x = -rng.integer(0, size / 2);
    while (x < size) {
      const int len = rng.integer(size / 7, size * 2 / 5);
      const cv::Scalar tint = jitter(rng, scale(base, rng.uniform(0.6, 1.3)), 14);
      const double grain_f = rng.uniform(0.8, 1.6);
      const std::uint32_t s = seed + static_cast<std::uint32_t>(row * 977 + x);
      for (int y = row * plank_h; y < (row + 1) * plank_h; ++y) {
        auto* p = img.ptr<cv::Vec3b>(y);
        for (int xx = std::max(0, x); xx < std::min(size, x + len); ++xx) {
          // Grain: noise stretched along the plank, bent by a slow warp.
          const double warp = 6.0 * fbm(xx / 90.0, y / 90.0, s + 7, 2);
          const double g = fbm(xx / 60.0, (y + warp) * grain_f / 2.5, s, 3);
          const double rings = 0.5 + 0.5 * std::sin((y + warp * 3) * grain_f * 0.9 + 10 * g);
          const double f = 0.78 + 0.3 * std::floor(g * 5.0) / 5.0 + 0.12 * std::floor(rings * 3.0) / 3.0;
          for (int k = 0; k < 3; ++k) p[xx][k] = cv::saturate_cast<uchar>(tint[k] * f);
        }
      }
      // Knots.
      const int knots = rng.integer(0, 3);
      for (int k = 0; k < knots; ++k) {
        const cv::Point c(x + rng.integer(10, std::max(11, len - 10)), row * plank_h + rng.integer(4, plank_h - 4));
        const int a = rng.integer(6, 18);
        for (int ring = 3; ring >= 0; --ring)
          cv::ellipse(img, c, {a * (ring + 1) / 3, a * (ring + 1) / 8 + 1}, 0, 0, 360,
                      scale(tint, 0.5 + 0.12 * ring), ring == 0 ? cv::FILLED : 1, cv::LINE_AA);
      }
      cv::line(img, {x, row * plank_h}, {x, (row + 1) * plank_h - 1}, scale(base, seam_dark), 3);
      for (const int nx : {x + 7, x + len - 8}) {  // nail heads at both plank ends
        for (const int ny : {row * plank_h + plank_h / 4, row * plank_h + plank_h * 3 / 4}) {
          cv::circle(img, {nx, ny}, 2, scale(base, 0.3), cv::FILLED, cv::LINE_AA);
        }
      }
      x += len;
    }
    cv::line(img, {0, row * plank_h}, {size - 1, row * plank_h}, scale(base, seam_dark), 3);
  }
  speckle(img, rng, size * 2, 1, scale(base, 0.45), scale(base, 1.25));
  // Scuffs and stains.
  for (int i = 0; i < 25; ++i) {
    const cv::Point c(rng.integer(0, size), rng.integer(0, size));
    blend(img, 0.25, [&](cv::Mat& l) {
      cv::ellipse(l, c, {rng.integer(8, 60), rng.integer(3, 20)}, rng.uniform(0, 180), 0, 360,
                  rng.chance(0.5) ? scale(base, 0.5) : scale(base, 1.3), cv::FILLED, cv::LINE_AA);
    });
  }
  return img;
}

cv::Mat stone_tiles(Rng& rng, int size, int tiles, const cv::Scalar& base, const cv::Scalar& grout) {
  cv::Mat img(size, size, CV_8UC3, grout);
  const std::uint32_t seed = static_cast<std::uint32_t>(rng.next());
  const int t = size / tiles;
  for (int j = 0; j < tiles; ++j) {
    for (int i = 0; i < tiles; ++i) {
      const cv::Rect r(i * t + 3, j * t + 3, t - 6, t - 6);
      const cv::Scalar tint = jitter(rng, scale(base, rng.uniform(0.7, 1.15)), 7);
      const double vein_f = rng.uniform(8, 25);
      const std::uint32_t s = seed + static_cast<std::uint32_t>(j * 131 + i);
      for (int y = r.y; y < r.y + r.height; ++y) {
        auto* p = img.ptr<cv::Vec3b>(y);
        for (int x = r.x; x < r.x + r.width; ++x) {
          const double n = fbm(x / vein_f, y / vein_f, s, 4);
          const double v = 0.82 + 0.35 * std::floor(n * 8.0) / 8.0 - (std::fabs(n - 0.5) < 0.02 ? 0.25 : 0.0);
          for (int k = 0; k < 3; ++k) p[x][k] = cv::saturate_cast<uchar>(tint[k] * v);
        }
      }
      // Mottling, chips and the occasional crack.
      cv::Mat tile = img(r);
      speckle(tile, rng, t / 5, 2, scale(tint, 0.55), scale(tint, 1.3));
      if (rng.chance(0.2)) {
        cv::Point p(rng.integer(0, r.width - 1), rng.integer(0, r.height - 1));
        for (int k = 0; k < 8; ++k) {
          const cv::Point q = p + cv::Point(rng.integer(-15, 15), rng.integer(-15, 15));
          cv::line(tile, p, q, scale(tint, 0.4), 1, cv::LINE_AA);
          p = q;
        }
      }
    }
  }
  return img;
}

cv::Mat carpet(Rng& rng, int size, const cv::Scalar& a, const cv::Scalar& b) {
  // A patterned wall-to-wall carpet: mottled ground in a few tones, scattered motifs of varied size and
  // contrast (no repeat), flecks.
  cv::Mat img(size, size, CV_8UC3);
  const std::uint32_t seed = static_cast<std::uint32_t>(rng.next());
  for (int y = 0; y < size; ++y) {
    auto* p = img.ptr<cv::Vec3b>(y);
    for (int x = 0; x < size; ++x) {
      const double n = fbm(x / 40.0, y / 40.0, seed, 4, 0.6);
      const double q = std::floor(n * 5.0) / 5.0;  // few tones: crisp iso-lines, small PNG
      const cv::Scalar c = mix(a, b, q);
      for (int k = 0; k < 3; ++k) p[x][k] = cv::saturate_cast<uchar>(c[k]);
    }
  }
  for (int i = 0; i < 140; ++i) {
    const double t = rng.uniform();
    const cv::Scalar col = t < 0.4 ? scale(a, rng.uniform(0.4, 0.7)) : t < 0.8 ? scale(b, rng.uniform(1.1, 1.5)) : hsv(rng.uniform(0, 360), 0.5, 0.8);
    random_shape(img, rng, size / rng.uniform(14.0, 30.0), col);
  }
  speckle(img, rng, size * size / 120, 1, scale(a, 0.4), scale(b, 1.4));
  return img;
}

cv::Mat concrete(Rng& rng, int size, const cv::Scalar& base, bool with_joints) {
  cv::Mat img(size, size, CV_8UC3);
  const std::uint32_t seed = static_cast<std::uint32_t>(rng.next());
  for (int y = 0; y < size; ++y) {
    auto* p = img.ptr<cv::Vec3b>(y);
    for (int x = 0; x < size; ++x) {
      const double n = fbm(x / 70.0, y / 70.0, seed, 5, 0.55);
      const double q = std::floor(n * 10.0) / 10.0;
      for (int k = 0; k < 3; ++k) p[x][k] = cv::saturate_cast<uchar>(base[k] * (0.7 + 0.55 * q));
    }
  }
  // Oil stains, tyre marks, cracks, patches, debris.
  for (int i = 0; i < 18; ++i) {
    const cv::Point c(rng.integer(0, size), rng.integer(0, size));
    blend(img, rng.uniform(0.2, 0.5), [&](cv::Mat& l) {
      cv::fillPoly(l, std::vector<std::vector<cv::Point>>{random_polygon(rng, c, rng.uniform(10, 50), 9, 1.0)},
                   scale(base, 0.35), cv::LINE_AA);
    });
  }
  for (int i = 0; i < 6; ++i) {
    const cv::Point2d c(rng.uniform(0, size), rng.uniform(0, size));
    const double r = rng.uniform(size * 0.2, size * 0.6), a0 = rng.uniform(0, 360);
    blend(img, 0.3, [&](cv::Mat& l) {
      cv::ellipse(l, c, cv::Size(static_cast<int>(r), static_cast<int>(r * 0.7)), a0, 0, rng.uniform(40, 120),
                  scale(base, 0.45), rng.integer(8, 16), cv::LINE_AA);
    });
  }
  for (int i = 0; i < 10; ++i) {
    cv::Point p(rng.integer(0, size), rng.integer(0, size));
    double a = rng.uniform(0, 2 * kPi);
    for (int k = 0; k < 25; ++k) {
      a += rng.uniform(-0.6, 0.6);
      const cv::Point q = p + cv::Point(static_cast<int>(12 * std::cos(a)), static_cast<int>(12 * std::sin(a)));
      cv::line(img, p, q, scale(base, 0.35), 1, cv::LINE_AA);
      p = q;
    }
  }
  for (int i = 0; i < 5; ++i) {
    const cv::Rect r(rng.integer(0, size - 100), rng.integer(0, size - 100), rng.integer(40, 140), rng.integer(40, 140));
    cv::rectangle(img, r, scale(base, rng.uniform(0.8, 1.15)), cv::FILLED);
    cv::rectangle(img, r, scale(base, 0.55), 2);
  }
  speckle(img, rng, size * 3, 2, scale(base, 0.4), scale(base, 1.3));
  if (with_joints) {
    const int step = size / 2;
    for (int k = 0; k <= 2; ++k) {
      cv::line(img, {k * step, 0}, {k * step, size - 1}, scale(base, 0.4), 3);
      cv::line(img, {0, k * step}, {size - 1, k * step}, scale(base, 0.4), 3);
    }
  }
  return img;
}

cv::Mat ceiling_tiles(Rng& rng, int size) {
  const cv::Scalar base(228, 232, 235);
  cv::Mat img(size, size, CV_8UC3, cv::Scalar(150, 150, 150));
  const int t = size / 4;
  for (int j = 0; j < 4; ++j) {
    for (int i = 0; i < 4; ++i) {
      const cv::Rect r(i * t + 4, j * t + 4, t - 8, t - 8);
      if ((i + j * 3) % 5 == 2) {  // a light panel
        cv::rectangle(img, r, cv::Scalar(250, 252, 255), cv::FILLED);
        for (int k = 1; k < 6; ++k) cv::line(img, {r.x, r.y + k * r.height / 6}, {r.x + r.width, r.y + k * r.height / 6}, cv::Scalar(210, 215, 220), 2);
        continue;
      }
      cv::rectangle(img, r, jitter(rng, base, 8), cv::FILLED);
      cv::Mat tile = img(r);
      // Fissured acoustic tile: short random worm marks.
      for (int k = 0; k < 110; ++k) {
        cv::Point p(rng.integer(0, r.width - 1), rng.integer(0, r.height - 1));
        const cv::Point q = p + cv::Point(rng.integer(-7, 7), rng.integer(-3, 3));
        cv::line(tile, p, q, cv::Scalar(170, 172, 175) + cv::Scalar::all(rng.uniform(-20, 20)), rng.integer(1, 2), cv::LINE_AA);
      }
      if (rng.chance(0.3)) {
        blend(tile, 0.3, [&](cv::Mat& l) { cv::circle(l, {rng.integer(0, r.width), rng.integer(0, r.height)}, rng.integer(10, 40), cv::Scalar(120, 160, 180), cv::FILLED, cv::LINE_AA); });
      }
    }
  }
  return img;
}

// ---------------------------------------------------------------------------------------------------
// Walls.

cv::Mat brick_wall(Rng& rng, int w, int h, const cv::Scalar& base, const cv::Scalar& mortar) {
  cv::Mat img(h, w, CV_8UC3, mortar);
  const std::uint32_t seed = static_cast<std::uint32_t>(rng.next());
  const int course = h / 16;
  for (int row = 0; row < 16; ++row) {
    int x = -rng.integer(0, w / 8);
    while (x < w) {
      const int len = rng.integer(w / 12, w / 7);
      const cv::Rect r(x + 2, row * course + 2, len - 4, course - 4);
      const cv::Scalar tint = jitter(rng, scale(base, rng.uniform(0.65, 1.25)), 16);
      const std::uint32_t s = seed + static_cast<std::uint32_t>(row * 1000 + x);
      for (int y = std::max(0, r.y); y < std::min(h, r.y + r.height); ++y) {
        auto* p = img.ptr<cv::Vec3b>(y);
        for (int xx = std::max(0, r.x); xx < std::min(w, r.x + r.width); ++xx) {
          const double f = 0.8 + 0.4 * std::floor(fbm(xx / 9.0, y / 9.0, s, 3) * 6.0) / 6.0;
          for (int k = 0; k < 3; ++k) p[xx][k] = cv::saturate_cast<uchar>(tint[k] * f);
        }
      }
      if (rng.chance(0.15)) {  // chipped corner
        const cv::Point c = rng.chance(0.5) ? r.tl() : cv::Point(r.x + r.width, r.y + r.height);
        cv::circle(img, c, rng.integer(3, 8), mortar, cv::FILLED, cv::LINE_AA);
      }
      x += len;
    }
  }
  // Soot, efflorescence and a couple of painted marks.
  for (int i = 0; i < 10; ++i) {
    const cv::Point c(rng.integer(0, w), rng.integer(0, h));
    blend(img, 0.25, [&](cv::Mat& l) { cv::ellipse(l, c, {rng.integer(20, 90), rng.integer(10, 60)}, rng.uniform(0, 180), 0, 360, rng.chance(0.6) ? cv::Scalar(40, 40, 45) : cv::Scalar(220, 225, 225), cv::FILLED, cv::LINE_AA); });
  }
  speckle(img, rng, w * h / 300, 1, scale(base, 0.4), scale(mortar, 1.1));
  return img;
}

cv::Mat wallpaper(Rng& rng, int w, int h, const cv::Scalar& background, double hue0, double hue_span) {
  cv::Mat img(h, w, CV_8UC3, background);
  // Vines: thin random curves.
  for (int i = 0; i < 30; ++i) {
    cv::Point2d p(rng.uniform(0, w), rng.uniform(0, h));
    double a = rng.uniform(0, 2 * kPi);
    const cv::Scalar c = hsv(hue0 + rng.uniform(0, hue_span), 0.35, 0.45);
    for (int k = 0; k < 30; ++k) {
      a += rng.uniform(-0.5, 0.5);
      const cv::Point2d q = p + cv::Point2d(9 * std::cos(a), 9 * std::sin(a));
      cv::line(img, p, q, c, 2, cv::LINE_AA);
      if (rng.chance(0.2)) cv::ellipse(img, q, {7, 3}, a * 180 / kPi + 60, 0, 360, c, cv::FILLED, cv::LINE_AA);
      p = q;
    }
  }
  // Blobs and flowers of varied size and colour.
  for (int i = 0; i < 170; ++i) {
    const cv::Point2d c(rng.uniform(0, w), rng.uniform(0, h));
    const double r = rng.uniform(5, 34);
    const cv::Scalar col = hsv(hue0 + rng.uniform(0, hue_span), rng.uniform(0.3, 0.8), rng.uniform(0.35, 0.95));
    if (rng.chance(0.45)) {
      const int petals = rng.integer(4, 8);
      const double a0 = rng.uniform(0, kPi);
      for (int k = 0; k < petals; ++k) {
        const double a = a0 + 2 * kPi * k / petals;
        cv::ellipse(img, c + cv::Point2d(r * 0.6 * std::cos(a), r * 0.6 * std::sin(a)),
                    cv::Size(static_cast<int>(r * 0.55), static_cast<int>(r * 0.25)), a * 180 / kPi, 0, 360, col,
                    cv::FILLED, cv::LINE_AA);
      }
      cv::circle(img, c, static_cast<int>(r * 0.22), hsv(hue0 + 180, 0.6, 0.3), cv::FILLED, cv::LINE_AA);
    } else {
      cv::fillPoly(img, std::vector<std::vector<cv::Point>>{random_polygon(rng, c, r, rng.integer(5, 10), 0.8)}, col,
                   cv::LINE_AA);
    }
  }
  return img;
}

cv::Mat wall_tiles(Rng& rng, int w, int h, const cv::Scalar& base) {
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(190, 195, 195));
  const int cols = 16, rows = 8, tw = w / cols, th = h / rows;
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < cols; ++i) {
      const cv::Rect r(i * tw + 2, j * th + 2, tw - 4, th - 4);
      const cv::Scalar tint = jitter(rng, scale(base, rng.uniform(0.85, 1.08)), 10);
      cv::rectangle(img, r, tint, cv::FILLED);
      cv::Mat tile = img(r);
      if (rng.chance(0.35)) {  // a decorated tile, each one different
        const cv::Scalar ink = hsv(rng.uniform(0, 360), 0.7, rng.uniform(0.3, 0.7));
        const cv::Point2d c(r.width / 2.0, r.height / 2.0);
        const int kind = rng.integer(0, 3);
        if (kind == 0) {
          for (int k = 0; k < 4; ++k) random_shape(tile, rng, r.width / 3.0, ink);
        } else if (kind == 1) {
          cv::fillPoly(tile, std::vector<std::vector<cv::Point>>{random_polygon(rng, c, r.width * 0.4, rng.integer(3, 8), 0.3)}, ink, cv::LINE_AA);
          cv::circle(tile, c, r.width / 8, tint, cv::FILLED, cv::LINE_AA);
        } else if (kind == 2) {
          for (int k = 0; k < 5; ++k) cv::line(tile, {rng.integer(0, r.width), rng.integer(0, r.height)}, {rng.integer(0, r.width), rng.integer(0, r.height)}, ink, rng.integer(2, 6), cv::LINE_AA);
        } else {
          cv::putText(tile, std::string(1, static_cast<char>('A' + rng.integer(0, 25))), {r.width / 5, r.height * 4 / 5}, cv::FONT_HERSHEY_TRIPLEX, r.height / 34.0, ink, 2, cv::LINE_AA);
        }
      }
      // Glaze highlight and the odd crack.
      cv::line(tile, {3, 3}, {r.width / 3, 3}, scale(tint, 1.15), 2);
      if (rng.chance(0.1)) cv::line(tile, {rng.integer(0, r.width), 0}, {rng.integer(0, r.width), r.height}, scale(tint, 0.5), 1, cv::LINE_AA);
    }
  }
  return img;
}

// A pinned sheet of paper or sticky note with text-like content.
cv::Mat note_sheet(Rng& rng, int nw, int nh, bool sheet) {
  const cv::Scalar col = sheet ? cv::Scalar(245, 245, 242) : hsv(rng.pick(std::vector<double>{55, 90, 190, 320, 30}), 0.55, 0.97);
  cv::Mat note(nh, nw, CV_8UC3, col);
  const int kind = sheet ? rng.integer(0, 3) : 0;
  if (kind == 1) {  // a bar chart
    const int bars = rng.integer(4, 9);
    for (int k = 0; k < bars; ++k) {
      const int bh = rng.integer(nh / 6, nh * 2 / 3);
      const int x0 = 6 + k * (nw - 12) / bars;
      cv::rectangle(note, {x0, nh - 8 - bh}, {x0 + (nw - 12) / bars - 3, nh - 8}, hsv(rng.uniform(0, 360), 0.6, 0.7), cv::FILLED);
    }
    text_block(note, rng, {4, 0, nw - 8, nh / 4}, 6.0, cv::Scalar(40, 40, 40));
  } else if (kind == 2) {  // a photo
    cv::rectangle(note, {4, 4}, {nw - 5, nh - 5}, hsv(rng.uniform(0, 360), 0.4, 0.6), cv::FILLED);
    cv::Mat inner = note(cv::Rect(4, 4, nw - 8, nh - 8));
    for (int k = 0; k < 6; ++k) random_shape(inner, rng, nw / 3.0, hsv(rng.uniform(0, 360), rng.uniform(0.3, 0.9), rng.uniform(0.2, 1.0)));
  } else {
    text_block(note, rng, {4, 0, nw - 8, nh - 6}, sheet ? 7.0 : rng.uniform(6, 11), sheet ? cv::Scalar(40, 40, 40) : cv::Scalar(120, 60, 30));
    if (sheet && rng.chance(0.5)) barcode(note, rng, {4, nh - 14, nw / 2, 10});
    if (rng.chance(0.3)) random_shape(note, rng, nw / 4.0, hsv(rng.uniform(0, 360), 0.8, 0.6));
  }
  cv::rectangle(note, {0, 0}, {nw - 1, nh - 1}, scale(col, 0.75), 1);
  return note;
}

void paste(cv::Mat& img, const cv::Mat& item, cv::Point tl) {
  const cv::Rect dst = cv::Rect(tl, item.size()) & cv::Rect(0, 0, img.cols, img.rows);
  if (dst.area() <= 0) return;
  item(cv::Rect(dst.x - tl.x, dst.y - tl.y, dst.width, dst.height)).copyTo(img(dst));
}

// A painted office wall with things pinned to it over its whole height: notes, printed sheets, charts,
// photos, a cork board, a cable duct with sockets, a skirting board with scuffs.
cv::Mat cluttered_wall(Rng& rng, int w, int h, const cv::Scalar& paint) {
  cv::Mat img(h, w, CV_8UC3, paint);
  shade(img, static_cast<std::uint32_t>(rng.next()), 150.0, 0.07, 3);
  const int duct_y = h * 7 / 10;
  // Cork board.
  const cv::Rect cork(rng.integer(40, w / 2), rng.integer(30, 80), rng.integer(w / 5, w / 4), rng.integer(h / 5, h / 4));
  cv::rectangle(img, cork, cv::Scalar(90, 140, 180), cv::FILLED);
  cv::Mat cork_m = img(cork);
  speckle(cork_m, rng, cork.area() / 25, 1, cv::Scalar(50, 90, 130), cv::Scalar(130, 180, 210));
  cv::rectangle(img, cork, cv::Scalar(60, 80, 100), 5);
  for (int i = 0; i < 16; ++i) {
    const int nw = rng.integer(30, 60), nh = rng.integer(30, 50);
    paste(img, note_sheet(rng, nw, nh, false), {cork.x + rng.integer(0, cork.width - nw), cork.y + rng.integer(0, cork.height - nh)});
  }
  // Notes and sheets everywhere else, in loose clusters.
  std::vector<cv::Rect> placed = {cork};
  for (int i = 0; i < 400 && placed.size() < 75; ++i) {
    const bool sheet = rng.chance(0.55);
    const int nw = sheet ? rng.integer(50, 100) : rng.integer(32, 60);
    const int nh = sheet ? static_cast<int>(nw * 1.35) : nw;
    const cv::Rect r(rng.integer(0, w - nw), rng.integer(0, h - 30 - nh), nw, nh);
    if ((r & cv::Rect(0, duct_y - 4, w, 60)).area() > 0) continue;
    bool overlaps = false;
    for (const auto& q : placed) overlaps = overlaps || (r & q).area() > r.area() / 5;
    if (overlaps) continue;
    placed.push_back(r);
    paste(img, note_sheet(rng, nw, nh, sheet), r.tl());
    cv::circle(img, r.tl() + cv::Point(nw / 2, 4), 3, hsv(rng.uniform(0, 360), 0.9, 0.8), cv::FILLED, cv::LINE_AA);
  }
  // Cable duct with sockets and labels, skirting with scuffs.
  cv::rectangle(img, {0, duct_y}, {w - 1, duct_y + 14}, cv::Scalar(235, 235, 235), cv::FILLED);
  cv::line(img, {0, duct_y + 14}, {w - 1, duct_y + 14}, cv::Scalar(150, 150, 150), 1);
  for (int x = rng.integer(20, 80); x < w - 40; x += rng.integer(90, 200)) {
    const int n = rng.integer(1, 3);
    for (int k = 0; k < n; ++k) {
      const cv::Point p(x + k * 30, duct_y + 18);
      cv::rectangle(img, p, p + cv::Point(26, 30), cv::Scalar(240, 240, 240), cv::FILLED);
      cv::rectangle(img, p, p + cv::Point(26, 30), cv::Scalar(120, 120, 120), 1);
      cv::circle(img, p + cv::Point(9, 15), 2, cv::Scalar(40, 40, 40), cv::FILLED);
      cv::circle(img, p + cv::Point(17, 15), 2, cv::Scalar(40, 40, 40), cv::FILLED);
    }
    cv::rectangle(img, {x, duct_y + 50}, {x + 40, duct_y + 58}, cv::Scalar(250, 250, 250), cv::FILLED);
    cv::putText(img, random_code(rng, 1, 2), {x + 2, duct_y + 57}, cv::FONT_HERSHEY_PLAIN, 0.6, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
    if (rng.chance(0.6)) {  // a cable hanging down to the floor
      cv::Point p(x + 10, duct_y + 48);
      const cv::Scalar cable = rng.chance(0.5) ? cv::Scalar(30, 30, 30) : hsv(rng.uniform(0, 360), 0.7, 0.7);
      while (p.y < h - 30) {
        const cv::Point q = p + cv::Point(rng.integer(-8, 8), 12);
        cv::line(img, p, q, cable, 3, cv::LINE_AA);
        p = q;
      }
    }
  }
  cv::rectangle(img, {0, h - 28}, {w - 1, h - 1}, scale(paint, 0.55), cv::FILLED);
  cv::line(img, {0, h - 28}, {w - 1, h - 28}, scale(paint, 0.85), 2);
  for (int i = 0; i < 40; ++i) {
    const int x = rng.integer(0, w), y = rng.integer(h - 60, h - 4);
    cv::line(img, {x, y}, {x + rng.integer(-25, 25), y + rng.integer(-4, 4)}, scale(paint, rng.uniform(0.35, 0.7)), rng.integer(1, 3), cv::LINE_AA);
  }
  return img;
}

// Fills a rectangle with quantised wood grain (for wainscots and panels).
void wood_fill(cv::Mat& img, cv::Rect r, const cv::Scalar& base, std::uint32_t seed, double ring_f) {
  r &= cv::Rect(0, 0, img.cols, img.rows);
  for (int y = r.y; y < r.y + r.height; ++y) {
    auto* p = img.ptr<cv::Vec3b>(y);
    for (int x = r.x; x < r.x + r.width; ++x) {
      const double warp = 12.0 * fbm(x / 90.0, y / 90.0, seed + 3, 3);
      const double rings = 0.5 + 0.5 * std::sin((x + warp) * ring_f + 5.0 * fbm(x / 15.0, y / 60.0, seed, 3));
      const double f = 0.78 + 0.3 * std::floor(rings * 5.0) / 5.0;
      for (int k = 0; k < 3; ++k) p[x][k] = cv::saturate_cast<uchar>(base[k] * f);
    }
  }
}

// A plastered wall over a wooden wainscot: stains, framed photos and hand-written notes above; panels
// of irregular width with scuffs, stickers, children's drawings and sockets below.
cv::Mat plaster(Rng& rng, int w, int h, const cv::Scalar& paint, const cv::Scalar& wainscot) {
  cv::Mat img(h, w, CV_8UC3, paint);
  const std::uint32_t seed = static_cast<std::uint32_t>(rng.next());
  shade(img, seed, 60.0, 0.1, 4);
  const int dado = h * 9 / 16;
  for (int i = 0; i < 14; ++i) {
    const cv::Point c(rng.integer(0, w), rng.integer(0, dado - 20));
    blend(img, 0.18, [&](cv::Mat& l) { cv::fillPoly(l, std::vector<std::vector<cv::Point>>{random_polygon(rng, c, rng.uniform(10, 60), 10, 1.0)}, scale(paint, 0.6), cv::LINE_AA); });
  }
  for (int i = 0; i < 7; ++i) {  // small framed photos
    const int pw = rng.integer(50, 90), ph = rng.integer(40, 90);
    const cv::Point p(rng.integer(10, w - pw - 10), rng.integer(15, dado - ph - 20));
    cv::rectangle(img, p - cv::Point(6, 6), p + cv::Point(pw + 6, ph + 6), hsv(rng.uniform(0, 60), 0.5, rng.uniform(0.15, 0.6)), cv::FILLED);
    cv::Mat photo(ph, pw, CV_8UC3);
    vertical_gradient(photo, hsv(rng.uniform(0, 360), 0.4, 0.9), hsv(rng.uniform(0, 360), 0.6, 0.4));
    for (int k = 0; k < 7; ++k) random_shape(photo, rng, pw / 3.0, hsv(rng.uniform(0, 360), rng.uniform(0.2, 0.9), rng.uniform(0.1, 1.0)));
    paste(img, photo, p);
  }
  for (int i = 0; i < 3; ++i) {
    text_block(img, rng, {rng.integer(20, w - 220), rng.integer(20, dado - 120), 200, 100}, 9.0, scale(paint, 0.5), cv::FONT_HERSHEY_SCRIPT_SIMPLEX);
  }
  // Wainscot.
  wood_fill(img, {0, dado, w, h - dado}, wainscot, seed + 17, 0.08);
  cv::rectangle(img, {0, dado - 8}, {w - 1, dado + 4}, scale(wainscot, 0.7), cv::FILLED);
  cv::line(img, {0, dado - 8}, {w - 1, dado - 8}, scale(wainscot, 1.3), 2);
  int x = rng.integer(4, 20);
  while (x < w - 40) {
    const int pw = std::min(rng.integer(60, 170), w - 10 - x);
    const cv::Rect panel(x, dado + 16, pw, h - 30 - (dado + 16));
    cv::rectangle(img, panel, scale(wainscot, 0.6), 3, cv::LINE_AA);
    cv::rectangle(img, panel - cv::Point(-6, -6) - cv::Size(12, 12), scale(wainscot, 1.25), 1, cv::LINE_AA);
    cv::Mat inner = img(panel - cv::Point(-8, -8) - cv::Size(16, 16));
    for (int item = rng.integer(2, 3); item > 0; --item) {
    const int kind = rng.integer(0, 3);
    if (kind == 0) {  // a child's drawing
      cv::Point p(rng.integer(0, inner.cols - 1), rng.integer(0, inner.rows - 1));
      const cv::Scalar crayon = hsv(rng.uniform(0, 360), 0.9, 0.8);
      for (int k = 0; k < 20; ++k) {
        const cv::Point q(std::clamp(p.x + rng.integer(-25, 25), 0, inner.cols - 1), std::clamp(p.y + rng.integer(-25, 25), 0, inner.rows - 1));
        cv::line(inner, p, q, crayon, 2, cv::LINE_AA);
        p = q;
      }
    } else if (kind == 1) {  // stickers
      for (int k = 0; k < 4; ++k) random_shape(inner, rng, 14, hsv(rng.uniform(0, 360), 0.8, 0.9));
    } else if (kind == 2) {  // a socket and a label
      const cv::Point p(inner.cols / 2 - 13, inner.rows / 2 - 15);
      cv::rectangle(inner, p, p + cv::Point(26, 30), cv::Scalar(240, 240, 238), cv::FILLED);
      cv::circle(inner, p + cv::Point(9, 15), 2, cv::Scalar(40, 40, 40), cv::FILLED);
      cv::circle(inner, p + cv::Point(17, 15), 2, cv::Scalar(40, 40, 40), cv::FILLED);
    } else {  // a small printed sheet or photo taped on
      const int nw = std::min(inner.cols - 4, rng.integer(30, 60));
      if (nw > 12) paste(inner, note_sheet(rng, nw, std::min(inner.rows - 4, nw * 4 / 3), rng.chance(0.5)), {rng.integer(0, inner.cols - nw), rng.integer(0, inner.rows / 2)});
    }
    }
    for (int k = rng.integer(2, 8); k > 0; --k) {  // scuffs
      const cv::Point q(rng.integer(0, inner.cols), rng.integer(inner.rows / 2, inner.rows));
      cv::line(inner, q, q + cv::Point(rng.integer(-20, 20), rng.integer(-5, 5)), scale(wainscot, rng.uniform(0.3, 0.6)), rng.integer(1, 3), cv::LINE_AA);
    }
    x += pw + rng.integer(8, 24);
  }
  cv::rectangle(img, {0, h - 22}, {w - 1, h - 1}, scale(wainscot, 0.5), cv::FILLED);
  return img;
}

cv::Mat concrete_blocks(Rng& rng, int w, int h, const cv::Scalar& base, const std::string& zone) {
  cv::Mat img(h, w, CV_8UC3, scale(base, 0.7));
  const int rows = 10, bh = h / rows;
  for (int row = 0; row < rows; ++row) {
    int x = -((row % 2) ? w / 16 : 0) - rng.integer(0, 10);
    while (x < w) {
      const int len = w / 8 + rng.integer(-6, 6);
      const cv::Rect r(x + 2, row * bh + 2, len - 4, bh - 4);
      const cv::Scalar tint = jitter(rng, scale(base, rng.uniform(0.78, 1.15)), 8);
      cv::rectangle(img, r, tint, cv::FILLED);
      for (int k = rng.integer(0, 4); k > 0; --k) {  // pores and chips
        cv::circle(img, {r.x + rng.integer(0, r.width), r.y + rng.integer(0, r.height)}, rng.integer(1, 4),
                   scale(tint, rng.uniform(0.5, 0.8)), cv::FILLED, cv::LINE_AA);
      }
      if (rng.chance(0.2)) {
        cv::line(img, {r.x + rng.integer(0, r.width), r.y}, {r.x + rng.integer(0, r.width), r.y + r.height},
                 scale(tint, 0.6), 1, cv::LINE_AA);
      }
      if (rng.chance(0.25)) {  // a shade patch
        blend(img, 0.3, [&](cv::Mat& l) {
          cv::rectangle(l, {r.x + rng.integer(0, r.width / 2), r.y}, {r.x + r.width, r.y + r.height},
                        scale(tint, rng.chance(0.5) ? 0.8 : 1.15), cv::FILLED);
        });
      }
      x += len;
    }
  }
  speckle(img, rng, w * h / 500, 1, scale(base, 0.5), scale(base, 1.2));
  for (int i = 0; i < 8; ++i) {  // water stains and soot
    const cv::Point c(rng.integer(0, w), rng.integer(0, h));
    blend(img, 0.2, [&](cv::Mat& l) {
      cv::fillPoly(l, std::vector<std::vector<cv::Point>>{random_polygon(rng, c, rng.uniform(20, 70), 10, 1.0)},
                   scale(base, 0.45), cv::LINE_AA);
    });
  }
  // Painted safety band, stencilled zone name and numbers, signs, a fuse box, pipes.
  cv::rectangle(img, {0, h - 60}, {w - 1, h - 40}, cv::Scalar(0, 200, 240), cv::FILLED);
  for (int x = 0; x < w; x += rng.integer(30, 70)) {  // irregular stripes: no period to alias on
    const int sw = rng.integer(12, 26);
    std::vector<cv::Point> stripe = {{x, h - 60}, {x + sw, h - 60}, {x + sw - 10, h - 40}, {x - 10, h - 40}};
    cv::fillConvexPoly(img, stripe, cv::Scalar(20, 20, 20), cv::LINE_AA);
  }
  cv::putText(img, zone, {rng.integer(40, w / 2), h / 2}, cv::FONT_HERSHEY_DUPLEX, 3.2, cv::Scalar(30, 30, 30), 9, cv::LINE_AA);
  cv::putText(img, random_code(rng, 0, 3), {rng.integer(w / 2 + 60, w - 200), h / 3}, cv::FONT_HERSHEY_SIMPLEX, 2.0, cv::Scalar(20, 60, 200), 6, cv::LINE_AA);
  for (int i = 0; i < 3; ++i) {
    const cv::Point p(rng.integer(20, w - 120), rng.integer(30, h / 2));
    const int kind = rng.integer(0, 2);
    if (kind == 0) {  // exit sign
      cv::rectangle(img, p, p + cv::Point(110, 45), cv::Scalar(60, 160, 20), cv::FILLED);
      cv::putText(img, "EXIT", p + cv::Point(10, 35), cv::FONT_HERSHEY_SIMPLEX, 1.1, cv::Scalar(255, 255, 255), 3, cv::LINE_AA);
    } else if (kind == 1) {  // warning triangle
      std::vector<cv::Point> tri = {p + cv::Point(40, 0), p + cv::Point(80, 70), p + cv::Point(0, 70)};
      cv::fillConvexPoly(img, tri, cv::Scalar(0, 210, 250), cv::LINE_AA);
      cv::polylines(img, tri, true, cv::Scalar(20, 20, 20), 4, cv::LINE_AA);
      cv::putText(img, "!", p + cv::Point(32, 60), cv::FONT_HERSHEY_DUPLEX, 1.5, cv::Scalar(20, 20, 20), 4, cv::LINE_AA);
    } else {  // fuse box
      cv::rectangle(img, p, p + cv::Point(90, 120), cv::Scalar(160, 160, 150), cv::FILLED);
      cv::rectangle(img, p, p + cv::Point(90, 120), cv::Scalar(80, 80, 80), 2);
      text_block(img, rng, {p.x + 8, p.y + 5, 75, 60}, 7, cv::Scalar(40, 40, 40));
      cv::circle(img, p + cv::Point(70, 100), 6, cv::Scalar(40, 40, 200), cv::FILLED, cv::LINE_AA);
    }
  }
  const int pipe_y = rng.integer(30, 70);
  cv::rectangle(img, {0, pipe_y}, {w - 1, pipe_y + 14}, cv::Scalar(60, 60, 180), cv::FILLED);
  cv::line(img, {0, pipe_y + 3}, {w - 1, pipe_y + 3}, cv::Scalar(120, 120, 230), 2);
  for (int x = rng.integer(30, 120); x < w; x += rng.integer(150, 300)) cv::rectangle(img, {x, pipe_y - 4}, {x + 8, pipe_y + 18}, cv::Scalar(50, 50, 50), cv::FILLED);
  return img;
}

// ---------------------------------------------------------------------------------------------------
// Things: posters, pictures, books, boards, screens, fabrics, doors, labels.

cv::Mat poster(Rng& rng, int w, int h) {
  cv::Mat img(h, w, CV_8UC3);
  const double hue = rng.uniform(0, 360);
  vertical_gradient(img, hsv(hue, rng.uniform(0.2, 0.7), rng.uniform(0.6, 1.0)),
                     hsv(hue + rng.uniform(30, 150), rng.uniform(0.3, 0.9), rng.uniform(0.2, 0.7)));
  const int shapes = rng.integer(25, 45);
  for (int i = 0; i < shapes; ++i) {
    const cv::Scalar col = hsv(hue + rng.uniform(-120, 120), rng.uniform(0.3, 1.0), rng.uniform(0.2, 1.0));
    if (rng.chance(0.4)) {
      blend(img, rng.uniform(0.4, 0.8), [&](cv::Mat& l) { random_shape(l, rng, w / 4.0, col); });
    } else {
      random_shape(img, rng, w / 6.0, col);
    }
  }
  // Title, subtitle and small print.
  const cv::Scalar ink = rng.chance(0.5) ? cv::Scalar(250, 250, 250) : cv::Scalar(15, 15, 15);
  const int band = rng.integer(0, 1) * (h - h / 4);
  blend(img, 0.6, [&](cv::Mat& l) { cv::rectangle(l, {0, band}, {w - 1, band + h / 4}, scale(ink, 0.0) + (ink[0] > 128 ? cv::Scalar(20, 20, 20) : cv::Scalar(235, 235, 235)), cv::FILLED); });
  cv::putText(img, random_word(rng, 4, 8, true), {w / 16, band + h / 9}, random_font(rng), w / 340.0, ink, 3, cv::LINE_AA);
  text_block(img, rng, {w / 16, band + h / 8, w * 7 / 8, h / 9}, 9, ink);
  if (rng.chance(0.5)) block_code(img, rng, {w - 70, h - 70}, 15, 4);
  cv::rectangle(img, {0, 0}, {w - 1, h - 1}, cv::Scalar(30, 30, 30), 6);
  return img;
}

cv::Mat picture(Rng& rng, int w, int h) {
  // A landscape painting: sky, sun, mountain ridges, trees, a lake, in a wooden frame.
  cv::Mat img(h, w, CV_8UC3);
  const double sky_h = rng.uniform(190, 230);
  vertical_gradient(img, hsv(sky_h, 0.6, 0.95), hsv(sky_h - 170, 0.3, 1.0));
  cv::circle(img, {rng.integer(w / 8, w * 7 / 8), rng.integer(h / 8, h / 3)}, rng.integer(15, 40), cv::Scalar(120, 230, 255), cv::FILLED, cv::LINE_AA);
  for (int c = 0; c < 5; ++c) {
    blend(img, 0.6, [&](cv::Mat& l) { cv::ellipse(l, {rng.integer(0, w), rng.integer(10, h / 3)}, {rng.integer(30, 90), rng.integer(8, 20)}, 0, 0, 360, cv::Scalar(250, 250, 250), cv::FILLED, cv::LINE_AA); });
  }
  for (int ridge = 0; ridge < 4; ++ridge) {
    std::vector<cv::Point> pts = {{0, h}};
    double y = h * (0.35 + 0.12 * ridge) + rng.uniform(-20, 20);
    for (int x = 0; x <= w; x += w / 24) {
      y += rng.uniform(-18, 18);
      pts.emplace_back(x, static_cast<int>(y));
    }
    pts.emplace_back(w, h);
    cv::fillPoly(img, std::vector<std::vector<cv::Point>>{pts}, hsv(rng.uniform(80, 150), 0.5, 0.75 - 0.15 * ridge), cv::LINE_AA);
  }
  for (int t = 0; t < 25; ++t) {
    const cv::Point base(rng.integer(0, w), rng.integer(h * 2 / 3, h));
    const int th = rng.integer(20, 70);
    std::vector<cv::Point> tree = {base + cv::Point(0, -th), base + cv::Point(th / 4, 0), base + cv::Point(-th / 4, 0)};
    cv::fillConvexPoly(img, tree, hsv(rng.uniform(90, 150), 0.7, rng.uniform(0.2, 0.45)), cv::LINE_AA);
  }
  cv::rectangle(img, {0, 0}, {w - 1, h - 1}, cv::Scalar(30, 70, 110), 18);
  cv::rectangle(img, {14, 14}, {w - 15, h - 15}, cv::Scalar(60, 130, 180), 4);
  return img;
}

cv::Mat bookshelf(Rng& rng, int w, int h, int shelves) {
  // Rows of book spines seen from the front, with the shelf boards between rows.
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(30, 45, 60));
  const int row_h = h / shelves;
  for (int s = 0; s < shelves; ++s) {
    const int y0 = s * row_h, y1 = (s + 1) * row_h - 14;
    int x = rng.integer(0, 12);
    while (x < w - 8) {
      if (rng.chance(0.06)) {  // a gap or a lying stack
        if (rng.chance(0.5)) {
          int yy = y1;
          for (int k = rng.integer(2, 5); k > 0; --k) {
            const int bh = rng.integer(10, 22), bw = rng.integer(70, 120);
            cv::rectangle(img, {x, yy - bh}, {std::min(w - 1, x + bw), yy - 1}, hsv(rng.uniform(0, 360), rng.uniform(0.3, 0.8), rng.uniform(0.3, 0.9)), cv::FILLED);
            yy -= bh;
          }
          x += 125;
        } else {
          x += rng.integer(15, 45);
        }
        continue;
      }
      const int bw = std::min(rng.integer(12, 42), w - 1 - x);
      if (bw < 12) break;
      const int bh = static_cast<int>((y1 - y0 - 10) * rng.uniform(0.62, 1.0));
      const cv::Scalar col = hsv(rng.uniform(0, 360), rng.uniform(0.25, 0.85), rng.uniform(0.25, 0.9));
      const cv::Rect r(x, y1 - bh, bw, bh);
      cv::rectangle(img, r, col, cv::FILLED);
      // Bands, title and author rotated along the spine.
      const cv::Scalar ink = (col[0] + col[1] + col[2]) / 3 > 120 ? cv::Scalar(20, 20, 20) : cv::Scalar(230, 235, 240);
      for (int b = rng.integer(0, 3); b > 0; --b) {
        const int by = r.y + rng.integer(4, std::max(5, bh - 10));
        cv::rectangle(img, {r.x, by}, {r.x + bw - 1, by + rng.integer(2, 8)}, rng.chance(0.5) ? ink : scale(col, 0.6), cv::FILLED);
      }
      if (bw >= 16) {
        cv::Mat spine(bw - 4, bh - 12, CV_8UC3, col);  // drawn horizontally, then turned
        const std::string title = random_word(rng, 3, 10, rng.chance(0.5));
        cv::putText(spine, title, {rng.integer(2, 20), (bw - 4) * 3 / 4}, random_font(rng), (bw - 4) / 32.0, ink, 1, cv::LINE_AA);
        cv::Mat turned;
        cv::rotate(spine, turned, cv::ROTATE_90_COUNTERCLOCKWISE);
        turned.copyTo(img(cv::Rect(r.x + 2, r.y + 6, turned.cols, turned.rows)));
      }
      cv::line(img, {x + bw - 1, r.y}, {x + bw - 1, y1}, scale(col, 0.5), 1);
      x += bw + (rng.chance(0.2) ? rng.integer(1, 4) : 0);
    }
    // Shelf board with a price-tag-like label now and then.
    cv::rectangle(img, {0, y1}, {w - 1, y1 + 13}, cv::Scalar(70, 110, 150), cv::FILLED);
    cv::line(img, {0, y1}, {w - 1, y1}, cv::Scalar(110, 160, 200), 2);
    for (int lx = rng.integer(10, 100); lx < w - 60; lx += rng.integer(120, 300)) {
      cv::rectangle(img, {lx, y1 + 2}, {lx + 44, y1 + 12}, cv::Scalar(240, 240, 240), cv::FILLED);
      cv::putText(img, random_code(rng, 2, 3), {lx + 2, y1 + 11}, cv::FONT_HERSHEY_PLAIN, 0.6, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
    }
  }
  return img;
}

cv::Mat whiteboard(Rng& rng, int w, int h) {
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(246, 247, 245));
  shade(img, static_cast<std::uint32_t>(rng.next()), 200.0, 0.04, 2);
  const std::vector<cv::Scalar> markers = {{40, 40, 40}, {180, 60, 20}, {40, 40, 200}, {50, 140, 30}};
  for (int i = 0; i < 16; ++i) {
    const cv::Scalar ink = rng.pick(markers);
    const cv::Rect area(rng.integer(10, w - 260), rng.integer(10, h - 140), rng.integer(160, 250), rng.integer(60, 130));
    const int kind = rng.integer(0, 3);
    if (kind == 0) {
      text_block(img, rng, area, rng.uniform(10, 16), ink, cv::FONT_HERSHEY_SCRIPT_SIMPLEX);
    } else if (kind == 1) {  // boxes and arrows diagram
      std::vector<cv::Point> centres;
      for (int k = 0; k < 4; ++k) {
        const cv::Point c(area.x + rng.integer(20, area.width - 20), area.y + rng.integer(15, area.height - 15));
        cv::rectangle(img, c - cv::Point(22, 12), c + cv::Point(22, 12), ink, 2, cv::LINE_AA);
        cv::putText(img, random_word(rng, 2, 4, true), c - cv::Point(18, -5), cv::FONT_HERSHEY_SIMPLEX, 0.4, ink, 1, cv::LINE_AA);
        if (!centres.empty()) cv::arrowedLine(img, centres.back(), c, ink, 2, cv::LINE_AA, 0, 0.1);
        centres.push_back(c);
      }
    } else if (kind == 2) {  // a plot
      cv::line(img, {area.x, area.y + area.height}, {area.x + area.width, area.y + area.height}, ink, 2, cv::LINE_AA);
      cv::line(img, {area.x, area.y}, {area.x, area.y + area.height}, ink, 2, cv::LINE_AA);
      cv::Point prev(area.x, area.y + area.height - 5);
      for (int x = area.x; x < area.x + area.width; x += 8) {
        const cv::Point p(x, area.y + static_cast<int>(area.height * (0.5 + 0.4 * std::sin(x * 0.05) * rng.uniform(0.6, 1.0))));
        cv::line(img, prev, p, rng.pick(markers), 2, cv::LINE_AA);
        prev = p;
      }
    } else {  // equations
      for (int k = 0; k < 3; ++k) {
        std::string eq = random_word(rng, 1, 2, false) + " = " + random_code(rng, 0, 2) + " + " + random_word(rng, 1, 3, false);
        cv::putText(img, eq, {area.x, area.y + 30 + k * 35}, cv::FONT_HERSHEY_SCRIPT_COMPLEX, 0.9, ink, 2, cv::LINE_AA);
      }
    }
  }
  // Sticky notes and the aluminium frame.
  for (int i = 0; i < 12; ++i) {
    const cv::Point p(rng.integer(5, w - 70), rng.integer(5, h - 70));
    const cv::Scalar col = hsv(rng.pick(std::vector<double>{55, 95, 320, 190}), 0.55, 0.98);
    cv::rectangle(img, p, p + cv::Point(60, 60), col, cv::FILLED);
    text_block(img, rng, {p.x + 3, p.y, 55, 55}, 8, cv::Scalar(60, 40, 40), cv::FONT_HERSHEY_SCRIPT_SIMPLEX);
  }
  cv::rectangle(img, {0, 0}, {w - 1, h - 1}, cv::Scalar(180, 180, 185), 12);
  cv::rectangle(img, {0, h - 24}, {w - 1, h - 1}, cv::Scalar(150, 150, 155), cv::FILLED);
  return img;
}

cv::Mat screen(Rng& rng, int w, int h) {
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(40, 30, 30));
  // A code editor: gutter with line numbers, syntax-coloured lines, a side panel and a title bar.
  cv::rectangle(img, {0, 0}, {w - 1, 22}, cv::Scalar(70, 60, 60), cv::FILLED);
  for (int i = 0; i < 4; ++i) cv::putText(img, random_word(rng, 4, 8, false) + ".cpp", {10 + i * 110, 16}, cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(220, 220, 220), 1, cv::LINE_AA);
  cv::rectangle(img, {0, 23}, {110, h - 1}, cv::Scalar(55, 45, 45), cv::FILLED);
  for (int y = 40; y < h; y += 16) cv::putText(img, random_word(rng, 3, 9, false), {8 + 10 * rng.integer(0, 2), y}, cv::FONT_HERSHEY_PLAIN, 0.8, cv::Scalar(190, 190, 170), 1, cv::LINE_AA);
  const std::vector<cv::Scalar> syntax = {{220, 180, 120}, {120, 200, 240}, {150, 230, 150}, {200, 200, 200}, {110, 150, 240}};
  int indent = 0;
  int n = 1;
  for (int y = 40; y < h - 4; y += 14, ++n) {
    cv::putText(img, std::to_string(n), {118, y}, cv::FONT_HERSHEY_PLAIN, 0.75, cv::Scalar(120, 120, 120), 1, cv::LINE_AA);
    indent = std::clamp(indent + rng.integer(-1, 1), 0, 5);
    int x = 150 + indent * 16;
    const int words = rng.integer(0, 6);
    for (int k = 0; k < words && x < w - 40; ++k) {
      const std::string word = random_word(rng, 1, 8, false) + (rng.chance(0.3) ? "(" : "");
      cv::putText(img, word, {x, y}, cv::FONT_HERSHEY_PLAIN, 0.85, rng.pick(syntax), 1, cv::LINE_AA);
      x += static_cast<int>(word.size()) * 8 + 8;
    }
  }
  return img;
}

cv::Mat fabric(Rng& rng, int size, const cv::Scalar& base, const cv::Scalar& accent) {
  // An irregular plaid with a woven texture and a few printed motifs.
  cv::Mat img(size, size, CV_8UC3, base);
  for (int i = 0; i < 14; ++i) {
    const bool vertical = rng.chance(0.5);
    const int pos = rng.integer(0, size), width = rng.integer(3, 30);
    const cv::Scalar col = rng.chance(0.5) ? accent : scale(base, rng.uniform(0.5, 1.4));
    blend(img, 0.45, [&](cv::Mat& l) {
      if (vertical) cv::rectangle(l, {pos, 0}, {pos + width, size - 1}, col, cv::FILLED);
      else cv::rectangle(l, {0, pos}, {size - 1, pos + width}, col, cv::FILLED);
    });
  }
  for (int y = 0; y < size; y += 4) cv::line(img, {0, y}, {size - 1, y}, scale(base, 0.85), 1);
  for (int i = 0; i < 30; ++i) random_shape(img, rng, size / 18.0, mix(accent, base, rng.uniform(0, 0.6)));
  speckle(img, rng, size * 4, 1, scale(base, 0.6), scale(accent, 1.2));
  // A plain rim: box faces that MuJoCo does not texture repeat the edge pixels, so they look plain.
  cv::rectangle(img, {0, 0}, {size - 1, size - 1}, scale(base, 0.9), 4);
  return img;
}

cv::Mat rug(Rng& rng, int size) {
  const double hue = rng.uniform(0, 30);
  cv::Mat img(size, size, CV_8UC3, hsv(hue, 0.7, 0.45));
  // Nested borders and a random medallion field.
  for (int k = 0; k < 5; ++k) {
    const int m = 12 + k * 18;
    cv::rectangle(img, {m, m}, {size - 1 - m, size - 1 - m}, hsv(hue + rng.uniform(-40, 200), 0.6, rng.uniform(0.3, 0.9)), rng.integer(3, 9));
  }
  for (int i = 0; i < 60; ++i) {
    const cv::Point2d c(rng.uniform(110, size - 110), rng.uniform(110, size - 110));
    const int n = rng.integer(4, 8);
    const double r = rng.uniform(8, 35);
    cv::fillPoly(img, std::vector<std::vector<cv::Point>>{random_polygon(rng, c, r, n, 0.2)}, hsv(hue + rng.uniform(-60, 220), 0.6, rng.uniform(0.3, 0.95)), cv::LINE_AA);
    cv::circle(img, c, static_cast<int>(r / 3), hsv(hue + 180, 0.5, 0.9), cv::FILLED, cv::LINE_AA);
  }
  speckle(img, rng, size * 6, 1, cv::Scalar(20, 20, 40), cv::Scalar(160, 170, 200));
  return img;
}

cv::Mat leaves(Rng& rng, int size) {
  cv::Mat img(size, size, CV_8UC3, cv::Scalar(20, 60, 25));
  for (int i = 0; i < 420; ++i) {
    const cv::Point2d c(rng.uniform(0, size), rng.uniform(0, size));
    const double a = rng.uniform(0, 180), len = rng.uniform(8, 24);
    const cv::Scalar col = hsv(rng.uniform(80, 140), rng.uniform(0.5, 0.9), rng.uniform(0.25, 0.8));
    cv::ellipse(img, c, cv::Size(static_cast<int>(len), static_cast<int>(len * 0.35)), a, 0, 360, col, cv::FILLED, cv::LINE_AA);
    cv::line(img, c - cv::Point2d(len * std::cos(a * kPi / 180), len * std::sin(a * kPi / 180)), c + cv::Point2d(len * std::cos(a * kPi / 180), len * std::sin(a * kPi / 180)), scale(col, 0.6), 1, cv::LINE_AA);
  }
  return img;
}

cv::Mat wood(Rng& rng, int w, int h, const cv::Scalar& base) {
  cv::Mat img(h, w, CV_8UC3);
  const std::uint32_t seed = static_cast<std::uint32_t>(rng.next());
  for (int y = 0; y < h; ++y) {
    auto* p = img.ptr<cv::Vec3b>(y);
    for (int x = 0; x < w; ++x) {
      const double warp = 20.0 * fbm(x / 150.0, y / 150.0, seed + 3, 3);
      const double rings = 0.5 + 0.5 * std::sin((y + warp) * 0.35 + 6.0 * fbm(x / 80.0, y / 20.0, seed, 3));
      const double f = 0.75 + 0.3 * std::floor(rings * 6.0) / 6.0;
      for (int k = 0; k < 3; ++k) p[x][k] = cv::saturate_cast<uchar>(base[k] * f);
    }
  }
  for (int i = 0; i < 6; ++i) {
    const cv::Point c(rng.integer(0, w), rng.integer(0, h));
    cv::ellipse(img, c, {rng.integer(10, 24), rng.integer(4, 8)}, 0, 0, 360, scale(base, 0.45), cv::FILLED, cv::LINE_AA);
  }
  speckle(img, rng, w * h / 200, 1, scale(base, 0.5), scale(base, 1.2));
  return img;
}

cv::Mat door(Rng& rng, int w, int h) {
  cv::Mat img = wood(rng, w, h, cv::Scalar(70, 110, 150));
  const cv::Scalar dark(40, 70, 100);
  cv::rectangle(img, {22, 22}, {w - 23, h * 2 / 5}, dark, 4, cv::LINE_AA);
  cv::rectangle(img, {22, h * 2 / 5 + 30}, {w - 23, h - 23}, dark, 4, cv::LINE_AA);
  cv::circle(img, {w - 40, h / 2}, 10, cv::Scalar(160, 170, 180), cv::FILLED, cv::LINE_AA);
  cv::rectangle(img, {w - 48, h / 2 + 16}, {w - 32, h / 2 + 40}, cv::Scalar(140, 150, 160), cv::FILLED);
  cv::rectangle(img, {w / 2 - 50, 60}, {w / 2 + 50, 95}, cv::Scalar(235, 235, 235), cv::FILLED);
  cv::putText(img, random_code(rng, 1, 3), {w / 2 - 40, 88}, cv::FONT_HERSHEY_SIMPLEX, 0.9, cv::Scalar(30, 30, 30), 2, cv::LINE_AA);
  text_block(img, rng, {w / 2 - 60, 110, 120, 60}, 8, cv::Scalar(230, 230, 230));
  return img;
}

cv::Mat metal_cabinet(Rng& rng, int w, int h, int drawers) {
  // A grey steel cabinet front: drawers with handles and label holders, stickers, scratches, a key lock.
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(150, 148, 145));
  shade(img, static_cast<std::uint32_t>(rng.next()), 80.0, 0.06, 3);
  const int dh = h / drawers;
  for (int k = 0; k < drawers; ++k) {
    const cv::Rect r(6, k * dh + 6, w - 12, dh - 12);
    cv::rectangle(img, r, cv::Scalar(95, 95, 95), 2, cv::LINE_AA);
    cv::rectangle(img, {w / 2 - 40, r.y + 20}, {w / 2 + 40, r.y + 34}, cv::Scalar(60, 60, 60), cv::FILLED);  // handle
    const cv::Rect label(w / 2 - 35, r.y + 45, 70, 30);
    cv::rectangle(img, label, cv::Scalar(235, 238, 240), cv::FILLED);
    cv::rectangle(img, label, cv::Scalar(80, 80, 80), 2);
    cv::putText(img, random_code(rng, 2, 2), {label.x + 5, label.y + 21}, cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(30, 30, 30), 1, cv::LINE_AA);
    for (int i = rng.integer(1, 3); i > 0; --i) {  // stickers and notes
      const int nw = rng.integer(25, 50);
      paste(img, note_sheet(rng, nw, nw, rng.chance(0.3)), {rng.integer(12, w - nw - 12), r.y + rng.integer(80, std::max(81, r.height - nw))});
    }
    for (int i = rng.integer(3, 8); i > 0; --i) {  // scratches
      const cv::Point p(rng.integer(10, w - 10), r.y + rng.integer(5, r.height - 5));
      cv::line(img, p, p + cv::Point(rng.integer(-30, 30), rng.integer(-6, 6)), cv::Scalar::all(rng.uniform(90, 200)), 1, cv::LINE_AA);
    }
  }
  cv::circle(img, {w - 30, 30}, 9, cv::Scalar(200, 200, 205), cv::FILLED, cv::LINE_AA);
  cv::line(img, {w - 30, 24}, {w - 30, 36}, cv::Scalar(40, 40, 40), 2);
  cv::rectangle(img, {0, 0}, {w - 1, h - 1}, cv::Scalar(110, 110, 110), 4);
  return img;
}

cv::Mat carton_label(Rng& rng, int size, const cv::Scalar& cardboard) {
  // A cardboard face: uniform rim (the box's other faces only repeat their rim colour), a printed
  // label with text and a barcode, handling symbols, a big stencilled number and tape.
  cv::Mat img(size, size, CV_8UC3, cardboard);
  cv::Mat inner = img(cv::Rect(10, 10, size - 20, size - 20));
  shade(inner, static_cast<std::uint32_t>(rng.next()), 40.0, 0.08, 3);
  cv::rectangle(img, {0, size / 2 - 14}, {size - 1, size / 2 + 14}, scale(cardboard, 1.12), cv::FILLED);  // tape
  const cv::Rect label(rng.integer(18, size / 3), rng.integer(18, size / 3), size / 2, size / 3);
  cv::rectangle(img, label, cv::Scalar(245, 245, 245), cv::FILLED);
  text_block(img, rng, {label.x + 4, label.y, label.width - 8, label.height / 2}, 6, cv::Scalar(20, 20, 20), cv::FONT_HERSHEY_PLAIN);
  barcode(img, rng, {label.x + 6, label.y + label.height / 2 + 4, label.width - 12, label.height / 3});
  cv::rectangle(img, label, cv::Scalar(60, 60, 60), 1);
  const cv::Scalar ink = rng.chance(0.5) ? cv::Scalar(30, 30, 30) : hsv(rng.uniform(0, 360), 0.8, 0.45);
  cv::putText(img, random_code(rng, rng.integer(0, 2), rng.integer(2, 3)), {rng.integer(14, size / 3), size - rng.integer(18, 40)}, cv::FONT_HERSHEY_DUPLEX, size / 170.0, ink, 3, cv::LINE_AA);
  // "This side up" arrows or a fragile glass or a logo.
  const cv::Point corner(size - 70, size - 80);
  switch (rng.integer(0, 2)) {
    case 0:
      for (int k = 0; k < 2; ++k) cv::arrowedLine(img, corner + cv::Point(12 + 26 * k, 55), corner + cv::Point(12 + 26 * k, 5), ink, 5, cv::LINE_AA, 0, 0.4);
      break;
    case 1: {
      std::vector<cv::Point> glass = {corner + cv::Point(10, 5), corner + cv::Point(50, 5), corner + cv::Point(38, 35), corner + cv::Point(22, 35)};
      cv::fillConvexPoly(img, glass, ink, cv::LINE_AA);
      cv::line(img, corner + cv::Point(30, 35), corner + cv::Point(30, 60), ink, 4);
      cv::line(img, corner + cv::Point(18, 60), corner + cv::Point(42, 60), ink, 4);
      break;
    }
    default: {
      cv::Mat logo = img(cv::Rect(corner, cv::Size(60, 60)));
      for (int k = 0; k < 3; ++k) random_shape(logo, rng, 20, ink);
    }
  }
  if (rng.chance(0.5)) block_code(img, rng, {size - rng.integer(80, 110), rng.integer(20, 50)}, 13, 4);
  cv::rectangle(img, {0, 0}, {size - 1, size - 1}, scale(cardboard, 0.8), 6);
  return img;
}

cv::Mat sign(Rng& rng, int w, int h, const std::string& text, const cv::Scalar& bg, const cv::Scalar& fg) {
  cv::Mat img(h, w, CV_8UC3, bg);
  cv::rectangle(img, {6, 6}, {w - 7, h - 7}, fg, 4);
  int base = 0;
  const double s = h / 40.0;
  const cv::Size ts = cv::getTextSize(text, cv::FONT_HERSHEY_DUPLEX, s, 8, &base);
  cv::putText(img, text, {(w - ts.width) / 2, (h + ts.height) / 2}, cv::FONT_HERSHEY_DUPLEX, s, fg, 8, cv::LINE_AA);
  // Small print: rack codes and load limits, different on every sign.
  cv::putText(img, random_code(rng, 3, 4), {14, h - 14}, cv::FONT_HERSHEY_PLAIN, 1.0, fg, 1, cv::LINE_AA);
  cv::putText(img, std::to_string(rng.integer(5, 20) * 100) + " kg", {w - 90, h - 14}, cv::FONT_HERSHEY_PLAIN, 1.0, fg, 1, cv::LINE_AA);
  return img;
}

// ---------------------------------------------------------------------------------------------------

struct Texture {
  std::string name;  // file name without .png
  std::function<cv::Mat(Rng&)> make;
};

std::vector<Texture> all_textures() {
  std::vector<Texture> t;
  // Floors and ceiling.
  t.push_back({"floor_wood_oak", [](Rng& r) { return wood_planks(r, 1024, cv::Scalar(80, 135, 185), 14, 0.45); }});
  t.push_back({"floor_wood_walnut", [](Rng& r) { return wood_planks(r, 1024, cv::Scalar(50, 80, 120), 16, 0.4); }});
  t.push_back({"floor_stone_tiles", [](Rng& r) { return stone_tiles(r, 1024, 6, cv::Scalar(170, 185, 195), cv::Scalar(90, 95, 100)); }});
  t.push_back({"floor_carpet_blue", [](Rng& r) { return carpet(r, 512, cv::Scalar(110, 60, 40), cv::Scalar(190, 140, 100)); }});
  t.push_back({"floor_concrete_a", [](Rng& r) { return concrete(r, 1024, cv::Scalar(150, 155, 160), true); }});
  t.push_back({"floor_concrete_b", [](Rng& r) { return concrete(r, 1024, cv::Scalar(140, 148, 150), true); }});
  t.push_back({"ceiling_tiles", [](Rng& r) { return ceiling_tiles(r, 512); }});
  // Walls.
  t.push_back({"wall_brick", [](Rng& r) { return brick_wall(r, 1024, 512, cv::Scalar(60, 80, 160), cv::Scalar(170, 180, 185)); }});
  t.push_back({"wall_wallpaper_warm", [](Rng& r) { return wallpaper(r, 1024, 512, cv::Scalar(180, 215, 235), 0, 60); }});
  t.push_back({"wall_wallpaper_cool", [](Rng& r) { return wallpaper(r, 1024, 512, cv::Scalar(225, 215, 200), 170, 90); }});
  t.push_back({"wall_kitchen_tiles", [](Rng& r) { return wall_tiles(r, 1024, 512, cv::Scalar(230, 225, 215)); }});
  t.push_back({"wall_office_a", [](Rng& r) { return cluttered_wall(r, 1024, 512, cv::Scalar(200, 215, 220)); }});
  t.push_back({"wall_office_b", [](Rng& r) { return cluttered_wall(r, 1024, 512, cv::Scalar(170, 200, 185)); }});
  t.push_back({"wall_plaster_green", [](Rng& r) { return plaster(r, 1024, 512, cv::Scalar(170, 205, 185), cv::Scalar(220, 230, 235)); }});
  t.push_back({"wall_plaster_yellow", [](Rng& r) { return plaster(r, 1024, 512, cv::Scalar(150, 215, 230), cv::Scalar(90, 120, 150)); }});
  const std::string zones = "ABCDEFGH";
  for (std::size_t i = 0; i < zones.size(); ++i) {
    const std::string zone(1, zones[i]);
    t.push_back({"wall_blocks_" + zone, [zone, i](Rng& r) {
                   const cv::Scalar base(165.0 + 4.0 * static_cast<double>(i % 3), 175.0 + 3.0 * static_cast<double>(i % 4), 180);
                   return concrete_blocks(r, 1024, 512, base, "ZONE " + zone);
                 }});
  }
  // Things.
  for (int i = 0; i < 8; ++i) t.push_back({"poster_" + std::to_string(i), [](Rng& r) { return poster(r, 512, 512); }});
  for (int i = 0; i < 4; ++i) t.push_back({"picture_" + std::to_string(i), [](Rng& r) { return picture(r, 512, 384); }});
  for (int i = 0; i < 4; ++i) t.push_back({"books_" + std::to_string(i), [](Rng& r) { return bookshelf(r, 512, 512, 4); }});
  t.push_back({"whiteboard", [](Rng& r) { return whiteboard(r, 1024, 512); }});
  t.push_back({"screen_0", [](Rng& r) { return screen(r, 512, 320); }});
  t.push_back({"screen_1", [](Rng& r) { return screen(r, 512, 320); }});
  t.push_back({"fabric_red", [](Rng& r) { return fabric(r, 256, cv::Scalar(50, 50, 150), cv::Scalar(200, 200, 210)); }});
  t.push_back({"fabric_teal", [](Rng& r) { return fabric(r, 256, cv::Scalar(120, 120, 40), cv::Scalar(60, 200, 230)); }});
  t.push_back({"rug", [](Rng& r) { return rug(r, 512); }});
  t.push_back({"leaves", [](Rng& r) { return leaves(r, 256); }});
  t.push_back({"wood_light", [](Rng& r) { return wood(r, 512, 256, cv::Scalar(120, 170, 210)); }});
  t.push_back({"wood_dark", [](Rng& r) { return wood(r, 512, 256, cv::Scalar(45, 75, 110)); }});
  t.push_back({"door", [](Rng& r) { return door(r, 256, 512); }});
  t.push_back({"cabinet_metal", [](Rng& r) { return metal_cabinet(r, 256, 640, 4); }});
  for (int i = 0; i < 16; ++i) {
    t.push_back({"carton_" + std::to_string(i), [i](Rng& r) {
                   const cv::Scalar cardboard = i % 3 == 2 ? cv::Scalar(200, 205, 205) : cv::Scalar(95 + 6 * (i % 4), 145 + 5 * (i % 3), 190);
                   return carton_label(r, 256, cardboard);
                 }});
  }
  const std::vector<std::string> aisles = {"A1", "A2", "B1", "B2", "C1", "C2", "D1", "D2"};
  for (const auto& a : aisles) {
    t.push_back({"sign_" + a, [a](Rng& r) {
                   // Row colours: A yellow, B blue, C green, D red.
                   const cv::Scalar bg[] = {{0, 200, 250}, {150, 70, 20}, {40, 140, 30}, {30, 30, 190}};
                   const int row = a[0] - 'A';
                   return sign(r, 256, 128, a, bg[row], row == 0 ? cv::Scalar(20, 20, 20) : cv::Scalar(250, 250, 250));
                 }});
  }
  return t;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out_dir = "scenes/textures";
  bool list_only = false;
  std::string only;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--list") {
      list_only = true;
    } else if (arg.rfind("--only=", 0) == 0) {
      only = arg.substr(7);
    } else if (arg == "-h" || arg == "--help") {
      std::printf("usage: fleetslam_make_textures [output_dir (default scenes/textures)] [--list] [--only=SUBSTRING]\n");
      return 0;
    } else if (arg.rfind("-", 0) == 0) {
      std::fprintf(stderr, "fleetslam_make_textures: unknown option %s (see --help)\n", arg.c_str());
      return 2;
    } else {
      out_dir = arg;
    }
  }
  const std::vector<Texture> textures = all_textures();
  if (!only.empty() && std::none_of(textures.begin(), textures.end(),
                                    [&](const Texture& t) { return t.name.find(only) != std::string::npos; })) {
    std::fprintf(stderr, "fleetslam_make_textures: no texture name contains '%s' (see --list)\n", only.c_str());
    return 2;
  }
  try {
    if (!list_only) std::filesystem::create_directories(out_dir);
    std::uintmax_t total = 0;
    for (const Texture& texture : textures) {
      if (!only.empty() && texture.name.find(only) == std::string::npos) continue;
      Rng rng(hash_name(texture.name));
      const cv::Mat img = texture.make(rng);
      const std::string path = out_dir + "/" + texture.name + ".png";
      if (list_only) {
        std::printf("%-24s %dx%d\n", texture.name.c_str(), img.cols, img.rows);
        continue;
      }
      if (!cv::imwrite(path, img, {cv::IMWRITE_PNG_COMPRESSION, 9})) {
        std::fprintf(stderr, "fleetslam_make_textures: cannot write %s\n", path.c_str());
        return 1;
      }
      const auto bytes = std::filesystem::file_size(path);
      total += bytes;
      std::printf("%-24s %4dx%-4d %7.1f KiB\n", texture.name.c_str(), img.cols, img.rows, bytes / 1024.0);
    }
    if (!list_only) std::printf("total %.2f MiB in %s\n", total / (1024.0 * 1024.0), out_dir.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fleetslam_make_textures: %s\n", e.what());
    return 1;
  }
  return 0;
}
