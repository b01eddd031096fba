#pragma once
// `circcomp plan --json`: what a plan changes as data (circtest.plan/1), for `circana report
// --changes`. The changes are read off the plan's files, not off its steps: every INI key that
// differs between a file's text before and after (file, section, key, before, after) and
// every other file created or changed, each with one line in plain words ("X backlash 0 →
// 10.0 µm"), so that a new kind of correction appears without a change here; a gain written
// into a HAL line as a literal (setp, "PIN = VALUE", sets) is a setting with its key, before,
// after, hal_line and hal_command (Plan::hal_values). A change without
// effect (a BACKLASH or squareness written as 0 where there was none) says so ("effective":
// false) so that a reader can leave it out.
#include <nlohmann/json.hpp>

#include "circtest/compensation/plan.hpp"

namespace circtest::compensation {

inline constexpr const char* kPlanSchema = "circtest.plan/1";

nlohmann::ordered_json plan_json(const Plan& plan);

}  // namespace circtest::compensation
