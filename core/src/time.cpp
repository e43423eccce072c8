#include "fleetslam/core/time.hpp"

#include <cctype>
#include <cmath>
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
  text = trim(text);
  const auto e = text.find_first_of("eE");
  if (e == std::string_view::npos) return parse_fixed_point(text, 9);
  // Scientific notation ("1.403715529112143517e+09", as numpy writes stamps): move the decimal
  // point in the digit string and parse exactly.
  std::string_view mantissa = text.substr(0, e);
  std::string_view exponent_text = text.substr(e + 1);
  if (!exponent_text.empty() && exponent_text.front() == '+') exponent_text.remove_prefix(1);
  // An exponent is a whole number: "2e-2.5" is not 2e-3.
  const std::string_view exponent_digits =
      !exponent_text.empty() && exponent_text.front() == '-' ? exponent_text.substr(1) : exponent_text;
  if (exponent_digits.empty() || exponent_digits.find_first_not_of("0123456789") != std::string_view::npos) {
    return std::nullopt;
  }
  const auto exponent = parse_fixed_point(exponent_text, 0);
  if (!exponent || *exponent > 30 || *exponent < -30 || exponent_text.empty()) return std::nullopt;
  std::string sign;
  if (!mantissa.empty() && (mantissa.front() == '-' || mantissa.front() == '+')) {
    sign = std::string(1, mantissa.front());
    mantissa.remove_prefix(1);
  }
  const auto dot = mantissa.find('.');
  std::string digits(mantissa.substr(0, dot));
  if (dot != std::string_view::npos) digits += mantissa.substr(dot + 1);
  if (digits.empty() || !all_digits(digits)) return std::nullopt;
  auto point = static_cast<long>(dot == std::string_view::npos ? mantissa.size() : dot) + static_cast<long>(*exponent);
  if (point < 0) {
    digits.insert(0, static_cast<std::size_t>(-point), '0');
    point = 0;
  }
  if (point > static_cast<long>(digits.size())) digits.append(static_cast<std::size_t>(point) - digits.size(), '0');
  const std::string shifted = sign + digits.substr(0, static_cast<std::size_t>(point)) + "." +
                              digits.substr(static_cast<std::size_t>(point));
  return parse_fixed_point(shifted, 9);
}

std::optional<TimeNs> parse_nanoseconds(std::string_view text) {
  const std::string_view trimmed = trim(text);
  const auto dot = trimmed.find('.');
  if (dot != std::string_view::npos && trimmed.find_first_not_of('0', dot + 1) != std::string_view::npos) {
    return std::nullopt;
  }
  return parse_fixed_point(text, 0);
}

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
