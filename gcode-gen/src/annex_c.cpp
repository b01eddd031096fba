#include "circtest/gcode/annex_c.hpp"

#include <fmt/format.h>

#include <cmath>

#include "circtest/core/error.hpp"
#include "circtest/gcode/plausible_ranges.hpp"

namespace circtest {

double annex_c_feed(double test_diameter, double reference_diameter, double reference_feed,
                    SpecWords words) {
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (!positive(test_diameter)) {
    throw UsageError(fmt::format("{}: the diameter must be positive, got {}",
                                 words(SpecSetting::test_diameter), test_diameter));
  }
  if (!positive(reference_diameter)) {
    throw UsageError(fmt::format("{}: the reference diameter must be positive, got {}",
                                 words(SpecSetting::reference_diameter), reference_diameter));
  }
  if (!positive(reference_feed)) {
    throw UsageError(fmt::format("{}: the reference feed must be positive, got {}",
                                 words(SpecSetting::reference_feed), reference_feed));
  }
  return reference_feed * std::sqrt(test_diameter / reference_diameter);
}

AnnexCNote annex_c_note(double test_diameter, double reference_diameter, double reference_feed,
                        LengthUnit units, SpecWords words) {
  const double mm = units == LengthUnit::inch ? kMmPerInch : 1.0;
  AnnexCNote note;
  note.test_diameter = test_diameter;
  note.reference_diameter = reference_diameter;
  note.reference_feed = reference_feed;
  note.scaled_feed_exact = annex_c_feed(test_diameter, reference_diameter, reference_feed, words);
  check_plausible(plausible::reference_diameter, reference_diameter * mm, units, words);
  check_plausible(plausible::reference_feed, reference_feed * mm, units, words);
  // The standard's own example rounds 559.02 mm/min to 559; inch feeds are small numbers
  // where a whole unit would be a coarse step.
  const double step = units == LengthUnit::mm ? 1.0 : 0.1;
  note.scaled_feed = std::round(note.scaled_feed_exact / step) * step;
  // A feed rounded up to one step would be a different test than the one asked for: refuse.
  const double scaled_mm = note.scaled_feed * mm;
  if (!(scaled_mm >= plausible::feed.min && scaled_mm <= plausible::feed.max)) {
    throw UsageError(fmt::format(
        "{}: the Annex C feed {} * sqrt[{}/{}] = {} {}/min is {} the plausible {:.6g}..{:.6g} "
        "{}/min",
        words(SpecSetting::reference_feed), reference_feed, test_diameter, reference_diameter,
        note.scaled_feed_exact, units == LengthUnit::inch ? "in" : "mm",
        scaled_mm > plausible::feed.max ? "above" : "below", plausible::feed.min / mm,
        plausible::feed.max / mm, units == LengthUnit::inch ? "in" : "mm"));
  }
  return note;
}

}  // namespace circtest
