#include "fleetslam/core/time.hpp"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <limits>

namespace fleetslam::core {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

bool all_digits(std::string_view s) {
  for (char c : s) {
    if (!std::isdigit(static_cast<unsigned char>(c))) return false;
  }
  return true;
}

// Parses "[+-]digits[.digits]" as a value scaled by 10^fraction_digits_kept, rounding the rest.
std::optional<TimeNs> parse_fixed_point(std::string_view text, int fraction_digits_kept) {
  text = trim(text);
  bool negative = false;
  if (!text.empty() && (text.front() == '-' || text.front() == '+')) {
    negative = text.front() == '-';
    text.remove_prefix(1);
  }
  const auto dot = text.find('.');
  const std::string_view integer = text.substr(0, dot);
  const std::string_view fraction = dot == std::string_view::npos ? std::string_view{} : text.substr(dot + 1);
  if ((integer.empty() && fraction.empty()) || !all_digits(integer) || !all_digits(fraction)) {
    return std::nullopt;
  }
  constexpr TimeNs kMax = std::numeric_limits<TimeNs>::max();
  TimeNs value = 0;
  auto push_digit = [&](char c) {
    const int d = c - '0';
    if (value > (kMax - d) / 10) return false;
    value = value * 10 + d;
    return true;
  };
  for (char c : integer) {
    if (!push_digit(c)) return std::nullopt;
  }
  for (int i = 0; i < fraction_digits_kept; ++i) {
    const char c = i < static_cast<int>(fraction.size()) ? fraction[static_cast<std::size_t>(i)] : '0';
    if (!push_digit(c)) return std::nullopt;
  }
  if (static_cast<int>(fraction.size()) > fraction_digits_kept &&
      fraction[static_cast<std::size_t>(fraction_digits_kept)] >= '5') {
    if (value == kMax) return std::nullopt;
    ++value;
  }
  return negative ? -value : value;
}

}  // namespace

TimeNs seconds_to_ns(double t_s) { return static_cast<TimeNs>(std::llround(t_s * 1e9)); }

std::optional<TimeNs> parse_seconds(std::string_view text) {
  if (auto exact = parse_fixed_point(text, 9)) return exact;
  // Scientific notation falls back to a double (the only lossy path).
  const std::string copy(trim(text));
  if (copy.find_first_of("eE") == std::string::npos) return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(copy.c_str(), &end);
  if (end != copy.c_str() + copy.size() || !std::isfinite(v) || std::fabs(v) > 9.2e9) {
    return std::nullopt;
  }
  return seconds_to_ns(v);
}

std::optional<TimeNs> parse_nanoseconds(std::string_view text) { return parse_fixed_point(text, 0); }

std::string format_seconds(TimeNs t_ns, int decimals) {
  if (decimals < 0) decimals = 0;
  if (decimals > 9) decimals = 9;
  const bool negative = t_ns < 0;
  // Work in unsigned to survive INT64_MIN.
  const auto magnitude = negative ? 0 - static_cast<std::uint64_t>(t_ns) : static_cast<std::uint64_t>(t_ns);
  std::uint64_t divisor = 1;
  for (int i = decimals; i < 9; ++i) divisor *= 10;
  std::uint64_t scaled = (magnitude + divisor / 2) / divisor;  // round half up on the magnitude
  std::uint64_t unit = 1;
  for (int i = 0; i < decimals; ++i) unit *= 10;
  std::string out = negative && scaled != 0 ? "-" : "";
  out += std::to_string(scaled / unit);
  if (decimals > 0) {
    std::string frac = std::to_string(scaled % unit);
    out += '.';
    out.append(static_cast<std::size_t>(decimals) - frac.size(), '0');
    out += frac;
  }
  return out;
}

}  // namespace fleetslam::core
