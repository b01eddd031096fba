#pragma once
// What the user can give or do about a refusal or a note. The analysis library names it as a
// Remedy; the front end says how in its own words (circana: its options, in
// analysis/src/commands.cpp), so library text names no command-line option.
#include <string_view>

#include "circtest/core/setting_words.hpp"

namespace circtest {

enum class Remedy {
  give_radius,       // the nominal radius of the test
  give_centre,       // the set-up centre of the test
  f_about_nominal,   // the request: F about the nominal (set-up) centre
  units_inch,        // the positions are in inch
  units_mm,          // the positions are in mm
  give_plane,        // the plane of the test
  evaluate_anyway,   // evaluate inputs that disagree, with a warning
  radius_tolerance,  // how far the fitted radius may be from the nominal one
  give_machine,      // the name of the machine tested (the history is per machine)
};

// The words for a remedy inside a message (core/setting_words.hpp).
using RemedyWords = SettingWords<Remedy>;

// The library's own words, naming the settings of EvaluationOptions and InputCheckOptions in
// plain language ("the nominal radius setting"): what a caller without a front end sees.
std::string_view library_remedy_words(Remedy remedy) noexcept;

}  // namespace circtest
