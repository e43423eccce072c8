#pragma once
// Time is int64 nanoseconds everywhere. Dataset timestamps written as decimal seconds
// ("1305031229.528748") are converted exactly, digit by digit, never through a double.

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>

namespace fleetslam::core {

using TimeNs = std::int64_t;

inline constexpr TimeNs kNsPerSecond = 1'000'000'000;

constexpr double ns_to_seconds(TimeNs t_ns) { return static_cast<double>(t_ns) * 1e-9; }

// Rounds to the nearest nanosecond.
TimeNs seconds_to_ns(double t_s);

// a + b clamped to TimeNs's range: a stamp near either end plus or minus a search window must not wrap.
inline TimeNs saturating_add(TimeNs a, TimeNs b) {
  TimeNs sum = 0;
  if (!__builtin_add_overflow(a, b, &sum)) return sum;
  return b > 0 ? std::numeric_limits<TimeNs>::max() : std::numeric_limits<TimeNs>::min();
}

// Parses decimal seconds ("1305031229.528748", "-0.5", "12") exactly; digits past the ninth decimal
// are rounded half away from zero. Scientific notation ("1.403715529112143517e+09") is exact too.
// nullopt on anything else (empty, NaN, trailing junk, overflow).
std::optional<TimeNs> parse_seconds(std::string_view text);

// Parses an integer nanosecond stamp ("1403715273262142976"); a fractional part of zeros
// ("1403715274312143104.0000000000") is accepted, any other fraction is not (nullopt): "1.005000000" is
// a stamp in seconds, not 1 ns.
std::optional<TimeNs> parse_nanoseconds(std::string_view text);

// Formats t_ns as decimal seconds with `decimals` digits (0..9), exactly ("1305031229.528748000").
std::string format_seconds(TimeNs t_ns, int decimals = 9);

}  // namespace fleetslam::core
