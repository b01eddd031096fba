#include "circtest/compensation/comp_table.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"

namespace circtest::compensation {

CompEntry CompTable::at(double position) const {
  if (entries.empty()) return {position, 0.0, 0.0};
  if (position <= entries.front().nominal) {
    return {position, entries.front().forward_trim, entries.front().reverse_trim};
  }
  if (position >= entries.back().nominal) {
    return {position, entries.back().forward_trim, entries.back().reverse_trim};
  }
  const auto hi = std::upper_bound(entries.begin(), entries.end(), position,
                                   [](double p, const CompEntry& e) { return p < e.nominal; });
  const auto lo = hi - 1;
  // Halved when the span overflows (nominals of opposite sign near DBL_MAX, fuzz_comp_table):
  // halving is exact there, and inf / inf would give NaN.
  const double span = hi->nominal - lo->nominal;
  const double t = std::isfinite(span) ? (position - lo->nominal) / span
                                       : (0.5 * position - 0.5 * lo->nominal) /
                                             (0.5 * hi->nominal - 0.5 * lo->nominal);
  // The weighted mean, not lo + t * (hi - lo): the difference of two finite trims of
  // opposite sign can overflow to inf (fuzz_comp_table), the mean of them cannot.
  const auto mix = [t](double a, double b) { return (1.0 - t) * a + t * b; };
  return {position, mix(lo->forward_trim, hi->forward_trim),
          mix(lo->reverse_trim, hi->reverse_trim)};
}

CompTable parse_comp_table(const std::string& text, int type, const std::string& source) {
  if (type != 0 && type != 1) {
    throw ParseError(source, 0, fmt::format("COMP_FILE_TYPE {} (expected 0 or 1)", type));
  }
  CompTable table;
  table.type = type;
  std::istringstream in(text);
  std::size_t line_no = 0;
  std::size_t blank_from = 0;
  for (std::string line; std::getline(in, line);) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos) {
      if (!blank_from) blank_from = line_no;
      continue;
    }
    std::istringstream words(line);
    std::string w[4];
    int n = 0;
    while (n < 4 && words >> w[n]) ++n;
    std::optional<double> v[3];
    bool numbers = n == 3;
    for (int i = 0; numbers && i < 3; ++i) numbers = (v[i] = parse_finite(w[i])).has_value();
    if (!numbers) {
      throw ParseError(source, line_no,
                       fmt::format("expected 'nominal {} {}' (three numbers); LinuxCNC stops "
                                   "reading the table here{}",
                                   type == 0 ? "forward" : "forward_trim",
                                   type == 0 ? "reverse" : "reverse_trim",
                                   line_no == 1 ? " and ignores all of it" : ""));
    }
    if (blank_from) {
      throw ParseError(source, blank_from, "blank line inside the table: LinuxCNC stops there");
    }
    CompEntry e{*v[0], *v[1], *v[2]};
    if (type == 0) e = {e.nominal, e.nominal - e.forward_trim, e.nominal - e.reverse_trim};
    if (!std::isfinite(e.forward_trim) || !std::isfinite(e.reverse_trim)) {
      // Type 0: nominal - actual of two finite numbers can still overflow (fuzz_comp_table).
      throw ParseError(source, line_no, "a trim (nominal - actual) is not a finite number");
    }
    if (!table.entries.empty() && !(e.nominal > table.entries.back().nominal)) {
      throw ParseError(source, line_no, "nominal positions must increase strictly");
    }
    table.entries.push_back(e);
    if (table.entries.size() > kMaxCompEntries) {
      throw ParseError(source, line_no, "more than 256 entries (LinuxCNC's limit)");
    }
  }
  if (table.entries.empty()) throw ParseError(source, 0, "no entry");
  return table;
}

std::string render_comp_table(const CompTable& table) {
  // Shortest text that reads back as the same double (LinuxCNC reads it with %lf): a fixed
  // 9 decimals once rounded a machine's own table on rewriting, and could make two close
  // nominal positions equal (fuzz_comp_table).
  std::string out;
  for (const CompEntry& e : table.entries) {
    if (table.type == 0) {
      out += fmt::format("{} {} {}\n", e.nominal, e.nominal - e.forward_trim,
                         e.nominal - e.reverse_trim);
    } else {
      out += fmt::format("{} {} {}\n", e.nominal, e.forward_trim, e.reverse_trim);
    }
  }
  return out;
}

}  // namespace circtest::compensation
