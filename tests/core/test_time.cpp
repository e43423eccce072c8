#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <random>

#include "fleetslam/core/time.hpp"

namespace fleetslam::core {
namespace {

TEST(Time, ParsesDecimalSecondsExactly) {
  EXPECT_EQ(parse_seconds("1305031229.528748"), TimeNs{1305031229528748000});
  EXPECT_EQ(parse_seconds("1311868164.363181"), TimeNs{1311868164363181000});
  EXPECT_EQ(parse_seconds("12"), TimeNs{12'000'000'000});
  EXPECT_EQ(parse_seconds("  0.5 "), TimeNs{500'000'000});
  EXPECT_EQ(parse_seconds("-0.25"), TimeNs{-250'000'000});
  EXPECT_EQ(parse_seconds(".5"), TimeNs{500'000'000});
  EXPECT_EQ(parse_seconds("1403715529.112143517"), TimeNs{1403715529112143517});
}

TEST(Time, RoundsDigitsPastNanoseconds) {
  EXPECT_EQ(parse_seconds("1.0000000004"), TimeNs{1'000'000'000});
  EXPECT_EQ(parse_seconds("1.0000000005"), TimeNs{1'000'000'001});
  EXPECT_EQ(parse_seconds("-1.0000000005"), TimeNs{-1'000'000'001});
}

TEST(Time, ParsesScientificNotationThroughDouble) {
  EXPECT_EQ(parse_seconds("1.403715529112143517e+09"), TimeNs{1403715529112143517});
  
}

TEST(Time, RejectsJunk) {
  for (const char* bad : {"", " ", "abc", "1.2.3", "1,5", "nan", "inf", "1e", "12x", "-", ".", "1e999", "2e-2.5", "2e1.0",
                          "1e-", "1e+"}) {
    EXPECT_FALSE(parse_seconds(bad).has_value()) << bad;
  }
  EXPECT_FALSE(parse_seconds("99999999999999999999").has_value());  // overflow
  EXPECT_FALSE(parse_nanoseconds("9223372036854775808").has_value());
}

TEST(Time, ParsesNanoseconds) {
  EXPECT_EQ(parse_nanoseconds("1403715273262142976"), TimeNs{1403715273262142976});
  EXPECT_EQ(parse_nanoseconds("1403715274312143104.0000000000"), TimeNs{1403715274312143104});
  EXPECT_EQ(parse_nanoseconds("9223372036854775807"), std::numeric_limits<TimeNs>::max());
  EXPECT_FALSE(parse_nanoseconds("14037152a3").has_value());
  // A fraction other than zeros is a stamp in seconds, not nanoseconds to round.
  EXPECT_FALSE(parse_nanoseconds("1.005000000").has_value());
  EXPECT_FALSE(parse_nanoseconds("1403715273262142976.5").has_value());
  EXPECT_EQ(parse_nanoseconds("12.000"), TimeNs{12});
}

TEST(Time, FormatsExactly) {
  EXPECT_EQ(format_seconds(1305031229528748000), "1305031229.528748000");
  EXPECT_EQ(format_seconds(1305031229528748000, 6), "1305031229.528748");
  EXPECT_EQ(format_seconds(-250'000'000, 4), "-0.2500");
  EXPECT_EQ(format_seconds(1'999'999'999, 0), "2");
  EXPECT_EQ(format_seconds(0, 3), "0.000");
  EXPECT_EQ(format_seconds(std::numeric_limits<TimeNs>::min(), 9), "-9223372036.854775808");
}

TEST(Time, FormatParseRoundTripProperty) {
  std::mt19937_64 rng(42);
  std::uniform_int_distribution<TimeNs> dist(-4'000'000'000'000'000'000, 4'000'000'000'000'000'000);
  for (int i = 0; i < 10000; ++i) {
    const TimeNs t = dist(rng);
    ASSERT_EQ(parse_seconds(format_seconds(t)), t);
    ASSERT_EQ(parse_nanoseconds(std::to_string(t)), t);
  }
}

TEST(Time, SecondsConversions) {
  EXPECT_EQ(seconds_to_ns(1.5), 1'500'000'000);
  EXPECT_DOUBLE_EQ(ns_to_seconds(2'500'000'000), 2.5);
}

}  // namespace
}  // namespace fleetslam::core
