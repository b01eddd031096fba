// circcomp's commands: plan (the diff or circtest.plan/1), apply (what it will change, the
// commit, the undo line) and revert, with standard output's contract around the commit.
#include "circtest/circcomp/commands.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

#include "circtest/compensation/diagnosis_input.hpp"
#include "circtest/compensation/plan_json.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/json_text.hpp"

namespace circtest::compensation {

namespace {

void print_summary(const Plan& plan, std::ostream& out) {
  for (const auto& c : plan.changes) out << "# change: " << c << "\n";
  for (const auto& n : plan.notes) out << "# note: " << n << "\n";
  for (const auto& a : plan.advice) out << "# advice: " << a << "\n";
}

// Writes what is in standard output's buffer; false when it cannot (a full disk, /dev/full, a
// closed pipe), with errno's reason in REASON.
bool flush_stdout(std::string& reason) {
  errno = 0;
  std::cout.flush();
  const bool ok = std::cout.good() && std::fflush(stdout) == 0 && std::ferror(stdout) == 0;
  if (!ok) reason = errno != 0 ? std::strerror(errno) : "write failed";
  return ok;
}

// Before a change is committed: what it will do is on standard output, or nothing happens.
void report_before_commit(const std::string& what) {
  std::string reason;
  if (!flush_stdout(reason)) {
    throw IoError("standard output",
                  fmt::format("write failed ({}): {} not started, nothing changed", reason, what));
  }
}

// After a change is committed: a standard output that fails now is no failure of the change.
// Exit 13 (unreported) and stderr say that the change IS made and how to undo it.
int report_after_commit(const std::string& done, const std::string& undo) {
  std::string reason;
  if (flush_stdout(reason)) return 0;
  throw Error(ExitCode::unreported,
              fmt::format("standard output: write failed ({}) after the {}: the change IS made; {}",
                          reason, done, undo));
}

// The plan; for an apply (CHECKED) also refused as stale when the INI it read is not the one
// measured, or is no longer there when the plan is made: another apply committed between the
// freshness check and the end of the plan, and the plan may mix files read before it with
// files read after (one such plan found "nothing to change" and exited 0). apply_plan checks
// the INI and every file against the plan again under the configuration's lock; an apply
// writes its INI first, so an INI unchanged after the plan means no file read was newer. A plan
// that fails while the INI is changing under it is refused as stale, not as what the torn read
// showed.
Plan plan_for(const std::string& ini, const std::vector<DiagnosisInput>& planes,
              const PlanOptions& options, bool checked) {
  const auto changed = [&] {
    return fmt::format(
        "{} changed while circcomp planned (another circcomp apply?): nothing "
        "changed; measure again, or plan again",
        ini);
  };
  try {
    Plan plan = make_plan(ini, planes, options);
    if (!checked) return plan;
    if (!plan.provenance_checked) throw StaleError(changed());
    try {
      require_fresh(ini, planes.front(), false);  // the INI read again: still the measured one
    } catch (const StaleError&) {
      throw StaleError(changed());
    }
    return plan;
  } catch (const StaleError&) {
    throw;
  } catch (const Error&) {
    if (!checked) throw;
    try {
      require_fresh(ini, planes.front(), false);
    } catch (const StaleError&) {
      throw StaleError(changed());
    }
    throw;
  }
}

int run_revert(const CirccompRequest& request) {
  const std::string& ini = request.ini;
  const RevertOptions& options = request.revert;
  std::cout << "circcomp: reverting " << ini << "\n";
  report_before_commit("the revert");
  const RevertResult r = revert(ini, options, request.after_step);
  if (r.reverted) {
    std::cout << "circcomp: reverted " + ini +
                     (options.as_found ? " to the configuration as found before the first apply\n"
                                       : " to the state before the last apply\n");
  } else {
    std::cout << "circcomp: nothing to revert for " + ini + "\n";
  }
  if (r.earlier_kept) {
    std::cout << "circcomp: earlier applies remain; circcomp revert --to as-found --ini " << ini
              << " goes back to the configuration as it was before the first\n";
  }
  return r.reverted ? report_after_commit("revert",
                                          "circcomp apply of the same diagnosis "
                                          "makes it again")
                    : 0;
}

}  // namespace

int run_circcomp(const CirccompRequest& r) {
  if (r.command == CirccompCommand::revert) return run_revert(r);
  check_plan_options(r.plan_options);  // a usage error before any file is read
  // One plane's diagnosis, or a test set's (one entry per plane). Read through core's
  // InputFile: a named FIFO (or device, folder) is refused unopened, a pipe is given as -.
  const std::vector<DiagnosisInput> planes = read_diagnosis_planes(r.diagnosis);
  if (r.command == CirccompCommand::apply)
    require_fresh(r.ini, planes.front(), r.plan_options.force, r.words);
  const Plan plan = plan_for(r.ini, planes, r.plan_options,
                             r.command == CirccompCommand::apply && !r.plan_options.force);
  if (r.command == CirccompCommand::plan && r.json) {
    // The changes as data (circtest.plan/1) for circana report --changes.
    std::cout << json_text(plan_json(plan), 2) << "\n";
    return 0;
  }
  if (r.command == CirccompCommand::plan) {
    std::cout << unified_diff(plan);
    print_summary(plan, std::cout);
    try {
      require_kins_module(plan, r.words);
    } catch (const HalError& e) {
      std::cout << "# note: apply will refuse (exit 7): " << e.what() << "\n";
    }
    if (!plan.provenance_checked) {
      std::cout << "# note: the diagnosis's ini_sha256 does not match " << r.ini
                << " now: apply will refuse (exit 10) without --force\n";
    }
    return 0;
  }
  if (plan.files.empty()) {
    print_summary(plan, std::cout);
    std::cout << "circcomp: nothing to change in " << r.ini << "\n";
    return 0;
  }
  require_kins_module(plan, r.words);
  // What the apply does is on standard output before it starts; the line after it says it
  // is done (exit 13 when only that line cannot be written: the change is made).
  print_summary(plan, std::cout);
  for (const auto& f : plan.files) {
    std::cout << "circcomp: " << (f.existed ? "changing " : "creating ") << f.path << "\n";
  }
  report_before_commit("the apply");
  apply_plan(plan, r.after_step);
  std::cout << "circcomp: applied; originals kept; undo with: circcomp revert --ini " << r.ini
            << "\n";
  return report_after_commit("apply", "undo it with: circcomp revert --ini " + r.ini);
}

}  // namespace circtest::compensation
