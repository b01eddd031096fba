// The values of the metadata keys the tools interpret (docs/trace-format.md, "Metadata
// values"), checked once when a trace is read: a bad value is a parse error at its own line,
// whichever tool reads the trace, instead of a usage error or a wrong number far away.
#include <fmt/format.h>

#include <array>
#include <cmath>
#include <string>
#include <string_view>

#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/plane.hpp"
#include "circtest/core/trace.hpp"
#include "circtest/core/trace_keys.hpp"

namespace circtest {
namespace {

enum class Kind {
  number,       // one finite number in [min, max] (min excluded when positive is set)
  list,         // comma-separated numbers, each as `number`; `count` of them (0: any, >= 1)
  count,        // a non-negative integer
  plane,        // XY, YZ or ZX
  length_unit,  // mm or inch
};

struct KeyRule {
  std::string_view key;
  Kind kind;
  double min = 0.0;
  double max = 0.0;
  bool positive = false;  // min itself excluded
  std::size_t items = 0;  // for lists
  std::string_view expected;
};

// 100 m is beyond any machine (circgen's plausible positions are +-100,000 mm), 1,000,000
// mm/min beyond any feed. The bounds keep every derived number finite; they are not
// tolerances.
constexpr double kMaxLength = 100'000.0;
constexpr std::array kRules{
    KeyRule{meta_key::radius_mm, Kind::number, 0.0, kMaxLength, true, 0,
            "a radius in mm above 0 and at most 100000"},
    KeyRule{meta_key::diameter_mm, Kind::number, 0.0, 2 * kMaxLength, true, 0,
            "a diameter in mm above 0 and at most 200000"},
    KeyRule{meta_key::radius_in, Kind::number, 0.0, kMaxLength / 25.4, true, 0,
            "a radius in inch above 0 and at most 3937"},
    KeyRule{meta_key::diameter_in, Kind::number, 0.0, 2 * kMaxLength / 25.4, true, 0,
            "a diameter in inch above 0 and at most 7874"},
    KeyRule{meta_key::bar_length_mm, Kind::number, 0.0, kMaxLength, true, 0,
            "a bar length in mm above 0 and at most 100000"},
    KeyRule{meta_key::centre_mm, Kind::list, -kMaxLength, kMaxLength, false, 3,
            "three numbers x,y,z in mm within +-100000"},
    KeyRule{meta_key::feed_mm_per_min, Kind::number, 0.0, 1e6, true, 0,
            "a feed in mm/min above 0 and at most 1000000"},
    KeyRule{meta_key::feeds_mm_per_min, Kind::list, 0.0, 1e6, true, 0,
            "comma-separated feeds in mm/min, each above 0 and at most 1000000"},
    KeyRule{meta_key::arc_deg, Kind::number, 0.0, 3600.0, true, 0,
            "a measured arc in deg above 0 and at most 3600"},
    KeyRule{meta_key::start_deg, Kind::number, -3600.0, 3600.0, false, 0,
            "a start angle in deg within +-3600"},
    KeyRule{meta_key::lead_deg, Kind::number, 0.0, 3600.0, false, 0,
            "a lead arc in deg from 0 to 3600"},
    KeyRule{meta_key::dwell_s, Kind::number, 0.0, 3600.0, false, 0, "a dwell in s from 0 to 3600"},
    KeyRule{meta_key::sample_period_s, Kind::number, 0.0, 10.0, true, 0,
            "a sample period in s above 0 and at most 10"},
    KeyRule{meta_key::temperature_air_C, Kind::number, -273.15, 1000.0, false, 0,
            "a temperature in deg C from -273.15 to 1000"},
    KeyRule{meta_key::temperature_machine_C, Kind::number, -273.15, 1000.0, false, 0,
            "a temperature in deg C from -273.15 to 1000"},
    KeyRule{meta_key::temperature_instrument_C, Kind::number, -273.15, 1000.0, false, 0,
            "a temperature in deg C from -273.15 to 1000"},
    // Real materials lie within 1e-7..3e-5 per K; 1e-3 leaves room for any unit slip that
    // still gives a finite correction, which the report then shows.
    KeyRule{meta_key::expansion_machine_per_K, Kind::number, -1e-3, 1e-3, false, 0,
            "an expansion coefficient per K within +-0.001"},
    KeyRule{meta_key::expansion_instrument_per_K, Kind::number, -1e-3, 1e-3, false, 0,
            "an expansion coefficient per K within +-0.001"},
    // A test set's trace lists its planes in program order (XY,YZ,ZX), each once.
    KeyRule{meta_key::plane, Kind::plane, 0, 0, false, 0, "XY, YZ or ZX"},
    KeyRule{meta_key::units, Kind::length_unit, 0, 0, false, 0, "mm or inch"},
    KeyRule{meta_key::rows, Kind::count, 0, 0, false, 0, "a row count (an integer >= 0)"},
    KeyRule{meta_key::runs, Kind::count, 0, 0, false, 0, "a run count (an integer >= 0)"},
    KeyRule{meta_key::overruns, Kind::count, 0, 0, false, 0, "a count (an integer >= 0)"},
    KeyRule{meta_key::gaps, Kind::count, 0, 0, false, 0, "a count (an integer >= 0)"},
    KeyRule{meta_key::lost_samples, Kind::count, 0, 0, false, 0, "a count (an integer >= 0)"},
};

bool in_range(const KeyRule& r, double v) {
  if (!std::isfinite(v) || v > r.max) return false;
  return r.positive ? v > r.min : v >= r.min;
}

bool valid(const KeyRule& r, std::string_view value) {
  switch (r.kind) {
    case Kind::number: {
      const auto v = parse_finite(value);
      return v && in_range(r, *v);
    }
    case Kind::list: {
      std::size_t n = 0;
      std::size_t pos = 0;
      while (true) {
        const auto comma = value.find(',', pos);
        const auto v = parse_finite(value.substr(pos, comma - pos));
        if (!v || !in_range(r, *v)) return false;
        ++n;
        if (comma == std::string_view::npos) break;
        pos = comma + 1;
      }
      return r.items == 0 || n == r.items;
    }
    case Kind::count: {
      const auto v = parse_finite(value);
      return v && *v >= 0 && *v <= 9.007199254740992e15 && std::floor(*v) == *v;
    }
    case Kind::plane:
      return parse_plane_list(value).has_value();
    case Kind::length_unit:
      return value == "mm" || value == "inch";
  }
  return false;
}

std::string shown(std::string_view s) {
  if (s.size() > 40) return std::string(s.substr(0, 37)) + "...";
  return std::string(s);
}

}  // namespace

void check_metadata(const TraceMetadata& metadata, const std::string& source) {
  const auto& entries = metadata.entries();
  // Each entry, not only the last of a key: a bad header value overridden by the trailer
  // still says the file is damaged.
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const auto& [key, value] = entries[i];
    for (const KeyRule& r : kRules) {
      if (key != r.key) continue;
      if (!valid(r, value)) {
        throw ParseError(
            source, metadata.line_at(i),
            fmt::format("metadata '{}': expected {}, got '{}'", key, r.expected, shown(value)));
      }
      break;
    }
  }
}

}  // namespace circtest
