// ISO 8601 UTC timestamps against dates worked out by hand (1700000000 s after the epoch is
// 2023-11-14 22:13:20 UTC), and the clock now against time().
#include "circtest/core/utc_time.hpp"

#include <gtest/gtest.h>

#include <ctime>

using circtest::utc_iso8601;
using circtest::utc_now_iso8601;

TEST(UtcTime, SecondsAndMilliseconds) {
  EXPECT_EQ(utc_iso8601(std::timespec{0, 0}), "1970-01-01T00:00:00Z");
  EXPECT_EQ(utc_iso8601(std::timespec{1700000000, 999999999}), "2023-11-14T22:13:20Z");
  EXPECT_EQ(utc_iso8601(std::timespec{1700000000, 123456789}, true), "2023-11-14T22:13:20.123Z");
  // Truncated: 999.9 ms is still second 20.
  EXPECT_EQ(utc_iso8601(std::timespec{1700000000, 999999999}, true), "2023-11-14T22:13:20.999Z");
  EXPECT_EQ(utc_iso8601(std::timespec{951782400, 0}), "2000-02-29T00:00:00Z");  // leap day
}

TEST(UtcTime, NowIsTheWallClock) {
  // The same clock as utc_now_iso8601: std::time() reads Linux's coarse clock, which can still
  // be in the previous second for a few ms after CLOCK_REALTIME has passed it (this test failed
  // so once under load).
  auto seconds = [] {
    std::timespec ts{};
    clock_gettime(CLOCK_REALTIME, &ts);
    return ts.tv_sec;
  };
  const std::time_t before = seconds();
  const std::string now = utc_now_iso8601(true);
  const std::time_t after = seconds();
  ASSERT_EQ(now.size(), 24u) << now;
  EXPECT_EQ(now.back(), 'Z');
  std::tm t{};
  ASSERT_NE(strptime(now.c_str(), "%Y-%m-%dT%H:%M:%S", &t), nullptr) << now;
  const std::time_t parsed = timegm(&t);
  EXPECT_GE(parsed, before);
  EXPECT_LE(parsed, after);
  EXPECT_EQ(utc_now_iso8601().size(), 20u);
}

TEST(UtcTime, CanonicalDatesAreRealDates) {
  using circtest::canonical_utc_iso8601;
  EXPECT_EQ(canonical_utc_iso8601("2026-11-23"), "2026-11-23");
  EXPECT_EQ(canonical_utc_iso8601("2026-11-23T15:47:14Z"), "2026-11-23T15:47:14Z");
  EXPECT_EQ(canonical_utc_iso8601("2026-11-23T15:47:14.123Z"), "2026-11-23T15:47:14.123Z");
  EXPECT_EQ(canonical_utc_iso8601("2026-11-23T15:47"), "2026-11-23T15:47:00Z");
  // An offset is taken off, across a day, a month and a year.
  EXPECT_EQ(canonical_utc_iso8601("2026-11-23T15:47:14+01:00"), "2026-11-23T14:47:14Z");
  EXPECT_EQ(canonical_utc_iso8601("2027-01-01T00:30:00+02:00"), "2026-12-31T22:30:00Z");
  EXPECT_EQ(canonical_utc_iso8601("2024-02-28T23:00:00-05:00"), "2024-02-29T04:00:00Z");
  EXPECT_EQ(canonical_utc_iso8601("2024-02-29"), "2024-02-29");  // leap year
  EXPECT_EQ(canonical_utc_iso8601("2000-02-29"), "2000-02-29");  // divisible by 400
  for (const char* bad :
       {"2026-13-45", "2026-00-10", "2026-04-31", "2025-02-29", "1900-02-29", "2026-11-23T24:00",
        "2026-11-23T10:60", "2026-11-23T10:00:60", "2026-1-5", "2026-11-23 10:00", "yesterday", "",
        "2026-11-23T10:00:00+1:00", "2026-11-23T10:00:00.Z", "2026-11-23Tjunk",
        "2026-11-23T10:00:00Zjunk", "+2026-11-23"}) {
    EXPECT_FALSE(canonical_utc_iso8601(bad).has_value()) << bad;
  }
}
