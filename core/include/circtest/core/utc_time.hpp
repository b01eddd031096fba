#pragma once
// Timestamps in the files circtest writes (trace metadata, the history's stored_at, the
// G-code header): ISO 8601 in UTC, one format for all.
#include <ctime>
#include <string>

namespace circtest {

// "2026-11-23T15:47:14Z"; with MILLISECONDS "2026-11-23T15:47:14.123Z" (truncated, not
// rounded: a time never shows later than it was).
std::string utc_iso8601(const std::timespec& time, bool milliseconds = false);

// The wall clock (CLOCK_REALTIME) now, as utc_iso8601.
std::string utc_now_iso8601(bool milliseconds = false);

}  // namespace circtest
