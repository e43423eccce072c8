#pragma once
// What every experiment writes: a table as CSV and as Markdown, numbers formatted the same way in both,
// and small statistics over repeated measurements.

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace fleetslam::experiments {

// A table of text cells: one header row, then rows of the same width (checked when written).
struct Table {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;

  // RFC 4180: fields with a comma, quote or newline are quoted; "\n" line ends; a trailing newline.
  std::string csv() const;
  // A GitHub Markdown table (pipes in cells escaped).
  std::string markdown() const;
};

// `value` with `decimals` digits after the point ("nan" when not finite).
std::string fixed(double value, int decimals);

// Writes `text` to `file` (parent folders created; runner::write_text_file). Throws InputError naming
// the file when it cannot.
void write_text(const std::filesystem::path& file, const std::string& text);

// The distinct items in the order they first appear.
std::vector<std::string> unique_in_order(const std::vector<std::string>& items);

// Mean and median (numpy's: the mean of the two middle values for an even count); NaN when empty.
double mean_of(const std::vector<double>& values);
double median_of(std::vector<double> values);

// The paper's average over repeated runs (PAPER.md section 3): with three or more values the largest and
// the smallest are dropped (one each) and the rest averaged; fewer values are averaged as they are.
double trimmed_mean(std::vector<double> values);

}  // namespace fleetslam::experiments
