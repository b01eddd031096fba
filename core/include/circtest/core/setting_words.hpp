#pragma once
// How a library names a setting the user may give, inside its messages. The library knows its
// settings as an enum (analysis: Remedy, circgen: SpecSetting, circcomp: PlanSetting); the
// front end passes a SettingWords that words each as its own (an option, "--radius"), and a
// caller without a front end gets the library's plain words ("the nominal radius setting").
// So library text names no command-line option, and every part does this one way.
#include <string_view>

namespace circtest {

// The words for `setting` inside a message; a plain function, so a default is a constant.
template <class Setting>
using SettingWords = std::string_view (*)(Setting setting);

}  // namespace circtest
