#pragma once
// Plots as self-contained SVG text (no display, no plotting library): a line plot of series over a
// numeric x axis and a grouped bar plot. Axes get "nice" ticks; colours come from one fixed palette in
// series order, so the same data gives the same bytes.

#include <string>
#include <vector>

namespace fleetslam::experiments {

struct PlotSeries {
  std::string name;
  std::vector<double> x;
  std::vector<double> y;  // same size as x; non-finite points are left out
};

struct LinePlot {
  std::string title;
  std::string x_label;
  std::string y_label;
  std::vector<PlotSeries> series;
  bool markers = true;  // a dot on every point (off for long series)
  int width_px = 720;
  int height_px = 420;
};

struct BarGroup {
  std::string label;
  std::vector<double> values;  // one per series name
};

struct BarPlot {
  std::string title;
  std::string y_label;
  std::vector<std::string> series;
  std::vector<BarGroup> groups;
  int width_px = 720;
  int height_px = 420;
};

std::string render_svg(const LinePlot& plot);
std::string render_svg(const BarPlot& plot);

}  // namespace fleetslam::experiments
