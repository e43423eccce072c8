// Evaluation picture as a hand-written SVG (see trajectory_plot.hpp).

#include "fleetslam/core/trajectory_plot.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <vector>

#include "fleetslam/core/error.hpp"
#include "fleetslam/core/markup.hpp"

namespace fleetslam::core {
namespace {

constexpr double kWidth = 900.0;
constexpr double kMapHeight = 620.0;
constexpr double kErrorTop = 700.0;
constexpr double kErrorHeight = 200.0;
constexpr double kHeight = 960.0;
constexpr double kLeft = 80.0;
constexpr double kRight = 20.0;
constexpr double kMapTop = 70.0;
constexpr const char* kGtColour = "#222222";
constexpr const char* kEstColour = "#d62728";
constexpr const char* kErrorColour = "#1f77b4";

std::string number(double v, int decimals = 2) {
  std::array<char, 64> buffer{};
  std::snprintf(buffer.data(), buffer.size(), "%.*f", decimals, v);
  return buffer.data();
}

// A value interval mapped linearly onto a pixel interval (p1 < p0 flips the axis, as SVG y does).
struct Axis {
  double v0 = 0.0, v1 = 1.0;
  double p0 = 0.0, p1 = 1.0;
  double to_px(double v) const { return p0 + (v - v0) / (v1 - v0) * (p1 - p0); }
};

// Round tick spacing (1, 2 or 5 times a power of ten) giving about `count` ticks over `range`.
double nice_step(double range, double count) {
  const double raw = range / count;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0}) {
    if (m * magnitude >= raw) return m * magnitude;
  }
  return 10.0 * magnitude;
}

// Digits enough to tell ticks `step` apart.
int tick_decimals(double step) { return std::max(0, static_cast<int>(std::ceil(-std::log10(step) - 1e-9))); }

// A tick label; the zero tick, reached through round-off, must not print as "-0".
std::string tick_label(double v, double step) { return number(std::fabs(v) < 1e-6 * step ? 0.0 : v, tick_decimals(step)); }

struct PlotPoint {
  double x = 0.0, y = 0.0;
  bool starts_segment = false;
};

// Per sample, whether a gap in `stamps` precedes it: more than five times the median spacing.
std::vector<bool> gap_before(const std::vector<TimeNs>& stamps) {
  std::vector<bool> gap(stamps.size(), false);
  if (stamps.size() < 3) return gap;
  std::vector<TimeNs> spacing;
  for (std::size_t i = 1; i < stamps.size(); ++i) spacing.push_back(stamps[i] - stamps[i - 1]);
  std::nth_element(spacing.begin(), spacing.begin() + static_cast<std::ptrdiff_t>(spacing.size() / 2), spacing.end());
  const TimeNs limit = 5 * spacing[spacing.size() / 2];
  for (std::size_t i = 1; i < stamps.size(); ++i) gap[i] = stamps[i] - stamps[i - 1] > limit;
  return gap;
}

std::vector<TimeNs> stamps_of(const Trajectory& t) {
  std::vector<TimeNs> stamps;
  for (const auto& p : t) stamps.push_back(p.t_ns);
  return stamps;
}

class SvgWriter {
 public:
  void line(double x0, double y0, double x1, double y1, const std::string& style) {
    out_ += "<line x1=\"" + number(x0) + "\" y1=\"" + number(y0) + "\" x2=\"" + number(x1) + "\" y2=\"" +
            number(y1) + "\" style=\"" + style + "\"/>\n";
  }
  void text(double x, double y, const std::string& s, const std::string& attributes = "") {
    out_ += "<text x=\"" + number(x) + "\" y=\"" + number(y) + "\" " + attributes + ">" + escape_markup(s) + "</text>\n";
  }
  // One path; a point starting a new segment (after a gap) is a move, not a line.
  void path(const std::vector<PlotPoint>& points, const std::string& colour, double width) {
    if (points.empty()) return;
    out_ += "<path fill=\"none\" stroke=\"" + colour + "\" stroke-width=\"" + number(width, 1) +
            "\" stroke-linejoin=\"round\" d=\"";
    for (const auto& p : points) out_ += (p.starts_segment ? "M" : "L") + number(p.x, 1) + "," + number(p.y, 1) + " ";
    out_ += "\"/>\n";
  }
  void raw(const std::string& s) { out_ += s; }
  const std::string& str() const { return out_; }

 private:
  std::string out_;
};

// Grid lines, tick labels and axis titles of a panel whose pixel box is given by the two axes.
void draw_axes(SvgWriter& svg, const Axis& x, const Axis& y, const std::string& x_title, const std::string& y_title) {
  const double left = std::min(x.p0, x.p1), right = std::max(x.p0, x.p1);
  const double top = std::min(y.p0, y.p1), bottom = std::max(y.p0, y.p1);
  const std::string grid = "stroke:#dddddd;stroke-width:1";
  const double x_step = nice_step(x.v1 - x.v0, 8.0), y_step = nice_step(y.v1 - y.v0, 6.0);
  for (double v = std::ceil(x.v0 / x_step) * x_step; v <= x.v1 + 1e-9 * x_step; v += x_step) {
    svg.line(x.to_px(v), top, x.to_px(v), bottom, grid);
    svg.text(x.to_px(v), bottom + 16, tick_label(v, x_step), "text-anchor=\"middle\" font-size=\"11\"");
  }
  for (double v = std::ceil(y.v0 / y_step) * y_step; v <= y.v1 + 1e-9 * y_step; v += y_step) {
    svg.line(left, y.to_px(v), right, y.to_px(v), grid);
    svg.text(left - 6, y.to_px(v) + 4, tick_label(v, y_step), "text-anchor=\"end\" font-size=\"11\"");
  }
  svg.raw("<rect x=\"" + number(left) + "\" y=\"" + number(top) + "\" width=\"" + number(right - left) +
          "\" height=\"" + number(bottom - top) + "\" fill=\"none\" stroke=\"#888888\"/>\n");
  svg.text((left + right) / 2, bottom + 36, x_title, "text-anchor=\"middle\" font-size=\"13\"");
  svg.text(left - 55, (top + bottom) / 2, y_title,
           "text-anchor=\"middle\" font-size=\"13\" transform=\"rotate(-90 " + number(left - 55) + " " +
               number((top + bottom) / 2) + ")\"");
}

// The two coordinate axes along which the points extend most, in x, y, z order.
std::array<int, 2> widest_axes(const Trajectory& gt) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const auto& p : gt) {
    lo = lo.cwiseMin(p.T_world_body.translation());
    hi = hi.cwiseMax(p.T_world_body.translation());
  }
  const Eigen::Vector3d extent = hi - lo;
  int narrowest = 0;
  for (int i = 1; i < 3; ++i) {
    if (extent(i) < extent(narrowest)) narrowest = i;
  }
  return narrowest == 0 ? std::array<int, 2>{1, 2} : narrowest == 1 ? std::array<int, 2>{0, 2} : std::array<int, 2>{0, 1};
}

// Equal-scale axes covering every point of both trajectories, padded, fitted into the map box.
std::array<Axis, 2> map_axes(const Trajectory& gt, const Trajectory& est, std::array<int, 2> dims) {
  std::array<double, 2> lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  std::array<double, 2> hi{-lo[0], -lo[1]};
  for (const Trajectory* t : {&gt, &est}) {
    for (const auto& p : *t) {
      for (int i = 0; i < 2; ++i) {
        lo[i] = std::min(lo[i], p.T_world_body.translation()(dims[i]));
        hi[i] = std::max(hi[i], p.T_world_body.translation()(dims[i]));
      }
    }
  }
  const double box_w = kWidth - kLeft - kRight, box_h = kMapHeight - kMapTop;
  // Metres per pixel: the larger need of the two directions, so both fit at the same scale.
  const double span = std::max({(hi[0] - lo[0]) / box_w, (hi[1] - lo[1]) / box_h, 1e-6}) * 1.08;
  const double cx = 0.5 * (lo[0] + hi[0]), cy = 0.5 * (lo[1] + hi[1]);
  Axis x{cx - 0.5 * span * box_w, cx + 0.5 * span * box_w, kLeft, kLeft + box_w};
  Axis y{cy - 0.5 * span * box_h, cy + 0.5 * span * box_h, kMapHeight, kMapTop};
  return {x, y};
}

// Pixel points of a trajectory, dropping points closer than half a pixel to the last one kept.
std::vector<PlotPoint> map_points(const Trajectory& t, const std::array<Axis, 2>& axes, std::array<int, 2> dims) {
  const std::vector<bool> gap = gap_before(stamps_of(t));
  std::vector<PlotPoint> points;
  for (std::size_t i = 0; i < t.size(); ++i) {
    const Eigen::Vector3d& p = t[i].T_world_body.translation();
    const PlotPoint q{axes[0].to_px(p(dims[0])), axes[1].to_px(p(dims[1])), i == 0 || gap[i]};
    if (q.starts_segment || std::hypot(q.x - points.back().x, q.y - points.back().y) >= 0.5) points.push_back(q);
  }
  return points;
}

void draw_legend_and_scale_bar(SvgWriter& svg, const Axis& x, const TrajectoryPlotLabels& labels) {
  const double lx = kLeft + 12, ly = kMapTop + 18;
  svg.raw("<rect x=\"" + number(lx - 6) + "\" y=\"" + number(ly - 14) +
          "\" width=\"210\" height=\"44\" fill=\"white\" fill-opacity=\"0.85\" stroke=\"#aaaaaa\"/>\n");
  svg.line(lx, ly - 4, lx + 24, ly - 4, std::string("stroke:") + kGtColour + ";stroke-width:2");
  svg.text(lx + 30, ly, labels.gt_name, "font-size=\"12\"");
  svg.line(lx, ly + 16, lx + 24, ly + 16, std::string("stroke:") + kEstColour + ";stroke-width:2");
  svg.text(lx + 30, ly + 20, labels.est_name, "font-size=\"12\"");
  // Scale bar: a round length near a fifth of the width, bottom right.
  const double metres = nice_step(x.v1 - x.v0, 5.0);
  const double px = x.to_px(x.v0 + metres) - x.to_px(x.v0);
  const double bx = kWidth - kRight - 16 - px, by = kMapHeight - 16;
  svg.raw("<rect x=\"" + number(bx - 6) + "\" y=\"" + number(by - 20) + "\" width=\"" + number(px + 12) +
          "\" height=\"28\" fill=\"white\" fill-opacity=\"0.85\"/>\n");
  svg.line(bx, by, bx + px, by, "stroke:black;stroke-width:3");
  svg.text(bx + px / 2, by - 6, number(metres, tick_decimals(metres)) + " m", "text-anchor=\"middle\" font-size=\"12\"");
}

void draw_map(SvgWriter& svg, const Trajectory& gt, const Trajectory& est, const TrajectoryPlotLabels& labels) {
  if (gt.empty() && est.empty()) return;
  const std::array<int, 2> dims = widest_axes(gt.empty() ? est : gt);
  const std::array<Axis, 2> axes = map_axes(gt, est, dims);
  const std::array<const char*, 3> names{"x", "y", "z"};
  draw_axes(svg, axes[0], axes[1], std::string(names[static_cast<std::size_t>(dims[0])]) + " [m]",
            std::string(names[static_cast<std::size_t>(dims[1])]) + " [m]");
  svg.path(map_points(gt, axes, dims), kGtColour, 1.5);
  svg.path(map_points(est, axes, dims), kEstColour, 1.2);
  draw_legend_and_scale_bar(svg, axes[0], labels);
}

// Abscissa of each pair: seconds since the first pair, or the ground-truth pose index.
std::vector<double> error_abscissa(const AteResult& ate, bool over_time) {
  std::vector<double> x;
  for (std::size_t i = 0; i < ate.errors_m.size(); ++i) {
    x.push_back(over_time ? ns_to_seconds(ate.t_ns[i] - ate.t_ns.front()) : static_cast<double>(ate.pairs[i].gt_index));
  }
  return x;
}

void draw_error_curve(SvgWriter& svg, const AteResult& ate, bool over_time) {
  if (ate.errors_m.empty()) return;
  const std::vector<double> abscissa = error_abscissa(ate, over_time);
  const double top = std::max(ate.stats.max, 1e-6) * 1.1;
  const Axis x{abscissa.front(), std::max(abscissa.back(), abscissa.front() + 1e-3), kLeft, kWidth - kRight};
  const Axis y{0.0, top, kErrorTop + kErrorHeight, kErrorTop};
  draw_axes(svg, x, y, over_time ? "time since the first pair [s]" : "pose index", "ATE [m]");
  const std::vector<bool> gap = gap_before(ate.t_ns);
  std::vector<PlotPoint> points;
  for (std::size_t i = 0; i < abscissa.size(); ++i) {
    points.push_back({x.to_px(abscissa[i]), y.to_px(ate.errors_m[i]), i == 0 || gap[i]});
  }
  svg.path(points, kErrorColour, 1.0);
  const double rmse_px = y.to_px(ate.stats.rmse);
  const std::string rmse_style = "stroke:#ff7f0e;stroke-width:1.5;stroke-dasharray:6,4";
  svg.line(x.p0, rmse_px, x.p1, rmse_px, rmse_style);
  // The key sits above the panel, clear of the curve.
  svg.line(x.p1 - 150, kErrorTop - 10, x.p1 - 125, kErrorTop - 10, rmse_style);
  svg.text(x.p1 - 120, kErrorTop - 6, "RMSE " + number(ate.stats.rmse, 4) + " m", "font-size=\"12\"");
}

}  // namespace

std::string trajectory_svg(const Trajectory& gt, const Trajectory& est_aligned, const AteResult& ate,
                           const TrajectoryPlotLabels& labels) {
  SvgWriter svg;
  svg.raw("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" +
          number(kWidth, 0) + "\" height=\"" + number(kHeight, 0) + "\" viewBox=\"0 0 " + number(kWidth, 0) + " " +
          number(kHeight, 0) + "\" font-family=\"sans-serif\">\n");
  svg.raw("<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n");
  svg.text(kWidth / 2, 24, labels.title, "text-anchor=\"middle\" font-size=\"15\" font-weight=\"bold\"");
  svg.text(kWidth / 2, 44, labels.subtitle, "text-anchor=\"middle\" font-size=\"13\"");
  draw_map(svg, gt, est_aligned, labels);
  draw_error_curve(svg, ate, labels.errors_over_time);
  svg.raw("</svg>\n");
  return svg.str();
}

void write_trajectory_svg(const std::filesystem::path& path, const Trajectory& gt, const Trajectory& est_aligned,
                          const AteResult& ate, const TrajectoryPlotLabels& labels) {
  const std::string file = path.string();
  std::error_code ec;
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path(), ec);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (ec || !out) throw InputError(file, "cannot open the file for writing");
  out << trajectory_svg(gt, est_aligned, ate, labels);
  out.flush();
  if (!out) throw InputError(file, "write failed");
}

}  // namespace fleetslam::core
