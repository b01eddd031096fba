#pragma once
// The circle fits see bare points, so their refusals (too few points, collinear, not finite)
// name no file. with_rows_context gives such a refusal the trace's file and the lines of the
// rows the points came from, so that no message says "<input>".
#include <fmt/format.h>

#include <cstddef>
#include <string>

#include "circtest/core/error.hpp"
#include "circtest/core/trace.hpp"

namespace circtest::detail {

// FIT() over rows [BEGIN, END) of the trace, which are WHAT ("run 2", "marked span").
template <typename Fit>
auto with_rows_context(const Trace& trace, std::size_t begin, std::size_t end,
                       const std::string& what, const Fit& fit) -> decltype(fit()) {
  try {
    return fit();
  } catch (const InputError& e) {
    if (!e.file().empty()) throw;
    const auto line = [&](std::size_t row) -> std::size_t {
      return row < trace.line_of_row.size() ? trace.line_of_row[row] : trace.header_line;
    };
    const std::size_t first = line(begin);
    const std::size_t last = end > begin ? line(end - 1) : first;
    const std::string message = fmt::format("{} (lines {}-{}): {}", what, first, last, e.detail());
    if (e.code() == ExitCode::parse) throw ParseError(trace.source, first, message);
    throw DataError(trace.source, first, message);
  }
}

}  // namespace circtest::detail
