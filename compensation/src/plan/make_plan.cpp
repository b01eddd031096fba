// The planner: the steps run in order over one context (plan/context.hpp), for one plane's
// diagnosis or a test set's; the corrections' names; the INI's freshness check.
#include <fmt/format.h>

#include <array>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "circtest/core/error.hpp"
#include "circtest/core/sha256.hpp"
#include "context.hpp"

namespace circtest::compensation {

using namespace detail;

namespace {

constexpr std::array<std::pair<Correction, std::string_view>, 6> kCorrectionNames{{
    {Correction::backlash, "backlash"},
    {Correction::scale, "scale"},
    {Correction::squareness, "squareness"},
    {Correction::cyclic, "cyclic"},
    {Correction::friction, "friction"},
    {Correction::servo, "servo"},
}};

// The steps of one plane's plan, in order.
constexpr PlanStep kPlaneSteps[] = {
    axes_step,         accept_squareness_step, write_squareness_step, servo_step,
    servo_advice_step, friction_step,          spike_advice_step,     collect_files_step,
};
// Each plane of a test set: its axes (those of no earlier plane), squareness and advice; then
// once for the set every plane's squareness, the notes, and the files.
constexpr PlanStep kSetPlaneSteps[] = {axes_step, accept_squareness_step, servo_advice_step,
                                       spike_advice_step};

}  // namespace

void check_plan_options(const PlanOptions& o) {
  if (!(o.gain > 0.0 && o.gain <= 1.0)) {
    throw UsageError(fmt::format("{}: expected 0 < F <= 1", o.setting_words(PlanSetting::gain)));
  }
}

std::string_view correction_name(Correction c) noexcept {
  for (const auto& [correction, name] : kCorrectionNames) {
    if (correction == c) return name;
  }
  return "correction";
}

std::optional<Correction> correction_named(std::string_view name) noexcept {
  for (const auto& [correction, n] : kCorrectionNames) {
    if (n == name) return correction;
  }
  return std::nullopt;
}

std::vector<Correction> all_corrections() {
  std::vector<Correction> out;
  for (const auto& entry : kCorrectionNames) out.push_back(entry.first);
  return out;
}

std::string_view library_setting_words(PlanSetting setting) noexcept {
  switch (setting) {
    case PlanSetting::force:
      return "the force setting";
    case PlanSetting::gain:
      return "the gain setting";
    case PlanSetting::record_with_ini:
      return "with circtest-run, or with circlog-record given the INI";
    case PlanSetting::without_squareness:
      return "leave squareness out of the corrections";
    case PlanSetting::without_friction:
      return "leave friction out of the corrections";
  }
  return "a setting";
}

void require_fresh(const std::string& ini_path, const DiagnosisInput& diagnosis, bool force,
                   PlanSettingWords words) {
  if (force) return;
  if (!diagnosis.diagnosis.ini_sha256) {
    throw StaleError(
        fmt::format("{}: has no ini_sha256, so nothing shows it measured {} as it is now; record "
                    "{}, or {}",
                    diagnosis.source, ini_path, words(PlanSetting::record_with_ini),
                    words(PlanSetting::force)));
  }
  const std::string now = sha256_hex(ini_text(ini_path));
  if (*diagnosis.diagnosis.ini_sha256 != now) {
    throw StaleError(fmt::format(
        "{} changed since the measurement of {} (SHA-256 {} then, {} now): a correction "
        "applied twice doubles; measure again, or {}",
        ini_path, diagnosis.source, diagnosis.diagnosis.ini_sha256->substr(0, 12),
        now.substr(0, 12), words(PlanSetting::force)));
  }
}

PlanContext::PlanContext(const std::string& path, const DiagnosisInput& d,
                         const PlanOptions& options)
    : ini_path(path),
      diagnosis(&d),
      o(options),
      ini(IniDocument::load(path)),
      config(path),
      upm(units_per_mm(ini)),
      dir(ini_dir(path)) {
  plan.ini_path = path;
}

PlanContext PlanContext::trial() const {
  PlanContext t(*this);
  t.plan = Plan{};
  t.plan.ini_path = ini_path;
  return t;
}

void PlanContext::merge(PlanContext&& tried) {
  ini = std::move(tried.ini);
  for (auto& [path, file] : tried.files) files[path] = std::move(file);
  const auto append = [](std::vector<std::string>& to, std::vector<std::string>& from) {
    to.insert(to.end(), std::make_move_iterator(from.begin()), std::make_move_iterator(from.end()));
  };
  append(plan.changes, tried.plan.changes);
  append(plan.advice, tried.plan.advice);
  append(plan.notes, tried.plan.notes);
  plan.hal_values.insert(plan.hal_values.end(), tried.plan.hal_values.begin(),
                         tried.plan.hal_values.end());
  plan.needs_kins_module = plan.needs_kins_module || tried.plan.needs_kins_module;
  plan.needs_fric_module = plan.needs_fric_module || tried.plan.needs_fric_module;
}

// Every file whose content changes: the INI and its includes, then the tables and HAL files.
void collect_files_step(PlanContext& c) {
  auto add = [&](const std::string& path, std::string after) {
    FileChange f;
    f.path = path;
    f.name = target_name(c.config, path);
    for (const FileChange& other : c.plan.files) {
      if (other.name == f.name) {
        throw DataError(c.ini_path, 0,
                        fmt::format("{} and {} are the same file ({}): name it one way", other.path,
                                    path, c.config.path(f.name)));
      }
    }
    f.before = slurp_if(path, f.existed);
    f.after = std::move(after);
    if (f.before != f.after) c.plan.files.push_back(std::move(f));
  };
  for (std::size_t i = 0; i < c.ini.file_count(); ++i) {
    if (c.ini.file_modified(i)) add(c.ini.file_path(i), c.ini.render_file(i));
  }
  for (const auto& [path, t] : c.files) add(path, t.second);
}

Plan make_plan(const std::string& ini_path, const DiagnosisInput& d, const PlanOptions& o) {
  check_plan_options(o);
  PlanContext c(ini_path, d, o);
  c.plan.ini_sha256 = sha256_hex(ini_text(ini_path));
  c.plan.provenance_checked =
      d.diagnosis.ini_sha256 && *d.diagnosis.ini_sha256 == c.plan.ini_sha256;
  for (const PlanStep step : kPlaneSteps) step(c);
  return std::move(c.plan);
}

Plan make_plan(const std::string& ini_path, const std::vector<DiagnosisInput>& planes,
               const PlanOptions& o) {
  if (planes.size() == 1) return make_plan(ini_path, planes.front(), o);
  if (planes.empty()) throw DataError(ini_path, 0, "no plane's diagnosis to plan from");
  check_plan_options(o);
  for (const auto& [requested, what] :
       {std::pair{o.friction_requested, "friction"}, std::pair{o.servo_requested, "servo"}}) {
    if (requested && o.only.size() == 1) {
      throw UsageError(
          fmt::format("{}: {} is planned from one plane's diagnosis, not from a test set (circana "
                      "diagnose --plane P --json)",
                      planes.front().source, what));
    }
  }
  const DiagnosisInput& first = planes.front();
  PlanContext c(ini_path, first, o);
  c.plan.ini_sha256 = sha256_hex(ini_text(ini_path));
  c.plan.provenance_checked =
      first.diagnosis.ini_sha256 && *first.diagnosis.ini_sha256 == c.plan.ini_sha256;
  for (const DiagnosisInput& d : planes) {
    c.diagnosis = &d;
    for (const PlanStep step : kSetPlaneSteps) step(c);
  }
  c.diagnosis = &first;
  write_squareness_step(c);
  if (c.wants(Correction::friction)) {
    c.plan.notes.push_back(
        "friction compensation is not planned from a test set: plan it from one plane's "
        "diagnosis (circana diagnose --plane P --json)");
  }
  if (c.wants(Correction::servo)) {
    // FF1 and P are matched to a common lag of the joints a plan changes together; the planes
    // of a set each measured two axes at their own feed, so one axis's lag comes from up to
    // two planes and a common target over three axes from none.
    c.plan.notes.push_back(
        "servo gains are not planned from a test set: its planes measured each axis's lag in "
        "different circles; plan them from one plane's diagnosis (circana diagnose --plane P "
        "--json)");
  }
  collect_files_step(c);
  return std::move(c.plan);
}

}  // namespace circtest::compensation
