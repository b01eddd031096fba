#pragma once
// ISO 230-4 Annex C: the feed that keeps the axis acceleration of a reference test when the
// diameter changes, V1 = V2 * sqrt(D1 / D2).
#include "circtest/gcode/generator.hpp"

namespace circtest {

// Throws UsageError unless all three are positive and finite (naming the one in `words`).
double annex_c_feed(double test_diameter, double reference_diameter, double reference_feed,
                    SpecWords words = library_spec_words);

// The Annex C feed rounded as it is programmed: whole mm/min, or 0.1 inch/min.
AnnexCNote annex_c_note(double test_diameter, double reference_diameter, double reference_feed,
                        LengthUnit units, SpecWords words = library_spec_words);

}  // namespace circtest
