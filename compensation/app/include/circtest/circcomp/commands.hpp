#pragma once
// circcomp's commands as calls: compensation/app/main.cpp parses the options into a
// CirccompRequest and runs it here; the planner and apply are circtest::compensation.
#include <string>

#include "circtest/compensation/plan.hpp"

namespace circtest::compensation {

enum class CirccompCommand { plan, apply, revert };

struct CirccompRequest {
  CirccompCommand command = CirccompCommand::plan;
  std::string ini;
  std::string diagnosis;     // plan, apply: the diagnosis JSON (a test set's too)
  PlanOptions plan_options;  // plan, apply (its setting_words: the front end's)
  bool json = false;         // plan: circtest.plan/1 instead of the diff
  RevertOptions revert;      // revert
  PlanSettingWords words = library_setting_words;  // the front end's words for a setting
  StepHook after_step;  // apply, revert: called after every step (the crash test's)
};

// Runs the request, writing its report to standard output. The exit code; throws Error (its
// code) for a refusal. apply and revert write what they will change before they start (exit 3,
// nothing changed, when standard output fails then), and Error with ExitCode::unreported when
// standard output fails only after the commit.
int run_circcomp(const CirccompRequest& request);

}  // namespace circtest::compensation
