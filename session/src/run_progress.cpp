// Progress while the program runs: which run, of how many, and how much of its measured arc
// is done. The runs and their arcs are the program's header (circgen's segments, radius,
// arc, units, as circlog-record reads them); a run's start and end are the program's marker
// output as LinuxCNC reports it (the LinuxCNC link's `run` and `run-end` events), and the
// share of the arc is the time since its start against the arc's length at its feed (the
// feed override is held at 100 %).
#include <fmt/format.h>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <ostream>

#include "circtest/core/numbers.hpp"
#include "circtest/core/trace_keys.hpp"
#include "recorder.hpp"
#include "session_steps.hpp"

namespace circtest::session {

namespace {

std::optional<double> header_value(const circlog_record::ProgramPlan& plan,
                                   const std::string& key) {
  for (const auto& [k, v] : plan.header) {
    if (k == key) return parse_finite(v);
  }
  return std::nullopt;
}

}  // namespace

RunProgress::RunProgress(const std::string& program, std::ostream& out, std::FILE* terminal,
                         double now_s)
    : out_(out), line_(terminal, "circtest", terminal != nullptr, now_s) {
  const circlog_record::ProgramPlan plan = circlog_record::read_program_plan(program);
  const std::optional<double> radius_mm = header_value(plan, meta_key::radius_mm);
  bool inch = false;
  for (const auto& [k, v] : plan.header) inch = inch || (k == meta_key::units && v == "inch");
  for (std::size_t i = 0; i < plan.runs.size(); ++i) {
    const circlog_record::AnnouncedRun& r = plan.runs[i];
    Run run;
    run.segment = r.segment_id;
    const std::string plane = r.plane ? std::string(plane_name(*r.plane)) : "";
    std::string label = r.label;  // a test set's says its plane last: it goes first here
    if (const std::string tail = " " + plane; !plane.empty() && label.ends_with(tail)) {
      label.resize(label.size() - tail.size());
    }
    run.what = fmt::format("{}run {} of {} ({})", plane.empty() ? "" : plane + " ", i + 1,
                           plan.runs.size(), label);
    // The measured arc: the plane's own arc_deg_PLANE in a test set, else arc_deg.
    std::optional<double> arc_deg =
        header_value(plan, std::string(meta_key::arc_deg) + "_" + plane);
    if (!arc_deg) arc_deg = header_value(plan, meta_key::arc_deg);
    const double feed_mm_per_s = r.feed_per_min * (inch ? 25.4 : 1.0) / 60.0;
    if (radius_mm && arc_deg && feed_mm_per_s > 0) {
      run.duration_s = *radius_mm * *arc_deg * std::numbers::pi / 180.0 / feed_mm_per_s;
    }
    runs_.push_back(run);
  }
}

const RunProgress::Run* RunProgress::find(int segment) const {
  const auto it = std::find_if(runs_.begin(), runs_.end(),
                               [segment](const Run& r) { return r.segment == segment; });
  return it == runs_.end() ? nullptr : &*it;
}

std::string RunProgress::what(int segment) const {
  const Run* r = find(segment);
  return r ? r->what : fmt::format("run {}", segment);
}

std::optional<int> RunProgress::percent(double now_s) const {
  const Run* r = current_ ? find(*current_) : nullptr;
  if (!r || !(r->duration_s > 0)) return std::nullopt;
  // Below 100 until LinuxCNC reports the arc's end.
  return std::clamp(static_cast<int>(std::floor((now_s - started_s_) / r->duration_s * 100)), 0,
                    99);
}

std::string RunProgress::status(double now_s) const {
  if (!current_) return "";
  const auto p = percent(now_s);
  return what(*current_) + (p ? fmt::format(": {} % of the path", *p) : ": recording");
}

void RunProgress::started(int segment, double now_s) {
  current_ = segment;
  started_s_ = now_s;
  next_step_ = kPlainStep;
  if (!line_.enabled()) out_ << "circtest: " << what(segment) << ": recording\n" << std::flush;
  update(now_s);
}

void RunProgress::ended(double now_s) {
  if (!current_) return;
  line_.clear();
  out_ << fmt::format("circtest: {}: recorded ({:.1f} s)\n", what(*current_), now_s - started_s_)
       << std::flush;
  current_.reset();
}

void RunProgress::update(double now_s) {
  if (!current_) return;
  if (line_.enabled()) {
    line_.update(now_s, status(now_s));
    return;
  }
  // Without a terminal: a plain line at each quarter of the path.
  const auto p = percent(now_s);
  if (p && *p >= next_step_) {
    const int reached = *p / kPlainStep * kPlainStep;
    out_ << "circtest: " << what(*current_) << ": " << reached << " % of the path\n" << std::flush;
    next_step_ = reached + kPlainStep;
  }
}

void RunProgress::clear() {
  line_.clear();
}

}  // namespace circtest::session
