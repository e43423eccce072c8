#include "fleetslam/experiments/svg_plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "fleetslam/core/markup.hpp"
#include "fleetslam/experiments/table.hpp"

namespace fleetslam::experiments {
namespace {

constexpr const char* kPalette[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf"};
constexpr double kLeft = 70.0, kRight = 170.0, kTop = 40.0, kBottom = 55.0;  // margins, px

const char* colour(std::size_t i) { return kPalette[i % (sizeof kPalette / sizeof kPalette[0])]; }

std::string num(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.2f", v);
  return buffer;
}

// Tick step of about `target` intervals over [lo, hi]: 1, 2 or 5 times a power of ten.
double nice_step(double lo, double hi, int target) {
  const double raw = (hi - lo) / target;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  for (const double f : {1.0, 2.0, 5.0, 10.0}) {
    if (f * magnitude >= raw) return f * magnitude;
  }
  return 10.0 * magnitude;
}

std::string tick_label(double v, double step) {
  const int decimals = step >= 1.0 ? 0 : static_cast<int>(std::ceil(-std::log10(step) - 1e-9));
  return fixed(std::abs(v) < step * 1e-6 ? 0.0 : v, std::min(decimals, 6));
}

struct Axis {
  double lo = 0.0, hi = 1.0, step = 0.2;
};

Axis make_axis(double lo, double hi, bool from_zero) {
  if (!std::isfinite(lo) || !std::isfinite(hi)) return {};
  if (from_zero) lo = std::min(lo, 0.0);
  if (hi <= lo) hi = lo + (lo == 0.0 ? 1.0 : std::abs(lo) * 0.1);
  Axis axis;
  axis.step = nice_step(lo, hi, 5);
  axis.lo = std::floor(lo / axis.step) * axis.step;
  axis.hi = std::ceil(hi / axis.step) * axis.step;
  return axis;
}

struct Frame {
  double width, height;
  double x0() const { return kLeft; }
  double x1() const { return width - kRight; }
  double y0() const { return height - kBottom; }
  double y1() const { return kTop; }
};

std::string header(const Frame& f, const std::string& title) {
  return "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + num(f.width) + "\" height=\"" + num(f.height) +
         "\" viewBox=\"0 0 " + num(f.width) + " " + num(f.height) + "\" font-family=\"sans-serif\" font-size=\"12\">\n" +
         "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n" + "<text x=\"" + num(f.width / 2) +
         "\" y=\"22\" text-anchor=\"middle\" font-size=\"15\">" + core::escape_markup(title) + "</text>\n";
}

std::string y_axis(const Frame& f, const Axis& y, const std::string& label) {
  std::string s;
  for (double v = y.lo; v <= y.hi + y.step * 1e-6; v += y.step) {
    const double py = f.y0() - (v - y.lo) / (y.hi - y.lo) * (f.y0() - f.y1());
    s += "<line x1=\"" + num(f.x0()) + "\" y1=\"" + num(py) + "\" x2=\"" + num(f.x1()) + "\" y2=\"" + num(py) +
         "\" stroke=\"#e0e0e0\"/>\n";
    s += "<text x=\"" + num(f.x0() - 6) + "\" y=\"" + num(py + 4) + "\" text-anchor=\"end\">" + tick_label(v, y.step) +
         "</text>\n";
  }
  s += "<text transform=\"translate(16," + num((f.y0() + f.y1()) / 2) + ") rotate(-90)\" text-anchor=\"middle\">" +
       core::escape_markup(label) + "</text>\n";
  s += "<line x1=\"" + num(f.x0()) + "\" y1=\"" + num(f.y0()) + "\" x2=\"" + num(f.x0()) + "\" y2=\"" + num(f.y1()) +
       "\" stroke=\"black\"/>\n";
  s += "<line x1=\"" + num(f.x0()) + "\" y1=\"" + num(f.y0()) + "\" x2=\"" + num(f.x1()) + "\" y2=\"" + num(f.y0()) +
       "\" stroke=\"black\"/>\n";
  return s;
}

std::string legend(const Frame& f, const std::vector<std::string>& names) {
  std::string s;
  for (std::size_t i = 0; i < names.size(); ++i) {
    const double y = f.y1() + 10.0 + 20.0 * static_cast<double>(i);
    s += "<rect x=\"" + num(f.x1() + 12) + "\" y=\"" + num(y - 9) + "\" width=\"14\" height=\"10\" fill=\"" +
         colour(i) + "\"/>\n";
    s += "<text x=\"" + num(f.x1() + 32) + "\" y=\"" + num(y) + "\">" + core::escape_markup(names[i]) + "</text>\n";
  }
  return s;
}

}  // namespace

std::string render_svg(const LinePlot& plot) {
  const Frame f{static_cast<double>(plot.width_px), static_cast<double>(plot.height_px)};
  double x_lo = std::numeric_limits<double>::infinity(), x_hi = -x_lo, y_lo = x_lo, y_hi = -x_lo;
  for (const PlotSeries& s : plot.series) {
    for (std::size_t i = 0; i < std::min(s.x.size(), s.y.size()); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      x_lo = std::min(x_lo, s.x[i]);
      x_hi = std::max(x_hi, s.x[i]);
      y_lo = std::min(y_lo, s.y[i]);
      y_hi = std::max(y_hi, s.y[i]);
    }
  }
  const Axis x = make_axis(x_lo, x_hi, false);
  const Axis y = make_axis(y_lo, y_hi, true);
  const auto px = [&](double v) { return f.x0() + (v - x.lo) / (x.hi - x.lo) * (f.x1() - f.x0()); };
  const auto py = [&](double v) { return f.y0() - (v - y.lo) / (y.hi - y.lo) * (f.y0() - f.y1()); };
  std::string s = header(f, plot.title) + y_axis(f, y, plot.y_label);
  for (double v = x.lo; v <= x.hi + x.step * 1e-6; v += x.step) {
    s += "<text x=\"" + num(px(v)) + "\" y=\"" + num(f.y0() + 18) + "\" text-anchor=\"middle\">" +
         tick_label(v, x.step) + "</text>\n";
  }
  s += "<text x=\"" + num((f.x0() + f.x1()) / 2) + "\" y=\"" + num(f.height - 12) + "\" text-anchor=\"middle\">" +
       core::escape_markup(plot.x_label) + "</text>\n";
  std::vector<std::string> names;
  for (std::size_t k = 0; k < plot.series.size(); ++k) {
    const PlotSeries& series = plot.series[k];
    names.push_back(series.name);
    std::string points, dots;
    for (std::size_t i = 0; i < std::min(series.x.size(), series.y.size()); ++i) {
      if (!std::isfinite(series.x[i]) || !std::isfinite(series.y[i])) continue;
      points += num(px(series.x[i])) + "," + num(py(series.y[i])) + " ";
      if (plot.markers) {
        dots += "<circle cx=\"" + num(px(series.x[i])) + "\" cy=\"" + num(py(series.y[i])) + "\" r=\"3\" fill=\"" +
                colour(k) + "\"/>\n";
      }
    }
    s += "<polyline fill=\"none\" stroke=\"" + std::string(colour(k)) + "\" stroke-width=\"2\" points=\"" + points +
         "\"/>\n" + dots;
  }
  return s + legend(f, names) + "</svg>\n";
}

std::string render_svg(const BarPlot& plot) {
  const Frame f{static_cast<double>(plot.width_px), static_cast<double>(plot.height_px)};
  double y_hi = 0.0;
  for (const BarGroup& g : plot.groups) {
    for (const double v : g.values) {
      if (std::isfinite(v)) y_hi = std::max(y_hi, v);
    }
  }
  const Axis y = make_axis(0.0, y_hi, true);
  const auto py = [&](double v) { return f.y0() - (v - y.lo) / (y.hi - y.lo) * (f.y0() - f.y1()); };
  std::string s = header(f, plot.title) + y_axis(f, y, plot.y_label);
  const double group_w = (f.x1() - f.x0()) / static_cast<double>(std::max<std::size_t>(1, plot.groups.size()));
  const double bar_w = 0.8 * group_w / static_cast<double>(std::max<std::size_t>(1, plot.series.size()));
  for (std::size_t g = 0; g < plot.groups.size(); ++g) {
    const double gx = f.x0() + group_w * static_cast<double>(g);
    for (std::size_t k = 0; k < plot.groups[g].values.size(); ++k) {
      const double v = plot.groups[g].values[k];
      if (!std::isfinite(v)) continue;
      const double bx = gx + 0.1 * group_w + bar_w * static_cast<double>(k);
      s += "<rect x=\"" + num(bx) + "\" y=\"" + num(py(v)) + "\" width=\"" + num(bar_w) + "\" height=\"" +
           num(f.y0() - py(v)) + "\" fill=\"" + colour(k) + "\"/>\n";
    }
    s += "<text x=\"" + num(gx + group_w / 2) + "\" y=\"" + num(f.y0() + 18) + "\" text-anchor=\"middle\">" +
         core::escape_markup(plot.groups[g].label) + "</text>\n";
  }
  return s + legend(f, plot.series) + "</svg>\n";
}

}  // namespace fleetslam::experiments
