#include "circtest/core/utc_time.hpp"

#include <fmt/format.h>

namespace circtest {

std::string utc_iso8601(const std::timespec& time, bool milliseconds) {
  std::tm utc{};
  gmtime_r(&time.tv_sec, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%S", &utc);
  if (!milliseconds) return fmt::format("{}Z", text);
  return fmt::format("{}.{:03d}Z", text, static_cast<int>(time.tv_nsec / 1000000));
}

std::string utc_now_iso8601(bool milliseconds) {
  std::timespec now{};
  clock_gettime(CLOCK_REALTIME, &now);
  return utc_iso8601(now, milliseconds);
}

}  // namespace circtest
