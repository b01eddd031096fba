#pragma once
// Timestamps in the files circtest writes (trace metadata, the history's stored_at, the
// G-code header): ISO 8601 in UTC, one format for all.
#include <ctime>
#include <optional>
#include <string>
#include <string_view>

namespace circtest {

// "2026-11-23T15:47:14Z"; with MILLISECONDS "2026-11-23T15:47:14.123Z" (truncated, not
// rounded: a time never shows later than it was).
std::string utc_iso8601(const std::timespec& time, bool milliseconds = false);

// The wall clock (CLOCK_REALTIME) now, as utc_iso8601.
std::string utc_now_iso8601(bool milliseconds = false);

// A date "YYYY-MM-DD" or date-time "YYYY-MM-DDTHH:MM[:SS[.digits]]" with "Z", "+HH:MM",
// "-HH:MM" or nothing (then read as UTC), checked strictly: month 1-12, the day within its
// month (29 February in leap years only), hour 0-23, minute and second 0-59. Returns it in
// the one form that sorts in time order as text: a date as given, a date-time in UTC as
// "YYYY-MM-DDTHH:MM:SS[.digits]Z"; nullopt for anything else.
std::optional<std::string> canonical_utc_iso8601(std::string_view text);

}  // namespace circtest
