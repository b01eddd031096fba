// circlog-record: writes what the circlog HAL module logs to a trace file. Parses the options
// into a RecordRequest and records it (hal_recording.cpp).
#include <cstdio>

#include "circtest/core/cli.hpp"
#include "options.hpp"

int main(int argc, char** argv) {
  return circtest::run_cli("circlog-record", [&] {
    namespace rec = circtest::circlog_record;
    const auto request = rec::parse_options(argc, argv, stdout);
    if (request) rec::record_from_hal(*request);
    return 0;
  });
}
