// report.html of `fleetslam run`: renders the run's metrics and time series (report_html.hpp) as one
// self-contained page: inline CSS, inline SVG charts (one line-chart helper with 1/2/5 x 10^k ticks, one
// top-down map view with equal axes), HTML tables; no script and no external resource. The input is never
// trusted: a missing or odd-typed key is shown as "not available" / "n/a", never thrown on. Numbers are
// printed with std::to_chars at fixed precision, so the same JSON always gives the same bytes.

#include "fleetslam/runner/report_html.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <tuple>
#include <unordered_set>
#include <utility>
#include <vector>

#include "fleetslam/core/error.hpp"
#include "fleetslam/core/markup.hpp"

namespace fleetslam::runner {
namespace {

using nlohmann::json;

constexpr const char* kNotAvailable = "not available";
constexpr const char* kNoValue = "n/a";
constexpr std::array<const char*, 8> kRobotPalette = {"#1f6fd1", "#d9480f", "#2b8a3e", "#9c36b5",
                                                      "#c2255c", "#0b7285", "#e67700", "#5c3d2e"};
constexpr double kPageWidthPx = 760.0;
constexpr std::size_t kMaxPolylinePoints = 2000;
constexpr double kInf = std::numeric_limits<double>::infinity();

// ---------------------------------------------------------------------------------------------------
// Reading the JSON without trusting it.

const json* child(const json* node, const char* key) {
  if (node == nullptr || !node->is_object()) return nullptr;
  const auto it = node->find(key);
  return it == node->end() ? nullptr : &*it;
}

const json* child(const json& node, const char* key) { return child(&node, key); }

// The number at `node` as a double (NaN and inf included); nullopt when it is no number.
std::optional<double> number_of(const json* node) {
  if (node == nullptr || !node->is_number()) return std::nullopt;
  return node->get<double>();
}

std::optional<double> finite_number_of(const json* node) {
  const auto value = number_of(node);
  if (!value || !std::isfinite(*value)) return std::nullopt;
  return value;
}

std::optional<std::string> string_of(const json* node) {
  if (node == nullptr || !node->is_string()) return std::nullopt;
  return node->get<std::string>();
}

std::optional<bool> bool_of(const json* node) {
  if (node == nullptr || !node->is_boolean()) return std::nullopt;
  return node->get<bool>();
}

// The elements of the array at `node`; none when it is no array.
std::vector<const json*> elements_of(const json* node) {
  std::vector<const json*> out;
  if (node == nullptr || !node->is_array()) return out;
  out.reserve(node->size());
  for (const json& element : *node) out.push_back(&element);
  return out;
}

// The first `columns` entries of an array row when they are all finite numbers, else nullopt.
std::optional<std::vector<double>> finite_row(const json* row, std::size_t columns) {
  if (row == nullptr || !row->is_array() || row->size() < columns) return std::nullopt;
  std::vector<double> values;
  values.reserve(columns);
  for (std::size_t i = 0; i < columns; ++i) {
    const auto value = finite_number_of(&(*row)[i]);
    if (!value) return std::nullopt;
    values.push_back(*value);
  }
  return values;
}

// ---------------------------------------------------------------------------------------------------
// Text: locale-independent number formatting (escaping: core::escape_markup).

// `value` with `decimals` digits after the point ("n/a" when not finite); "-0.00" comes out as "0.00".
std::string fixed(double value, int decimals) {
  if (!std::isfinite(value)) return kNoValue;
  std::array<char, 128> buffer{};
  auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value, std::chars_format::fixed,
                              decimals);
  if (result.ec != std::errc()) {
    result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value, std::chars_format::scientific, 3);
  }
  std::string text(buffer.data(), result.ptr);
  if (!text.empty() && text.front() == '-' && text.find_first_not_of("-0.") == std::string::npos) text.erase(0, 1);
  return text;
}

// `fixed` without the trailing zeros of the fraction ("0.0500" -> "0.05", "2.000" -> "2").
std::string fixed_trimmed(double value, int decimals) {
  std::string text = fixed(value, decimals);
  if (text.find('.') == std::string::npos || text.find('e') != std::string::npos) return text;
  text.erase(text.find_last_not_of('0') + 1);
  if (text.back() == '.') text.pop_back();
  return text == "-0" ? "0" : text;
}

// A value of unknown unit: integers as integers, others with a precision that suits their size.
std::string smart_number(double value) {
  if (!std::isfinite(value)) return kNoValue;
  const double magnitude = std::abs(value);
  if (magnitude < 1e15 && value == std::round(value)) return fixed(value, 0);
  if (magnitude >= 100.0) return fixed_trimmed(value, 1);
  if (magnitude >= 1.0) return fixed_trimmed(value, 3);
  return fixed_trimmed(value, 4);
}

// A value and the limit it is judged against, as smart_number prints them, with more decimals where that
// rounding makes two different numbers look the same (0.03004 against 0.03 read "0.03 <= 0.03 FAIL").
std::pair<std::string, std::string> value_and_limit(double value, double limit) {
  std::string v = smart_number(value);
  std::string l = smart_number(limit);
  for (int decimals = 5; v == l && value != limit && decimals <= 17; ++decimals) {
    v = fixed_trimmed(value, decimals);
    l = fixed_trimmed(limit, decimals);
  }
  return {v, l};
}

// Table cell text of a number scaled by `scale` ("n/a" when missing, of another type or not finite).
std::string number_text(const json* node, int decimals, double scale = 1.0) {
  const auto value = number_of(node);
  return value ? fixed(*value * scale, decimals) : kNoValue;
}

std::string count_text(const json* node) {
  const auto value = number_of(node);
  return value ? smart_number(*value) : kNoValue;
}

std::string string_text(const json* node) {
  const auto text = string_of(node);
  return text ? core::escape_markup(*text) : kNoValue;
}

std::string not_available_html() { return std::string("<p class=\"na\">") + kNotAvailable + "</p>\n"; }

std::string px(double value) { return fixed(value, 1); }

// ---------------------------------------------------------------------------------------------------
// Robots: a label and a distinct colour each, the same in every table and chart.

std::string robot_label(const json* robot, std::size_t index) {
  const auto name = string_of(child(robot, "name"));
  if (name && !name->empty()) return *name;
  return "robot " + std::to_string(index + 1);
}

class RobotColours {
 public:
  void add(const std::string& label) {
    if (std::find(labels_.begin(), labels_.end(), label) == labels_.end()) labels_.push_back(label);
  }
  std::string colour_of(const std::string& label) const {
    const auto it = std::find(labels_.begin(), labels_.end(), label);
    if (it == labels_.end()) return "#6b7280";
    return kRobotPalette[static_cast<std::size_t>(it - labels_.begin()) % kRobotPalette.size()];
  }

 private:
  std::vector<std::string> labels_;
};

RobotColours robot_colours(const json& report) {
  RobotColours colours;
  const auto metrics_robots = elements_of(child(child(report, "metrics"), "robots"));
  for (std::size_t i = 0; i < metrics_robots.size(); ++i) colours.add(robot_label(metrics_robots[i], i));
  const auto series_robots = elements_of(child(child(report, "series"), "robots"));
  for (std::size_t i = 0; i < series_robots.size(); ++i) colours.add(robot_label(series_robots[i], i));
  return colours;
}

std::string swatch(const std::string& colour) {
  return "<span class=\"sw\" style=\"background:" + colour + "\"></span>";
}

// ---------------------------------------------------------------------------------------------------
// Axes: "nice" tick steps of 1, 2 or 5 x 10^k.

struct Axis {
  double lo = 0.0;
  double hi = 1.0;
  double step = 0.2;
  int decimals = 1;
};

double nice_step(double span, int target_ticks) {
  const double raw = span / std::max(1, target_ticks);
  if (!(raw > 0.0) || !std::isfinite(raw)) return 1.0;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  const double normalised = raw / magnitude;
  const double factor = normalised < 1.5 ? 1.0 : normalised < 3.5 ? 2.0 : normalised < 7.5 ? 5.0 : 10.0;
  return factor * magnitude;
}

int decimals_for_step(double step) {
  return std::clamp(static_cast<int>(-std::floor(std::log10(step) + 1e-9)), 0, 6);
}

// An axis over [lo, hi] widened to whole steps; a degenerate range is widened first.
Axis nice_axis(double lo, double hi, int target_ticks) {
  if (!std::isfinite(lo) || !std::isfinite(hi)) return Axis{};
  if (hi < lo) std::swap(lo, hi);
  if (hi - lo < 1e-12) {  // widened, without crossing zero from non-negative data
    const double pad = std::abs(lo) > 1e-12 ? std::abs(lo) * 0.1 : 1.0;
    lo = lo >= 0.0 ? std::max(0.0, lo - pad) : lo - pad;
    hi += pad;
  }
  Axis axis;
  axis.step = nice_step(hi - lo, target_ticks);
  axis.lo = std::floor(lo / axis.step + 1e-9) * axis.step;
  axis.hi = std::ceil(hi / axis.step - 1e-9) * axis.step;
  axis.decimals = decimals_for_step(axis.step);
  return axis;
}

std::vector<double> ticks_of(const Axis& axis) {
  std::vector<double> ticks;
  const double first = std::ceil(axis.lo / axis.step - 1e-9) * axis.step;
  for (int i = 0; i < 60; ++i) {
    const double tick = first + i * axis.step;
    if (tick > axis.hi + axis.step * 1e-6) break;
    ticks.push_back(tick);
  }
  return ticks;
}

// ---------------------------------------------------------------------------------------------------
// The line-chart helper (ATE, coverage, keyframe scores).

struct XY {
  double x = 0.0;
  double y = 0.0;
};

struct ChartLine {
  std::string colour;
  std::vector<XY> points;
  bool dashed = false;
};

struct ChartDots {
  std::string colour;
  std::vector<XY> points;
};

struct LineChart {
  std::string description;  // <title> of the SVG
  std::string x_label;
  std::string y_label;
  std::vector<ChartLine> lines;
  std::vector<ChartDots> dots;
  std::optional<double> y_min;  // fixed ends of the y axis (data outside is clamped)
  std::optional<double> y_max;
  double height_px = 240.0;
};

// Every `stride`-th point, the last one always kept, so that at most `max_points` remain.
std::vector<XY> thinned(const std::vector<XY>& points, std::size_t max_points) {
  if (points.size() <= max_points || max_points < 2) return points;
  const std::size_t stride = (points.size() + max_points - 2) / (max_points - 1);
  std::vector<XY> out;
  std::size_t last = 0;
  for (std::size_t i = 0; i < points.size(); i += stride) {
    out.push_back(points[i]);
    last = i;
  }
  if (last + 1 != points.size()) out.push_back(points.back());
  return out;
}

bool chart_has_data(const LineChart& chart) {
  for (const auto& line : chart.lines) {
    if (!line.points.empty()) return true;
  }
  for (const auto& dots : chart.dots) {
    if (!dots.points.empty()) return true;
  }
  return false;
}

struct ChartRange {
  double x_lo = 0.0;
  double x_hi = 0.0;
  double y_lo = 0.0;
  double y_hi = 0.0;
};

ChartRange data_range(const LineChart& chart) {
  ChartRange range{kInf, -kInf, kInf, -kInf};
  const auto take = [&range](const std::vector<XY>& points) {
    for (const XY& p : points) {
      range.x_lo = std::min(range.x_lo, p.x);
      range.x_hi = std::max(range.x_hi, p.x);
      range.y_lo = std::min(range.y_lo, p.y);
      range.y_hi = std::max(range.y_hi, p.y);
    }
  };
  for (const auto& line : chart.lines) take(line.points);
  for (const auto& dots : chart.dots) take(dots.points);
  if (chart.y_min) range.y_lo = *chart.y_min;
  if (chart.y_max) range.y_hi = *chart.y_max;
  return range;
}

// Pixel mapping of a chart's plot area.
struct PlotArea {
  double left = 0.0;
  double top = 0.0;
  double width = 0.0;
  double height = 0.0;
  Axis x;
  Axis y;
  double to_px_x(double value) const { return left + (value - x.lo) / (x.hi - x.lo) * width; }
  double to_px_y(double value) const { return top + (y.hi - value) / (y.hi - y.lo) * height; }
};

std::string svg_open(double width_px, double height_px, const std::string& description) {
  return "<svg class=\"chart\" role=\"img\" width=\"" + px(width_px) +
         "\" height=\"" + px(height_px) + "\" viewBox=\"0 0 " + px(width_px) + " " + px(height_px) + "\"><title>" +
         core::escape_markup(description) + "</title>\n";
}

std::string svg_text(double x, double y, const std::string& anchor, const std::string& text,
                     const std::string& extra = {}) {
  return "<text x=\"" + px(x) + "\" y=\"" + px(y) + "\" text-anchor=\"" + anchor + "\"" + extra + ">" +
         core::escape_markup(text) + "</text>";
}

std::string axes_svg(const PlotArea& area, const std::string& x_label, const std::string& y_label) {
  std::string svg = "<g class=\"grid\" stroke=\"#e5e7eb\" stroke-width=\"1\">";
  for (const double tick : ticks_of(area.x)) {
    const double x = area.to_px_x(tick);
    svg += "<line x1=\"" + px(x) + "\" y1=\"" + px(area.top) + "\" x2=\"" + px(x) + "\" y2=\"" +
           px(area.top + area.height) + "\"/>";
  }
  for (const double tick : ticks_of(area.y)) {
    const double y = area.to_px_y(tick);
    svg += "<line x1=\"" + px(area.left) + "\" y1=\"" + px(y) + "\" x2=\"" + px(area.left + area.width) +
           "\" y2=\"" + px(y) + "\"/>";
  }
  svg += "</g>\n<rect x=\"" + px(area.left) + "\" y=\"" + px(area.top) + "\" width=\"" + px(area.width) +
         "\" height=\"" + px(area.height) + "\" fill=\"none\" stroke=\"#9ca3af\"/>\n<g>";
  const double bottom = area.top + area.height;
  for (const double tick : ticks_of(area.x)) {
    svg += svg_text(area.to_px_x(tick), bottom + 15.0, "middle", fixed(tick, area.x.decimals));
  }
  for (const double tick : ticks_of(area.y)) {
    svg += svg_text(area.left - 6.0, area.to_px_y(tick) + 4.0, "end", fixed(tick, area.y.decimals));
  }
  svg += svg_text(area.left + area.width / 2.0, bottom + 32.0, "middle", x_label, " class=\"label\"");
  const double y_mid = area.top + area.height / 2.0;
  svg += svg_text(14.0, y_mid, "middle", y_label,
                  " class=\"label\" transform=\"rotate(-90 14.0 " + px(y_mid) + ")\"");
  return svg + "</g>\n";
}

XY clamped_to(const PlotArea& area, const XY& p) {
  return XY{std::clamp(p.x, area.x.lo, area.x.hi), std::clamp(p.y, area.y.lo, area.y.hi)};
}

std::string polyline_svg(const PlotArea& area, const ChartLine& line) {
  std::string points;
  for (const XY& raw : thinned(line.points, kMaxPolylinePoints)) {
    const XY p = clamped_to(area, raw);
    if (!points.empty()) points += ' ';
    points += px(area.to_px_x(p.x)) + "," + px(area.to_px_y(p.y));
  }
  const std::string dash = line.dashed ? " stroke-dasharray=\"6 4\"" : "";
  return "<polyline fill=\"none\" stroke=\"" + line.colour + "\" stroke-width=\"1.8\" stroke-linejoin=\"round\"" +
         dash + " points=\"" + points + "\"/>\n";
}

std::string dots_svg(const PlotArea& area, const ChartDots& dots) {
  std::string svg = "<g fill=\"" + dots.colour + "\" stroke=\"#fff\" stroke-width=\"0.8\">";
  for (const XY& raw : thinned(dots.points, kMaxPolylinePoints)) {
    const XY p = clamped_to(area, raw);
    svg += "<circle cx=\"" + px(area.to_px_x(p.x)) + "\" cy=\"" + px(area.to_px_y(p.y)) + "\" r=\"3\"/>";
  }
  return svg + "</g>\n";
}

// Whether [lo, hi] can be drawn: finite, with a finite span, far from overflowing.
bool drawable_range(double lo, double hi) {
  constexpr double kLargest = 1e12;
  return std::isfinite(hi - lo) && std::abs(lo) < kLargest && std::abs(hi) < kLargest;
}

// One SVG line chart with its axes, or "not available" when it has no (drawable) point.
std::string render_line_chart(const LineChart& chart) {
  if (!chart_has_data(chart)) return not_available_html();
  const ChartRange range = data_range(chart);
  if (!drawable_range(range.x_lo, range.x_hi) || !drawable_range(range.y_lo, range.y_hi)) {
    return std::string("<p class=\"na\">") + kNotAvailable + " (values out of range)</p>\n";
  }
  PlotArea area;
  area.left = 62.0;
  area.top = 10.0;
  area.width = kPageWidthPx - area.left - 16.0;
  area.height = chart.height_px - area.top - 44.0;
  area.x = nice_axis(range.x_lo, range.x_hi, 8);
  area.y = nice_axis(range.y_lo, range.y_hi, 5);
  if (chart.y_min && chart.y_max && *chart.y_max > *chart.y_min) {
    area.y.lo = *chart.y_min;
    area.y.hi = *chart.y_max;
  }
  std::string svg = svg_open(kPageWidthPx, chart.height_px, chart.description);
  svg += axes_svg(area, chart.x_label, chart.y_label);
  for (const auto& line : chart.lines) {
    if (!line.points.empty()) svg += polyline_svg(area, line);
  }
  for (const auto& dots : chart.dots) {
    if (!dots.points.empty()) svg += dots_svg(area, dots);
  }
  return svg + "</svg>\n";
}

// Rows [t, value, ...] of a series as points (x = column 0, y = column `y_column` x `y_scale`).
std::vector<XY> series_points(const json* series, std::size_t y_column, double y_scale) {
  std::vector<XY> points;
  for (const json* row : elements_of(series)) {
    const auto values = finite_row(row, y_column + 1);
    if (values) points.push_back(XY{(*values)[0], (*values)[y_column] * y_scale});
  }
  return points;
}

// ---------------------------------------------------------------------------------------------------
// Legends (HTML, with small inline SVG keys).

std::string legend_key_svg(const std::string& shape) {
  return "<svg width=\"26\" height=\"12\" viewBox=\"0 0 26 12\" aria-hidden=\"true\">" + shape + "</svg>";
}

std::string legend_item(const std::string& key_html, const std::string& label) {
  return "<span>" + key_html + core::escape_markup(label) + "</span>";
}

std::string robots_legend(const std::vector<std::string>& labels, const RobotColours& colours) {
  std::string html = "<div class=\"legend\">";
  for (const auto& label : labels) html += "<span>" + swatch(colours.colour_of(label)) + core::escape_markup(label) + "</span>";
  return html + "</div>\n";
}

// ---------------------------------------------------------------------------------------------------
// Page sections.

std::string css() {
  return R"(body{margin:0;background:#eceff3;color:#1d232b;
  font:14px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,"Helvetica Neue",Arial,sans-serif}
main{max-width:800px;margin:0 auto;padding:22px 20px 40px;background:#fff}
h1{font-size:22px;margin:0 0 6px}
h2{font-size:17px;margin:26px 0 8px;padding-bottom:4px;border-bottom:2px solid #e5e7eb}
h3{font-size:14px;margin:14px 0 2px}
.facts{display:grid;grid-template-columns:max-content 1fr max-content 1fr;gap:2px 14px;margin:6px 0}
.facts dt{color:#6b7280}.facts dd{margin:0;font-weight:600}
.banner{margin:14px 0 6px;padding:12px 20px;border-radius:8px;color:#fff;
  font-size:32px;font-weight:800;letter-spacing:.05em}
.banner small{display:block;font-size:14px;font-weight:500;letter-spacing:0}
.banner.pass{background:#1e8e3e}.banner.fail{background:#c5221f}.banner.unknown{background:#6b7280}
table{border-collapse:collapse;width:100%;font-size:12.5px;margin:4px 0}
th,td{padding:3px 7px;border-bottom:1px solid #e5e7eb;text-align:left;vertical-align:top}
th{background:#f3f4f6;font-weight:600}
.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
.pill{display:inline-block;padding:0 7px;border-radius:9px;color:#fff;font-weight:700;font-size:11.5px}
.pill.pass{background:#1e8e3e}.pill.fail{background:#c5221f}.pill.unknown{background:#6b7280}
.na{color:#6b7280;font-style:italic;margin:4px 0}
.note{color:#4b5563;font-size:12.5px;margin:2px 0 6px}
.sw{display:inline-block;width:11px;height:11px;border-radius:2px;margin-right:5px;vertical-align:-1px}
svg.chart{display:block;max-width:100%;height:auto;margin:4px 0}
svg text{font:11px system-ui,sans-serif;fill:#374151}
svg text.label{font-size:12px;fill:#111827}
.legend{display:flex;flex-wrap:wrap;gap:3px 16px;font-size:12px;color:#374151;margin:2px 0 6px}
.legend svg{vertical-align:middle;margin-right:4px}
section{break-inside:avoid}
@media print{body{background:#fff}main{padding:0}}
)";
}

// "label: value" pairs of the header, a missing value shown as "not available".
std::string fact(const std::string& label, const std::optional<std::string>& value_html) {
  const std::string value = value_html ? *value_html : std::string("<span class=\"na\">") + kNotAvailable + "</span>";
  return "<dt>" + core::escape_markup(label) + "</dt><dd>" + value + "</dd>";
}

std::optional<std::string> number_fact(const json* node, int decimals, const std::string& unit_html,
                                       double scale = 1.0) {
  const auto value = number_of(node);
  if (!value) return std::nullopt;
  if (!std::isfinite(*value)) return std::string(kNoValue);
  return fixed(*value * scale, decimals) + unit_html;
}

std::optional<std::string> count_fact(const json* node) {
  const auto value = number_of(node);
  if (!value) return std::nullopt;
  return smart_number(*value);
}

std::optional<std::string> string_fact(const json* node) {
  const auto text = string_of(node);
  if (!text) return std::nullopt;
  return core::escape_markup(*text);
}

std::string header_section(const json& report) {
  const json* metrics = child(report, "metrics");
  const auto title = string_of(child(report, "title"));
  std::string html =
      "<header><h1>" + core::escape_markup(title ? *title : "fleetslam run report") + "</h1>\n<dl class=\"facts\">";
  html += fact("Scenario", string_fact(child(metrics, "scenario")));
  html += fact("Seed", count_fact(child(metrics, "seed")));
  html += fact("Simulated time", number_fact(child(metrics, "simulated_s"), 2, " s"));
  html += fact("Wall time", number_fact(child(metrics, "wall_s"), 2, " s"));
  html += fact("Real-time factor", number_fact(child(metrics, "real_time_factor"), 3, "&times;"));
  return html + "</dl></header>\n";
}

std::string banner_section(const json* verdict) {
  const auto passed = bool_of(child(verdict, "passed"));
  const auto criteria = elements_of(child(verdict, "criteria"));
  std::size_t passed_count = 0;
  for (const json* criterion : criteria) passed_count += bool_of(child(criterion, "passed")).value_or(false) ? 1 : 0;
  std::string detail;
  if (verdict == nullptr || !verdict->is_object()) {
    detail = std::string("verdict ") + kNotAvailable;
  } else if (criteria.empty()) {
    detail = "no criteria";
  } else {
    detail = std::to_string(passed_count) + " of " + std::to_string(criteria.size()) + " criteria passed";
  }
  const std::string css_class = !passed ? "unknown" : *passed ? "pass" : "fail";
  const std::string word = !passed ? "NO VERDICT" : *passed ? "PASS" : "FAIL";
  return "<div class=\"banner " + css_class + "\" id=\"verdict\">" + word + "<small>" + core::escape_markup(detail) +
         "</small></div>\n";
}

std::string pill(const std::optional<bool>& passed) {
  if (!passed) return std::string("<span class=\"pill unknown\">") + kNoValue + "</span>";
  return *passed ? "<span class=\"pill pass\">PASS</span>" : "<span class=\"pill fail\">FAIL</span>";
}

std::string comparison_html(const json* comparison) {
  const auto text = string_of(comparison);
  if (!text) return "";
  if (*text == "<=") return "&le; ";
  if (*text == ">=") return "&ge; ";
  return core::escape_markup(*text) + " ";
}

std::string criterion_row(const json* criterion, const RobotColours& colours) {
  const auto robot = string_of(child(criterion, "robot"));
  std::string robot_html;
  if (!robot) {
    robot_html = kNoValue;
  } else if (robot->empty()) {
    robot_html = "run-wide";
  } else {
    robot_html = swatch(colours.colour_of(*robot)) + core::escape_markup(*robot);
  }
  const auto value = number_of(child(criterion, "value"));
  const auto limit = number_of(child(criterion, "limit"));
  const auto note = string_of(child(criterion, "note"));
  std::string value_text = value ? smart_number(*value) : kNoValue;
  std::string limit_text = limit ? smart_number(*limit) : kNoValue;
  if (value && limit) std::tie(value_text, limit_text) = value_and_limit(*value, *limit);
  return "<tr><td>" + string_text(child(criterion, "name")) + "</td><td>" + robot_html + "</td><td class=\"num\">" +
         value_text + "</td><td class=\"num\">" + comparison_html(child(criterion, "comparison")) + limit_text +
         "</td><td>" + pill(bool_of(child(criterion, "passed"))) + "</td><td>" + (note ? core::escape_markup(*note) : "") +
         "</td></tr>\n";
}

std::string criteria_section(const json* verdict, const RobotColours& colours) {
  std::string html = "<section><h2>Pass/fail criteria</h2>\n";
  const auto criteria = elements_of(child(verdict, "criteria"));
  if (criteria.empty()) return html + not_available_html() + "</section>\n";
  html += "<table class=\"criteria\"><tr><th>Criterion</th><th>Robot</th><th class=\"num\">Value</th>"
          "<th class=\"num\">Limit</th><th>Result</th><th>Note</th></tr>\n";
  for (const json* criterion : criteria) html += criterion_row(criterion, colours);
  return html + "</table></section>\n";
}

std::string goals_text(const json* robot) {
  const auto reached = number_of(child(robot, "goals_reached"));
  const auto total = number_of(child(robot, "goals_total"));
  if (!reached && !total) return kNoValue;
  return (reached ? smart_number(*reached) : kNoValue) + " / " + (total ? smart_number(*total) : kNoValue);
}

std::string robot_row(const json* robot, std::size_t index, const RobotColours& colours) {
  const std::string label = robot_label(robot, index);
  const json* ate = child(robot, "ate_world_m");
  std::string row = "<tr><td>" + swatch(colours.colour_of(label)) + core::escape_markup(label) + "</td><td>" +
                    string_text(child(robot, "status")) + "</td>";
  for (const char* key : {"frames", "tracked", "lost", "keyframes"}) {
    row += "<td class=\"num\">" + count_text(child(robot, key)) + "</td>";
  }
  for (const char* key : {"rmse", "mean", "max"}) {
    row += "<td class=\"num\">" + number_text(child(ate, key), 1, 100.0) + "</td>";
  }
  row += "<td class=\"num\">" + count_text(child(robot, "collisions")) + "</td><td class=\"num\">" +
         goals_text(robot) + "</td></tr>\n";
  return row;
}

std::string map_facts(const json* metrics) {
  const json* accuracy = child(metrics, "merged_map_accuracy");
  const json* coverage = child(metrics, "coverage");
  std::string html = "<h3>Merged map and coverage</h3>\n<dl class=\"facts\">";
  html += fact("Map points", count_fact(child(accuracy, "map_points")));
  html += fact("Completeness", number_fact(child(accuracy, "completeness"), 1, " %", 100.0));
  html += fact("Error mean", number_fact(child(accuracy, "mean_m"), 1, " cm", 100.0));
  html += fact("Error median", number_fact(child(accuracy, "median_m"), 1, " cm", 100.0));
  html += fact("Error p95", number_fact(child(accuracy, "p95_m"), 1, " cm", 100.0));
  html += fact("Coverage (final)", number_fact(child(coverage, "final"), 1, " %", 100.0));
  html += fact("Free cells (truth)", count_fact(child(coverage, "free_cells_truth")));
  return html + "</dl>\n";
}

std::string robots_section(const json* metrics, const RobotColours& colours) {
  std::string html = "<section><h2>Robots</h2>\n";
  const auto robots = elements_of(child(metrics, "robots"));
  if (robots.empty()) {
    html += not_available_html();
  } else {
    html += "<table class=\"robots\"><tr><th rowspan=\"2\">Robot</th><th rowspan=\"2\">Status</th>"
            "<th class=\"num\" rowspan=\"2\">Frames</th><th class=\"num\" rowspan=\"2\">Tracked</th>"
            "<th class=\"num\" rowspan=\"2\">Lost</th><th class=\"num\" rowspan=\"2\">Keyframes</th>"
            "<th class=\"num\" colspan=\"3\" style=\"text-align:center\">ATE world (cm)</th>"
            "<th class=\"num\" rowspan=\"2\">Collisions</th><th class=\"num\" rowspan=\"2\">Goals</th></tr>\n"
            "<tr><th class=\"num\">rmse</th><th class=\"num\">mean</th><th class=\"num\">max</th></tr>\n";
    for (std::size_t i = 0; i < robots.size(); ++i) html += robot_row(robots[i], i, colours);
    html += "</table>\n";
  }
  return html + map_facts(metrics) + "</section>\n";
}

// ---------------------------------------------------------------------------------------------------
// Top-down view: map points, plans, truth and estimated trajectories, goals, in the world's x-y plane.

struct Bounds {
  double x_min = kInf;
  double x_max = -kInf;
  double y_min = kInf;
  double y_max = -kInf;
  bool valid() const { return x_min <= x_max && y_min <= y_max; }
  void add(double x, double y) {
    x_min = std::min(x_min, x);
    x_max = std::max(x_max, x);
    y_min = std::min(y_min, y);
    y_max = std::max(y_max, y);
  }
};

struct MapPoint {
  double x_m = 0.0;
  double y_m = 0.0;
  std::string colour;  // "#rgb"
  std::uint64_t colour_key = 0x999;  // the same 12 bits as a number
};

struct RobotTracks {
  std::string label;
  std::string colour;
  std::vector<XY> estimated;
  std::vector<XY> truth;
  std::vector<std::vector<XY>> plans;  // latest last
  std::vector<XY> goals;
};

char hex_digit(int value) { return "0123456789abcdef"[std::clamp(value, 0, 15)]; }

// A 0..255 channel (clamped) quantised to one hex digit.
char channel_digit(double value) {
  const double clamped = std::clamp(value, 0.0, 255.0);
  return hex_digit(static_cast<int>(std::lround(clamped * 15.0 / 255.0)));
}

std::vector<MapPoint> map_points_of(const json* series) {
  std::vector<MapPoint> points;
  for (const json* row : elements_of(child(series, "map_points"))) {
    const auto xy = finite_row(row, 2);
    if (!xy) continue;
    MapPoint point{(*xy)[0], (*xy)[1], "#999", 0x999};
    const auto rgb = finite_row(row, 6);
    if (rgb) {
      point.colour = std::string("#") + channel_digit((*rgb)[3]) + channel_digit((*rgb)[4]) + channel_digit((*rgb)[5]);
      point.colour_key = std::stoull(point.colour.substr(1), nullptr, 16);
    }
    points.push_back(point);
  }
  return points;
}

std::vector<XY> xy_rows(const json* rows, std::size_t x_column) {
  std::vector<XY> points;
  for (const json* row : elements_of(rows)) {
    const auto values = finite_row(row, x_column + 2);
    if (values) points.push_back(XY{(*values)[x_column], (*values)[x_column + 1]});
  }
  return points;
}

// The last `max_plans` plans with a drawable path, oldest first. Plans are taken in the order given.
std::vector<std::vector<XY>> latest_plans(const json* plans, std::size_t max_plans) {
  std::vector<std::vector<XY>> paths;
  for (const json* plan : elements_of(plans)) {
    auto path = xy_rows(child(plan, "path_xy"), 0);
    if (path.size() >= 2) paths.push_back(std::move(path));
  }
  if (paths.size() > max_plans) paths.erase(paths.begin(), paths.end() - static_cast<std::ptrdiff_t>(max_plans));
  return paths;
}

std::vector<RobotTracks> robot_tracks(const json* series, const RobotColours& colours) {
  std::vector<RobotTracks> tracks;
  const auto robots = elements_of(child(series, "robots"));
  for (std::size_t i = 0; i < robots.size(); ++i) {
    RobotTracks track;
    track.label = robot_label(robots[i], i);
    track.colour = colours.colour_of(track.label);
    track.estimated = xy_rows(child(robots[i], "estimated_xy"), 1);
    track.truth = xy_rows(child(robots[i], "truth_xy"), 1);
    track.plans = latest_plans(child(robots[i], "plans"), 3);
    track.goals = xy_rows(child(robots[i], "goals_xy"), 0);
    tracks.push_back(std::move(track));
  }
  return tracks;
}

double quantile(std::vector<double> values, double q) {
  const auto k = static_cast<std::size_t>(q * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

// The region to show: the trajectories, plans and goals whole, the map points without their outer 1 %.
Bounds view_bounds(const std::vector<MapPoint>& map, const std::vector<RobotTracks>& tracks) {
  Bounds bounds;
  if (!map.empty()) {
    std::vector<double> xs;
    std::vector<double> ys;
    for (const auto& p : map) {
      xs.push_back(p.x_m);
      ys.push_back(p.y_m);
    }
    bounds.add(quantile(xs, 0.01), quantile(ys, 0.01));
    bounds.add(quantile(xs, 0.99), quantile(ys, 0.99));
  }
  for (const auto& track : tracks) {
    for (const auto* points : {&track.estimated, &track.truth, &track.goals}) {
      for (const XY& p : *points) bounds.add(p.x, p.y);
    }
    for (const auto& plan : track.plans) {
      for (const XY& p : plan) bounds.add(p.x, p.y);
    }
  }
  return bounds;
}

// World metres to SVG pixels with equal scales on both axes and y up.
struct TopDownFrame {
  double left = 52.0;
  double top = 10.0;
  double width = 0.0;
  double height = 0.0;
  double px_per_m = 1.0;
  Axis x;
  Axis y;
  double to_px_x(double x_m) const { return left + (x_m - x.lo) * px_per_m; }
  double to_px_y(double y_m) const { return top + (y.hi - y_m) * px_per_m; }
  bool inside(double x_m, double y_m) const { return x_m >= x.lo && x_m <= x.hi && y_m >= y.lo && y_m <= y.hi; }
};

TopDownFrame top_down_frame(const Bounds& bounds) {
  TopDownFrame frame;
  frame.width = kPageWidthPx - frame.left - 14.0;
  const double span_x = std::max(bounds.x_max - bounds.x_min, 2.0);
  const double span_y = std::max(bounds.y_max - bounds.y_min, 2.0);
  const double pad = 0.04 * std::max(span_x, span_y);
  const double max_height = 640.0;
  const double min_height = 260.0;
  frame.px_per_m = std::min(frame.width / (span_x + 2 * pad), max_height / (span_y + 2 * pad));
  frame.height = std::max(min_height, (span_y + 2 * pad) * frame.px_per_m);
  const double centre_x = (bounds.x_min + bounds.x_max) / 2.0;
  const double centre_y = (bounds.y_min + bounds.y_max) / 2.0;
  const double half_x = frame.width / frame.px_per_m / 2.0;
  const double half_y = frame.height / frame.px_per_m / 2.0;
  const double step = nice_step(2.0 * std::max(half_x, half_y), 8);
  frame.x = Axis{centre_x - half_x, centre_x + half_x, step, decimals_for_step(step)};
  frame.y = Axis{centre_y - half_y, centre_y + half_y, step, decimals_for_step(step)};
  return frame;
}

std::string top_down_axes(const TopDownFrame& frame) {
  PlotArea area;
  area.left = frame.left;
  area.top = frame.top;
  area.width = frame.width;
  area.height = frame.height;
  area.x = frame.x;
  area.y = frame.y;
  return axes_svg(area, "x (m)", "y (m)");
}

// Map points as small squares, one <path> per (quantised) colour, one square per pixel cell and colour.
std::string map_points_svg(const TopDownFrame& frame, const std::vector<MapPoint>& map) {
  constexpr double kSquarePx = 2.0;
  std::map<std::string, std::string> paths_by_colour;
  std::unordered_set<std::uint64_t> drawn_cells;
  for (const auto& point : map) {
    if (!frame.inside(point.x_m, point.y_m)) continue;
    const double x = frame.to_px_x(point.x_m) - kSquarePx / 2.0;
    const double y = frame.to_px_y(point.y_m) - kSquarePx / 2.0;
    const auto cell_x = static_cast<std::uint64_t>(std::max(0.0, std::floor(x / 1.5)));
    const auto cell_y = static_cast<std::uint64_t>(std::max(0.0, std::floor(y / 1.5)));
    if (!drawn_cells.insert((cell_x << 40) | (cell_y << 16) | point.colour_key).second) continue;
    paths_by_colour[point.colour] += "M" + px(x) + " " + px(y) + "h2v2h-2z";
  }
  std::string svg = "<g class=\"map\" opacity=\"0.6\">";
  for (const auto& [colour, path] : paths_by_colour) svg += "<path fill=\"" + colour + "\" d=\"" + path + "\"/>\n";
  return svg + "</g>\n";
}

std::string path_d(const TopDownFrame& frame, const std::vector<XY>& points) {
  std::string d;
  for (const XY& p : thinned(points, kMaxPolylinePoints)) {
    d += (d.empty() ? "M" : " L") + px(frame.to_px_x(p.x)) + " " + px(frame.to_px_y(p.y));
  }
  return d;
}

std::string track_path_svg(const TopDownFrame& frame, const std::vector<XY>& points, const std::string& colour,
                           const std::string& style) {
  if (points.size() < 2) return "";
  return "<path fill=\"none\" stroke=\"" + colour + "\" stroke-linejoin=\"round\" stroke-linecap=\"round\" " +
         style + " d=\"" + path_d(frame, points) + "\"/>\n";
}

std::string start_end_markers(const TopDownFrame& frame, const std::vector<XY>& points, const std::string& colour) {
  if (points.empty()) return "";
  const XY& start = points.front();
  const XY& end = points.back();
  const double ex = frame.to_px_x(end.x);
  const double ey = frame.to_px_y(end.y);
  return "<circle cx=\"" + px(frame.to_px_x(start.x)) + "\" cy=\"" + px(frame.to_px_y(start.y)) +
         "\" r=\"5\" fill=\"" + colour + "\" stroke=\"#fff\" stroke-width=\"1.5\"/>" + "<rect x=\"" + px(ex - 5.0) +
         "\" y=\"" + px(ey - 5.0) + "\" width=\"10\" height=\"10\" fill=\"" + colour +
         "\" stroke=\"#fff\" stroke-width=\"1.5\"/>\n";
}

std::string goal_markers(const TopDownFrame& frame, const std::vector<XY>& goals, const std::string& colour) {
  std::string d;
  for (const XY& goal : goals) {
    const double x = frame.to_px_x(goal.x);
    const double y = frame.to_px_y(goal.y);
    d += "M" + px(x - 5.0) + " " + px(y - 5.0) + "l10 10m0 -10l-10 10";
  }
  if (d.empty()) return "";
  return "<path fill=\"none\" stroke=\"#fff\" stroke-width=\"4.5\" d=\"" + d + "\"/><path fill=\"none\" stroke=\"" +
         colour + "\" stroke-width=\"2.2\" d=\"" + d + "\"/>\n";
}

std::string robot_layers_svg(const TopDownFrame& frame, const std::vector<RobotTracks>& tracks) {
  std::string svg;
  for (const auto& track : tracks) {
    for (std::size_t i = 0; i < track.plans.size(); ++i) {
      const bool latest = i + 1 == track.plans.size();
      svg += track_path_svg(frame, track.plans[i], track.colour,
                            latest ? "stroke-width=\"1.2\" opacity=\"0.75\"" : "stroke-width=\"1\" opacity=\"0.35\"");
    }
  }
  for (const auto& track : tracks) {
    svg += track_path_svg(frame, track.truth, track.colour,
                          "stroke-width=\"1.6\" stroke-dasharray=\"5 4\" opacity=\"0.9\"");
    svg += track_path_svg(frame, track.estimated, "#fff", "stroke-width=\"4\" opacity=\"0.7\"");
    svg += track_path_svg(frame, track.estimated, track.colour, "stroke-width=\"2.2\"");
  }
  for (const auto& track : tracks) {
    svg += start_end_markers(frame, track.estimated.empty() ? track.truth : track.estimated, track.colour);
    svg += goal_markers(frame, track.goals, track.colour);
  }
  return svg;
}

// A bar of a round length (1/2/5 x 10^k m, about a fifth of the width) in the lower left corner.
std::string scale_bar_svg(const TopDownFrame& frame) {
  const double target_m = frame.width / frame.px_per_m / 5.0;
  const double magnitude = std::pow(10.0, std::floor(std::log10(target_m)));
  const double normalised = target_m / magnitude;
  const double length_m = (normalised >= 5.0 ? 5.0 : normalised >= 2.0 ? 2.0 : 1.0) * magnitude;
  const double length_px = length_m * frame.px_per_m;
  const double x = frame.left + 14.0;
  const double y = frame.top + frame.height - 16.0;
  const std::string label = fixed(length_m, decimals_for_step(length_m)) + " m";
  return "<g class=\"scale\"><rect x=\"" + px(x - 6.0) + "\" y=\"" + px(y - 18.0) + "\" width=\"" +
         px(length_px + 12.0) + "\" height=\"26\" fill=\"#fff\" opacity=\"0.85\" rx=\"3\"/><path fill=\"none\" "
         "stroke=\"#111827\" stroke-width=\"2\" d=\"M" + px(x) + " " + px(y - 4.0) + "v6h" + px(length_px) + "v-6\"/>" +
         svg_text(x + length_px / 2.0, y - 6.0, "middle", label, " class=\"label\"") + "</g>\n";
}

std::string top_down_legend(const std::vector<RobotTracks>& tracks, bool has_map) {
  std::string html = "<div class=\"legend\">";
  for (const auto& track : tracks) html += "<span>" + swatch(track.colour) + core::escape_markup(track.label) + "</span>";
  html += legend_item(legend_key_svg("<path d=\"M1 6h24\" stroke=\"#374151\" stroke-width=\"2.2\"/>"), "estimated");
  html += legend_item(legend_key_svg("<path d=\"M1 6h24\" stroke=\"#374151\" stroke-width=\"1.6\" "
                                     "stroke-dasharray=\"5 4\"/>"),
                      "truth");
  html += legend_item(legend_key_svg("<path d=\"M1 6h24\" stroke=\"#374151\" stroke-width=\"1\" opacity=\"0.6\"/>"),
                      "latest plans");
  html += legend_item(legend_key_svg("<circle cx=\"13\" cy=\"6\" r=\"5\" fill=\"#374151\"/>"), "start");
  html += legend_item(legend_key_svg("<rect x=\"8\" y=\"1\" width=\"10\" height=\"10\" fill=\"#374151\"/>"), "end");
  html += legend_item(legend_key_svg("<path d=\"M8 1l10 10m0 -10l-10 10\" stroke=\"#374151\" stroke-width=\"2\"/>"),
                      "goal");
  if (has_map) {
    html += legend_item(legend_key_svg("<rect x=\"7\" y=\"3\" width=\"3\" height=\"3\" fill=\"#999\"/><rect x=\"13\" "
                                       "y=\"6\" width=\"3\" height=\"3\" fill=\"#b85\"/>"),
                        "merged map points");
  }
  return html + "</div>\n";
}

std::string top_down_section(const json* series, const RobotColours& colours) {
  std::string html = "<section><h2>Top-down view (world frame)</h2>\n";
  const auto map = map_points_of(series);
  const auto tracks = robot_tracks(series, colours);
  const Bounds bounds = view_bounds(map, tracks);
  if (!bounds.valid()) return html + not_available_html() + "</section>\n";
  if (!drawable_range(bounds.x_min, bounds.x_max) || !drawable_range(bounds.y_min, bounds.y_max)) {
    return html + "<p class=\"na\">" + kNotAvailable + " (coordinates out of range)</p></section>\n";
  }
  const TopDownFrame frame = top_down_frame(bounds);
  const double height_px = frame.top + frame.height + 44.0;
  html += svg_open(kPageWidthPx, height_px, "Top-down view of the merged map and the robots' trajectories");
  html += "<rect x=\"" + px(frame.left) + "\" y=\"" + px(frame.top) + "\" width=\"" + px(frame.width) +
          "\" height=\"" + px(frame.height) + "\" fill=\"#fbfbfc\"/>\n";
  html += top_down_axes(frame);
  html += map_points_svg(frame, map);
  html += robot_layers_svg(frame, tracks);
  html += scale_bar_svg(frame);
  html += "</svg>\n" + top_down_legend(tracks, !map.empty());
  const std::string map_note = map.empty() ? std::string("map points ") + kNotAvailable
                                           : std::to_string(map.size()) + " map points";
  return html + "<p class=\"note\">" + map_note + "; x to the right, y up, equal scales.</p></section>\n";
}

// ---------------------------------------------------------------------------------------------------
// Charts over time.

std::string ate_section(const json* series, const RobotColours& colours) {
  LineChart chart;
  chart.description = "Absolute trajectory error over time per robot";
  chart.x_label = "time (s)";
  chart.y_label = "ATE (cm)";
  chart.y_min = 0.0;
  std::vector<std::string> labels;
  const auto robots = elements_of(child(series, "robots"));
  for (std::size_t i = 0; i < robots.size(); ++i) {
    const std::string label = robot_label(robots[i], i);
    auto points = series_points(child(robots[i], "ate_over_time"), 1, 100.0);
    if (points.empty()) continue;
    labels.push_back(label);
    chart.lines.push_back(ChartLine{colours.colour_of(label), std::move(points), false});
  }
  std::string html = "<section><h2>ATE over time (world frame)</h2>\n" + render_line_chart(chart);
  if (!labels.empty()) html += robots_legend(labels, colours);
  return html + "</section>\n";
}

std::string coverage_section(const json* series, const json* metrics) {
  LineChart chart;
  chart.description = "Share of the free space covered over time";
  chart.x_label = "time (s)";
  chart.y_label = "coverage (%)";
  chart.y_min = 0.0;
  chart.y_max = 100.0;
  chart.height_px = 220.0;
  auto points = series_points(child(series, "coverage_over_time"), 1, 100.0);
  if (!points.empty()) chart.lines.push_back(ChartLine{"#0b7285", std::move(points), false});
  std::string html = "<section><h2>Coverage of the free space</h2>\n";
  const auto final_share = number_fact(child(child(metrics, "coverage"), "final"), 1, " %", 100.0);
  if (final_share) html += "<p class=\"note\">final coverage: " + *final_share + "</p>\n";
  return html + render_line_chart(chart) + "</section>\n";
}

std::string keyframe_chart(const json* robot, std::size_t index, const RobotColours& colours, const json* metrics) {
  const std::string label = robot_label(robot, index);
  const std::string colour = colours.colour_of(label);
  LineChart chart;
  chart.description = "Keyframe policy score over time of " + label;
  chart.x_label = "time (s)";
  chart.y_label = "score";
  chart.height_px = 190.0;
  ChartDots inserted{"#111827", {}};
  std::size_t decisions = 0;
  for (const json* row : elements_of(child(robot, "keyframe_decisions"))) {
    const auto values = finite_row(row, 3);
    if (!values) continue;
    ++decisions;
    const XY point{(*values)[0], (*values)[1]};
    if ((*values)[2] >= 0.5) inserted.points.push_back(point);
    if (chart.lines.empty()) chart.lines.push_back(ChartLine{colour, {}, false});
    chart.lines.front().points.push_back(point);
  }
  const std::size_t inserted_count = inserted.points.size();
  chart.dots.push_back(std::move(inserted));
  std::string html = "<h3>" + swatch(colour) + core::escape_markup(label) + "</h3>\n";
  if (decisions == 0) return html + not_available_html();
  html += "<p class=\"note\">" + std::to_string(inserted_count) + " keyframes inserted in " +
          std::to_string(decisions) + " decisions";
  for (const json* metrics_robot : elements_of(child(metrics, "robots"))) {
    if (string_of(child(metrics_robot, "name")) != label) continue;
    const auto keyframes = number_of(child(metrics_robot, "keyframes"));
    if (keyframes) html += "; keyframes in the agent's map: " + smart_number(*keyframes);
    break;
  }
  html += " (line: score, dots: inserted)</p>\n";
  return html + render_line_chart(chart);
}

std::string keyframes_section(const json* series, const json* metrics, const RobotColours& colours) {
  std::string html = "<section><h2>Keyframe decisions</h2>\n";
  const auto robots = elements_of(child(series, "robots"));
  if (robots.empty()) return html + not_available_html() + "</section>\n";
  for (std::size_t i = 0; i < robots.size(); ++i) html += keyframe_chart(robots[i], i, colours, metrics);
  return html + "</section>\n";
}

// ---------------------------------------------------------------------------------------------------
// Timings.

std::string robot_timing_rows(const json* robot, std::size_t index, const RobotColours& colours) {
  const json* timings = child(robot, "timings_ms");
  if (timings == nullptr || !timings->is_object() || timings->empty()) return "";
  const std::string label = robot_label(robot, index);
  std::string rows;
  for (const auto& [stage, stats] : timings->items()) {
    rows += "<tr><td>" + swatch(colours.colour_of(label)) + core::escape_markup(label) + "</td><td>" + core::escape_markup(stage) +
            "</td>";
    for (const char* key : {"mean", "median", "p95"}) {
      rows += "<td class=\"num\">" + number_text(child(&stats, key), 2) + "</td>";
    }
    rows += "</tr>\n";
  }
  return rows;
}

std::string central_timings(const json* metrics) {
  const json* timings = child(metrics, "central_timings_ms");
  std::string html = "<h3>Central unit</h3>\n";
  if (timings == nullptr || !timings->is_object() || timings->empty()) return html + not_available_html();
  html += "<table class=\"timings\"><tr><th>Stage</th><th class=\"num\">Time (ms)</th></tr>\n";
  for (const auto& [stage, value] : timings->items()) {
    html += "<tr><td>" + core::escape_markup(stage) + "</td><td class=\"num\">" + number_text(&value, 2) + "</td></tr>\n";
  }
  return html + "</table>\n";
}

std::string timings_section(const json* metrics, const RobotColours& colours) {
  std::string html = "<section><h2>Timings</h2>\n<h3>Per robot and stage (ms)</h3>\n";
  std::string rows;
  const auto robots = elements_of(child(metrics, "robots"));
  for (std::size_t i = 0; i < robots.size(); ++i) rows += robot_timing_rows(robots[i], i, colours);
  if (rows.empty()) {
    html += not_available_html();
  } else {
    html += "<table class=\"timings\"><tr><th>Robot</th><th>Stage</th><th class=\"num\">mean</th>"
            "<th class=\"num\">median</th><th class=\"num\">p95</th></tr>\n" +
            rows + "</table>\n";
  }
  return html + central_timings(metrics) + "</section>\n";
}

}  // namespace

std::string render_report_html(const nlohmann::json& report) {
  const json* metrics = child(report, "metrics");
  const json* series = child(report, "series");
  const json* verdict = child(metrics, "verdict");
  const RobotColours colours = robot_colours(report);
  const auto title = string_of(child(report, "title"));
  std::string html = "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>" +
                     core::escape_markup(title ? *title : "fleetslam run report") + "</title>\n<style>\n" + css() +
                     "</style>\n</head>\n<body>\n<main>\n";
  html += header_section(report);
  html += banner_section(verdict);
  html += criteria_section(verdict, colours);
  html += robots_section(metrics, colours);
  html += top_down_section(series, colours);
  html += ate_section(series, colours);
  html += coverage_section(series, metrics);
  html += keyframes_section(series, metrics, colours);
  html += timings_section(metrics, colours);
  return html + "</main>\n</body>\n</html>\n";
}

void write_report_html(const std::filesystem::path& file, const nlohmann::json& report) {
  const std::string html = render_report_html(report);
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  if (!out) throw InputError(file.string(), "cannot be written (cannot open the file for the HTML report)");
  out.write(html.data(), static_cast<std::streamsize>(html.size()));
  out.close();
  if (!out) throw InputError(file.string(), "cannot be written (writing the HTML report failed)");
}

}  // namespace fleetslam::runner
