// Text lists of the dataset layouts: rows with line numbers, numbers, image lists, absent images.

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <system_error>

#include <spdlog/logger.h>

#include "dataset_internal.hpp"
#include "fleetslam/core/error.hpp"

namespace fleetslam::core::dataset_detail {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

// Commas separate fields when the line has any (EuRoC csv); otherwise runs of blanks do (TUM).
std::vector<std::string> split_fields(std::string_view line) {
  std::vector<std::string> fields;
  if (line.find(',') != std::string_view::npos) {
    std::size_t start = 0;
    while (true) {
      const std::size_t comma = line.find(',', start);
      fields.emplace_back(trim(line.substr(start, comma - start)));
      if (comma == std::string_view::npos) break;
      start = comma + 1;
    }
    return fields;
  }
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    const std::size_t start = i;
    while (i < line.size() && !std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    if (i > start) fields.emplace_back(line.substr(start, i - start));
  }
  return fields;
}

std::optional<TimeNs> parse_stamp(const std::string& text, StampUnit unit) {
  return unit == StampUnit::kSeconds ? parse_seconds(text) : parse_nanoseconds(text);
}

}  // namespace

std::vector<TextRow> read_text_rows(const std::filesystem::path& file, const std::string& purpose) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) {
    throw InputError(file.string(), "missing file (the " + purpose + ")");
  }
  std::ifstream in(file);
  if (!in) throw InputError(file.string(), "cannot open the " + purpose);
  std::vector<TextRow> rows;
  std::string line;
  std::size_t number = 0;
  while (std::getline(in, line)) {
    ++number;
    const std::string_view text = trim(line);
    if (text.empty() || text.front() == '#') continue;
    rows.push_back({number, split_fields(text)});
  }
  if (in.bad()) throw InputError(file.string(), "read error in the " + purpose);
  return rows;
}

double parse_number(const std::string& text, const std::string& where, const char* column) {
  double value = 0.0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (text.empty() || ec != std::errc() || ptr != end) {
    throw InputError(where, std::string(column) + " '" + text + "' is not a number");
  }
  if (!std::isfinite(value)) {
    throw InputError(where, std::string(column) + " is " + text + ", not a finite number");
  }
  return value;
}

std::vector<ImageRow> read_image_list(const std::filesystem::path& list_file, StampUnit unit,
                                      const std::filesystem::path& image_folder, const std::string& purpose) {
  std::vector<ImageRow> rows;
  for (const TextRow& row : read_text_rows(list_file, purpose)) {
    const std::string where = at_line(list_file.string(), row.line);
    if (row.fields.size() != 2) {
      throw InputError(where, "expected 2 fields (timestamp, image file), found " +
                                  std::to_string(row.fields.size()));
    }
    const std::optional<TimeNs> t_ns = parse_stamp(row.fields[0], unit);
    if (!t_ns) {
      throw InputError(where, "timestamp '" + row.fields[0] + "' is not " +
                                  (unit == StampUnit::kSeconds ? "a valid time in seconds"
                                                               : "integer nanoseconds (one with a fraction is in seconds)"));
    }
    if (row.fields[1].empty()) throw InputError(where, "empty image file name");
    if (!rows.empty() && *t_ns <= rows.back().t_ns) {
      throw InputError(where, "timestamp " + row.fields[0] + " does not increase (previous row " +
                                  rows.back().where + ")");
    }
    rows.push_back({*t_ns, image_folder / row.fields[1], where});
  }
  if (rows.empty()) throw InputError(list_file.string(), "the " + purpose + " lists no images");
  return rows;
}

std::vector<ImageRow> drop_absent_images(std::vector<ImageRow> rows, bool skip_absent,
                                         std::vector<SkippedRow>& skipped, const Logger& logger) {
  std::error_code ec;
  std::vector<bool> present(rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) present[i] = std::filesystem::exists(rows[i].image, ec);
  const auto last_present = std::find(present.rbegin(), present.rend(), true);
  if (!rows.empty() && last_present == present.rend()) {
    throw InputError(rows.front().where, "none of the listed images is present (first: " +
                                             rows.front().image.string() + ")");
  }
  const std::size_t tail_start = static_cast<std::size_t>(present.rend() - last_present);
  std::vector<ImageRow> kept;
  kept.reserve(rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    if (present[i]) {
      kept.push_back(std::move(rows[i]));
      continue;
    }
    const bool in_tail = i >= tail_start;
    const std::string why = "image " + rows[i].image.string() + " is absent" +
                            (in_tail ? " (listed after the last image present)" : "");
    if (!in_tail && !skip_absent) throw InputError(rows[i].where, why);
    logger->warn("{}: {}; row skipped", rows[i].where, why);
    skipped.push_back({rows[i].where, why});
  }
  return kept;
}

TimeNs median_interval_ns(const std::vector<TimeNs>& stamps) {
  if (stamps.size() < 2) return 0;
  std::vector<TimeNs> gaps(stamps.size() - 1);
  for (std::size_t i = 1; i < stamps.size(); ++i) gaps[i - 1] = stamps[i] - stamps[i - 1];
  const auto middle = gaps.begin() + static_cast<std::ptrdiff_t>(gaps.size() / 2);
  std::nth_element(gaps.begin(), middle, gaps.end());
  return *middle;
}

double mean_rate_hz(const std::vector<ImuSample>& samples) {
  if (samples.size() < 2 || samples.back().t_ns <= samples.front().t_ns) return 0.0;
  return static_cast<double>(samples.size() - 1) / ns_to_seconds(samples.back().t_ns - samples.front().t_ns);
}

std::string exact(double value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

Logger or_null(Logger logger) { return logger ? logger : null_logger(); }

}  // namespace fleetslam::core::dataset_detail
