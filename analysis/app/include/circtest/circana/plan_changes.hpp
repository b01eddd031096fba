#pragma once
// What circcomp changed between a before and an after test, read from the plans of its apply
// rounds (circcomp plan --json: circtest.plan/1) and netted for the report's page 1: one line
// per item in words a customer reads, from its value before the first round to its value
// after the last.
#include <optional>
#include <string>
#include <vector>

namespace circtest {

// One item a plan changes: an INI key, a compensation table, a gain in a HAL file, a file.
struct PlanChange {
  std::string item;  // what it changes (file, section, key, HAL line; or its words)
  std::string file, section, key;
  std::optional<std::string> before, after;  // before the first round, after the last
  std::string first_words, words;            // circcomp's words of the first and last round
  bool wiring = false;                       // makes LinuxCNC use a setting (a HAL file, ...)
};

// Adds the effective changes of the plan at PATH to CHANGES, a later round's change of an
// item already there merged into it; ADVICE becomes this plan's advice. ParseError naming the
// file and key for anything but a circtest.plan/1 document whose changes have words.
void read_plan_changes(const std::string& path, std::vector<PlanChange>& changes,
                       std::vector<std::string>& advice);

struct NetChanges {
  std::vector<std::string> settings;  // one line per item, in the order first changed
  std::vector<std::string> wiring;
};
// The net lines: an INI key whose rounds undid each other is left out; a compensation table
// once, from its first values to its final ones; an axis' friction compensator
// ([FRICTION_<axis>]) as one line of its pulse height and timing.
NetChanges net_changes(const std::vector<PlanChange>& changes);

}  // namespace circtest
