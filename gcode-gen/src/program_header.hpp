#pragma once
// The header of circgen's program (internal to the gcode library).
#include <string>
#include <utility>
#include <vector>

#include "circtest/gcode/generator.hpp"
#include "program_writer.hpp"

namespace circtest::gcode_detail {

// The header's key: value lines (the recorder copies them into the trace's metadata).
std::vector<std::pair<std::string, std::string>> program_header(
    const std::vector<CircleTestSpec>& planes, const std::vector<MeasuredRun>& runs,
    const ProgramWriter& w);

}  // namespace circtest::gcode_detail
