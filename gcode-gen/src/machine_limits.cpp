#include "circtest/gcode/machine_limits.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <limits>
#include <sstream>

#include <sys/stat.h>

#include "circtest/core/angles.hpp"
#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/ini.hpp"
#include "circtest/core/input_file.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/strings.hpp"

namespace circtest {

namespace {

std::string upper_text(std::string text) {
  for (char& c : text) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return text;
}

std::optional<double> ini_number(const IniDocument& ini, const char* section, const char* key) {
  const auto entry = ini.find(section, key);
  if (!entry || entry->value.empty()) return std::nullopt;
  const auto number = parse_finite(entry->value);
  if (!number) {
    throw ParseError(entry->file, entry->line,
                     fmt::format("[{}] {}: '{}' is not a number", section, key, entry->value));
  }
  return *number;
}

// A velocity or acceleration: zero or negative is not a limit but a broken configuration,
// and would turn every check (and the lead run-up it sizes) into a division by it.
std::optional<double> ini_positive(const IniDocument& ini, const char* section, const char* key) {
  const auto number = ini_number(ini, section, key);
  if (number && !(*number > 0.0)) {
    const auto entry = ini.find(section, key);
    throw ParseError(
        entry->file, entry->line,
        fmt::format("[{}] {}: expected a positive number, got '{}'", section, key, entry->value));
  }
  return number;
}

// The range of a numeric LINEAR_UNITS (machine units per mm): from metres (0.001) to
// micrometres (1000) with a decade to spare on each side.
constexpr double kMinUnitsPerMm = 1e-4;
constexpr double kMaxUnitsPerMm = 1e4;

// [TRAJ] LINEAR_UNITS as LinuxCNC 2.9 reads it (emcIniFile linearUnitsMap): machine units per
// mm as a number, or a name, case-insensitive.
double mm_per_unit(const IniDocument& ini) {
  const auto entry = ini.find("TRAJ", "LINEAR_UNITS");
  if (!entry || entry->value.empty()) return 1.0;
  if (const auto units_per_mm = parse_finite(entry->value)) {
    if (!(*units_per_mm >= kMinUnitsPerMm && *units_per_mm <= kMaxUnitsPerMm)) {
      throw ParseError(entry->file, entry->line,
                       fmt::format("[TRAJ] LINEAR_UNITS: expected a positive number of units "
                                   "per mm, {}..{}, got '{}'",
                                   kMinUnitsPerMm, kMaxUnitsPerMm, entry->value));
    }
    return 1.0 / *units_per_mm;
  }
  const std::string v = upper_text(entry->value);
  if (v == "MM" || v == "METRIC") return 1.0;
  if (v == "INCH" || v == "IMPERIAL" || v == "IN") return kMmPerInch;
  throw ParseError(entry->file, entry->line,
                   fmt::format("[TRAJ] LINEAR_UNITS: unknown unit '{}' (expected mm, metric, "
                               "in, inch, imperial or units per mm)",
                               entry->value));
}

// The axis letters the machine has: [TRAJ] COORDINATES, else the kinematics' coordinates=;
// empty when neither says.
std::string coordinate_letters(const IniDocument& ini) {
  std::string letters;
  if (const auto coordinates = ini.get("TRAJ", "COORDINATES")) {
    letters = *coordinates;
  } else if (const auto kins = ini.get("KINS", "KINEMATICS")) {
    const auto at = kins->find("coordinates=");
    if (at != std::string::npos) letters = kins->substr(at + 12, kins->find(' ', at) - at - 12);
  }
  std::string out;
  for (char c : letters) {
    if (std::isalpha(static_cast<unsigned char>(c))) out += static_cast<char>(std::toupper(c));
  }
  return out;
}

// [RS274NGC] DISABLE_G92_PERSISTENCE: LinuxCNC 2.9 reads it with boost::lexical_cast<bool>,
// which takes 0 and 1 only and leaves any other value at false (G92 kept); later versions
// take yes/true/on as true. A value other than 0 or 1 means different things to them.
G92Persistence g92_persistence(const IniDocument& ini) {
  const auto entry = ini.find("RS274NGC", "DISABLE_G92_PERSISTENCE");
  if (!entry || entry->value == "0") return G92Persistence::kept;
  if (entry->value == "1") return G92Persistence::cleared;
  throw ParseError(entry->file, entry->line,
                   fmt::format("[RS274NGC] DISABLE_G92_PERSISTENCE = {}: expected 0 or 1 (LinuxCNC "
                               "2.9 takes any other value as 0, later versions yes/true/on as 1)",
                               entry->value));
}

// An input file that exists must be a regular one: a FIFO would be waited on for ever.
void require_regular(const std::string& path, std::string_view what) {
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
    throw IoError(path,
                  fmt::format("is {}, expected a regular {}", file_kind_name(st.st_mode), what));
  }
}

}  // namespace

MachineLimits machine_limits_from(const IniDocument& ini) {
  MachineLimits limits;
  limits.source = ini.path();
  limits.mm_per_machine_unit = mm_per_unit(ini);
  const double unit = limits.mm_per_machine_unit;
  auto length = [unit](std::optional<double> v) {
    return v ? std::optional<double>(*v * unit) : std::nullopt;
  };
  limits.max_linear_velocity_mm_per_s = length(ini_positive(ini, "TRAJ", "MAX_LINEAR_VELOCITY"));
  limits.max_linear_acceleration_mm_per_s2 =
      length(ini_positive(ini, "TRAJ", "MAX_LINEAR_ACCELERATION"));
  const std::string letters = coordinate_letters(ini);
  for (int i = 0; i < 3; ++i) {
    AxisLimits& axis = limits.axes[i];
    axis.axis = static_cast<char>('x' + i);
    const char letter = static_cast<char>('X' + i);
    const std::string section = fmt::format("AXIS_{}", letter);
    const bool has_section = ini.has_section(section);
    axis.present = has_section || letters.find(letter) != std::string::npos;
    if (!axis.present) continue;
    axis.min_limit_mm = length(ini_number(ini, section.c_str(), "MIN_LIMIT"));
    axis.max_limit_mm = length(ini_number(ini, section.c_str(), "MAX_LIMIT"));
    if (axis.min_limit_mm && axis.max_limit_mm && *axis.min_limit_mm > *axis.max_limit_mm) {
      const auto entry = ini.find(section.c_str(), "MIN_LIMIT");
      throw ParseError(entry->file, entry->line,
                       fmt::format("[{}] MIN_LIMIT = {} is above MAX_LIMIT = {}", section,
                                   entry->value, ini.find(section.c_str(), "MAX_LIMIT")->value));
    }
    axis.max_velocity_mm_per_s = length(ini_positive(ini, section.c_str(), "MAX_VELOCITY"));
    axis.max_acceleration_mm_per_s2 =
        length(ini_positive(ini, section.c_str(), "MAX_ACCELERATION"));
    // LinuxCNC 2.9 (iniaxis.cc, emccfg.h) gives an axis without these keys 1 unit/s and
    // 1 unit/s^2, and limits of +-1e99: a real machine limit, checked as such.
    if (!axis.max_velocity_mm_per_s) axis.max_velocity_mm_per_s = unit * 1.0;
    if (!axis.max_acceleration_mm_per_s2) axis.max_acceleration_mm_per_s2 = unit * 1.0;
  }
  for (const auto& entry : ini.get_all("HAL", "HALFILE")) limits.hal_files.push_back(entry.value);
  limits.g92_persistence = g92_persistence(ini);
  for (const std::string& section : ini.sections()) {
    for (const auto& entry : ini.entries(section)) {
      limits.values.emplace(upper_text(section) + "/" + upper_text(entry.key), entry.value);
    }
  }
  return limits;
}

std::optional<MotionOutputs> find_motion_outputs(const std::string& hal_text,
                                                 const std::string& source,
                                                 const MachineLimits& ini) {
  // "[SECTION]KEY" is replaced by the INI value, as halcmd does with -i.
  auto substitute = [&ini](const std::string& word) {
    if (word.size() < 3 || word[0] != '[') return word;
    const auto close = word.find(']');
    if (close == std::string::npos) return word;
    const auto it =
        ini.values.find(upper_text(word.substr(1, close - 1)) + "/" + word.substr(close + 1));
    return it == ini.values.end() ? word : it->second;
  };
  const auto emcmot = ini.values.find("EMCMOT/EMCMOT");
  const std::string module = emcmot == ini.values.end() ? "motmod" : emcmot->second;
  std::size_t line_no = 0, begin = 0;
  std::string logical;
  std::size_t logical_line = 0;
  while (begin <= hal_text.size()) {
    std::size_t end = hal_text.find('\n', begin);
    if (end == std::string::npos) end = hal_text.size();
    std::string line = hal_text.substr(begin, end - begin);
    begin = end + 1;
    ++line_no;
    if (const auto hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    line = std::string(trim(line));
    if (logical.empty()) logical_line = line_no;
    if (!line.empty() && line.back() == '\\') {
      line.pop_back();
      logical += line + ' ';
      if (begin <= hal_text.size()) continue;
    } else {
      logical += line;
    }
    std::vector<std::string> words;
    std::size_t pos = 0;
    while (pos < logical.size()) {
      const auto start = logical.find_first_not_of(" \t\r", pos);
      if (start == std::string::npos) break;
      const auto stop = logical.find_first_of(" \t\r", start);
      words.push_back(logical.substr(start, stop == std::string::npos ? stop : stop - start));
      pos = stop == std::string::npos ? logical.size() : stop;
    }
    logical.clear();
    if (words.size() < 2 || words[0] != "loadrt") continue;
    const std::string loaded = substitute(words[1]);
    if (loaded != module && loaded != "motmod") continue;
    MotionOutputs outputs;
    outputs.where = fmt::format("{}:{}", source, logical_line);
    for (std::size_t i = 2; i < words.size(); ++i) {
      const auto eq = words[i].find('=');
      if (eq == std::string::npos) continue;
      const std::string name = words[i].substr(0, eq);
      if (name != "num_dio" && name != "num_aio") continue;
      const std::string value = substitute(words[i].substr(eq + 1));
      int count = -1;
      const auto [ptr, ec] = std::from_chars(value.data(), value.data() + value.size(), count);
      if (ec != std::errc() || ptr != value.data() + value.size() || count < 0) {
        throw ParseError(
            source, logical_line,
            fmt::format("loadrt {}: {}='{}' is not a whole number", loaded, name, value));
      }
      (name == "num_dio" ? outputs.num_dio : outputs.num_aio) = count;
    }
    return outputs;
  }
  return std::nullopt;
}

MachineLimits parse_machine_limits(const std::string& text, const std::string& source) {
  return machine_limits_from(IniDocument::parse(text, source));
}

MachineLimits read_machine_limits(const std::string& path) {
  require_regular(path, "INI file");
  MachineLimits limits = machine_limits_from(IniDocument::load(path));
  {
    const auto it = limits.values.find("RS274NGC/PARAMETER_FILE");
    const std::string name =
        it == limits.values.end() || it->second.empty() ? "rs274ngc.var" : it->second;
    const std::filesystem::path file(name);
    limits.parameter_file =
        file.is_absolute() ? name : (std::filesystem::path(path).parent_path() / file).string();
  }
  // HAL files are found beside the INI (LinuxCNC runs halcmd in the configuration's
  // folder), LIB: ones in the installed HAL library. A file that is not there (or a .tcl
  // one) is not checked: the output check then says nothing rather than guess.
  const std::filesystem::path dir = std::filesystem::path(path).parent_path();
  for (const std::string& name : limits.hal_files) {
    std::filesystem::path file;
    if (name.starts_with("LIB:")) {
      file = std::filesystem::path("/usr/share/linuxcnc/hallib") / name.substr(4);
    } else {
      file = std::filesystem::path(name).is_absolute() ? std::filesystem::path(name) : dir / name;
    }
    if (file.extension() != ".hal" || !std::filesystem::exists(file)) continue;
    require_regular(file.string(), "HAL file");
    if (auto outputs = find_motion_outputs(read_file(file.string()), file.string(), limits)) {
      limits.motion_outputs = std::move(outputs);
      break;
    }
  }
  return limits;
}

namespace {

// A feed and a radius as the user gave them: in the program's units.
std::string user_feed(const CircleTestSpec& spec, double mm_per_min) {
  const bool inch = spec.units == LengthUnit::inch;
  return fmt::format("{:.10g} {}/min", inch ? mm_per_min / kMmPerInch : mm_per_min,
                     inch ? "in" : "mm");
}
// "F1200 on R0.5 mm", "F20 on R2 in".
std::string user_arc(const CircleTestSpec& spec, double feed_mm_per_min) {
  const bool inch = spec.units == LengthUnit::inch;
  const double per = inch ? kMmPerInch : 1.0;
  return fmt::format("F{:.10g} on R{:.10g} {}", feed_mm_per_min / per, spec.radius_mm / per,
                     inch ? "in" : "mm");
}

std::string axis_section(char axis) {
  return fmt::format("[AXIS_{}]", static_cast<char>(std::toupper(axis)));
}

// The machine must have every axis the test moves.
void check_axes_present(const CircleTestSpec& spec, const MachineLimits& limits) {
  const PlaneAxes axes = plane_axes(spec.plane);
  for (char axis : {axes.first, axes.second, axes.normal}) {
    if (!limits.axes[axis - 'x'].present) {
      throw ParseError(limits.source, 0,
                       fmt::format("the machine has no {} axis (not in [TRAJ] COORDINATES, "
                                   "no {} section): cannot run the test there",
                                   static_cast<char>(std::toupper(axis)), axis_section(axis)));
    }
  }
}

// Extent of every position the program visits, per axis, in work coordinates (mm).
std::pair<std::array<double, 3>, std::array<double, 3>> path_extent_mm(const CircleTestSpec& spec) {
  const PlaneAxes axes = plane_axes(spec.plane);
  std::array<double, 3> low = spec.centre_mm;
  std::array<double, 3> high = spec.centre_mm;
  const auto [from_deg, to_deg] = swept_range_deg(spec);
  std::vector<double> angles{from_deg, to_deg};
  if (to_deg - from_deg >= 360.0) {
    for (int q = 0; q < 4; ++q) angles.push_back(90.0 * q);
  } else {
    for (double q = std::ceil(from_deg / 90.0) * 90.0; q <= to_deg; q += 90.0) {
      angles.push_back(q);
    }
  }
  const int a = axes.first - 'x';
  const int b = axes.second - 'x';
  // The tool never visits the centre of the circle, only the normal axis stays there.
  low[a] = low[b] = std::numeric_limits<double>::infinity();
  high[a] = high[b] = -std::numeric_limits<double>::infinity();
  // A ballbar's feed-in starts outside the circle.
  const double reach_mm =
      spec.radius_mm + (spec.instrument == Instrument::ballbar ? spec.feed_in_mm : 0.0);
  for (double deg : angles) {
    const double pa = spec.centre_mm[a] + reach_mm * std::cos(deg_to_rad(deg));
    const double pb = spec.centre_mm[b] + reach_mm * std::sin(deg_to_rad(deg));
    low[a] = std::min(low[a], pa), high[a] = std::max(high[a], pa);
    low[b] = std::min(low[b], pb), high[b] = std::max(high[b], pb);
  }
  if (spec.safe_mm) {
    const int n = axes.normal - 'x';
    low[n] = std::min(low[n], *spec.safe_mm), high[n] = std::max(high[n], *spec.safe_mm);
  }
  return {low, high};
}

void check_soft_limits(const CircleTestSpec& spec, const MachineLimits& limits,
                       const std::array<double, 3>& work_offset_mm) {
  const double unit = limits.mm_per_machine_unit;
  const char* unit_name = unit == 1.0 ? "mm" : "inch";
  const auto [low, high] = path_extent_mm(spec);
  for (int i = 0; i < 3; ++i) {
    const AxisLimits& axis = limits.axes[i];
    const char letter = static_cast<char>('X' + i);
    const double machine_low = low[i] + work_offset_mm[i];
    const double machine_high = high[i] + work_offset_mm[i];
    // A micrometre of slack so that a circle touching a limit exactly is not refused.
    constexpr double kSlackMm = 1e-6;
    if (axis.min_limit_mm && machine_low < *axis.min_limit_mm - kSlackMm) {
      throw LimitError(fmt::format(
          "{}: the test reaches {} = {:.10g} {} in machine coordinates, below {} MIN_LIMIT = {}",
          limits.source, letter, machine_low / unit, unit_name, axis_section(axis.axis),
          *axis.min_limit_mm / unit));
    }
    if (axis.max_limit_mm && machine_high > *axis.max_limit_mm + kSlackMm) {
      throw LimitError(fmt::format(
          "{}: the test reaches {} = {:.10g} {} in machine coordinates, above {} MAX_LIMIT = {}",
          limits.source, letter, machine_high / unit, unit_name, axis_section(axis.axis),
          *axis.max_limit_mm / unit));
    }
  }
}

void check_velocity(const CircleTestSpec& spec, const MachineLimits& limits) {
  const double unit = limits.mm_per_machine_unit;
  const char* unit_name = unit == 1.0 ? "mm" : "inch";
  const PlaneAxes axes = plane_axes(spec.plane);
  const double max_feed =
      *std::max_element(spec.feeds_mm_per_min.begin(), spec.feeds_mm_per_min.end());
  const double v_mm_per_s = max_feed / 60.0;
  // On a circle each axis of the plane reaches the full path speed and the full centripetal
  // acceleration somewhere, so the per-axis limits apply to the path values directly.
  for (char a : {axes.first, axes.second}) {
    const AxisLimits& axis = limits.axes[a - 'x'];
    if (axis.max_velocity_mm_per_s && v_mm_per_s > *axis.max_velocity_mm_per_s) {
      throw LimitError(fmt::format("{}: feed {} = {:.4g} {}/s exceeds {} MAX_VELOCITY = {}",
                                   limits.source, user_feed(spec, max_feed), v_mm_per_s / unit,
                                   unit_name, axis_section(a), *axis.max_velocity_mm_per_s / unit));
    }
  }
  if (limits.max_linear_velocity_mm_per_s && v_mm_per_s > *limits.max_linear_velocity_mm_per_s) {
    throw LimitError(
        fmt::format("{}: feed {} = {:.4g} {}/s exceeds [TRAJ] MAX_LINEAR_VELOCITY = {}",
                    limits.source, user_feed(spec, max_feed), v_mm_per_s / unit, unit_name,
                    *limits.max_linear_velocity_mm_per_s / unit));
  }
}

// The arc's centripetal acceleration and the lead-in's run-up against the lowest
// acceleration limit of the plane; false when no limit applies.
bool check_acceleration(const CircleTestSpec& spec, const MachineLimits& limits, SpecWords words) {
  const double unit = limits.mm_per_machine_unit;
  const char* unit_name = unit == 1.0 ? "mm" : "inch";
  const PlaneAxes axes = plane_axes(spec.plane);
  const double max_feed =
      *std::max_element(spec.feeds_mm_per_min.begin(), spec.feeds_mm_per_min.end());
  const double v_mm_per_s = max_feed / 60.0;
  const double centripetal = v_mm_per_s * v_mm_per_s / spec.radius_mm;
  // LinuxCNC 2.9's planner (blendmath.c, pmCircleActualMaxVel) keeps sqrt(1 - 0.5^2) of the
  // acceleration for the normal component on an arc and silently slows the arc down beyond
  // it: the measured arc would then not run at the programmed feed.
  const double normal_share = std::sqrt(1.0 - 0.25);
  const double tangential_share = 0.5;
  double a_max = std::numeric_limits<double>::infinity();
  std::string a_name;
  for (char a : {axes.first, axes.second}) {
    const AxisLimits& axis = limits.axes[a - 'x'];
    if (axis.max_acceleration_mm_per_s2 && *axis.max_acceleration_mm_per_s2 < a_max) {
      a_max = *axis.max_acceleration_mm_per_s2;
      a_name = fmt::format("{} MAX_ACCELERATION", axis_section(a));
    }
  }
  if (limits.max_linear_acceleration_mm_per_s2 &&
      *limits.max_linear_acceleration_mm_per_s2 < a_max) {
    a_max = *limits.max_linear_acceleration_mm_per_s2;
    a_name = "[TRAJ] MAX_LINEAR_ACCELERATION";
  }
  if (!std::isfinite(a_max)) return false;
  if (centripetal > a_max) {
    throw LimitError(fmt::format(
        "{}: centripetal acceleration V^2/R = {:.4g} {}/s^2 at {} exceeds {} = {}", limits.source,
        centripetal / unit, unit_name, user_arc(spec, max_feed), a_name, a_max / unit));
  }
  if (centripetal > normal_share * a_max) {
    throw LimitError(fmt::format(
        "{}: centripetal acceleration V^2/R = {:.4g} {}/s^2 at {} is above the "
        "{:.4g} {}/s^2 [0.866 * {} = {}] that LinuxCNC's planner allows on an arc; it would "
        "slow the arc below the feed",
        limits.source, centripetal / unit, unit_name, user_arc(spec, max_feed),
        normal_share * a_max / unit, unit_name, a_name, a_max / unit));
  }
  // The run-up from rest on the lead-in arc, with the tangential acceleration the planner
  // leaves on an arc of this curvature.
  const double tangential =
      a_max * std::max(tangential_share, std::sqrt(1.0 - std::pow(centripetal / a_max, 2)));
  const double run_up_mm = v_mm_per_s * v_mm_per_s / (2.0 * tangential);
  const double lead_mm = spec.radius_mm * deg_to_rad(spec.lead_deg);
  const bool inch = spec.units == LengthUnit::inch;
  const double user_unit = inch ? kMmPerInch : 1.0;
  const char* user_unit_name = inch ? "in" : "mm";
  const int digits = inch ? 4 : 3;
  if (run_up_mm > lead_mm) {
    const double needed_deg = rad_to_deg(run_up_mm / spec.radius_mm);
    throw LimitError(fmt::format(
        "{}: the {} deg lead-in [{:.{}f} {}] is shorter than the {:.{}f} {} needed to reach "
        "{} with {} = {}; use {} {:.0f} or more",
        limits.source, spec.lead_deg, lead_mm / user_unit, digits, user_unit_name,
        run_up_mm / user_unit, digits, user_unit_name, user_feed(spec, max_feed), a_name,
        a_max / unit, words(SpecSetting::lead), std::ceil(needed_deg)));
  }
  return true;
}

void check_motion_outputs(const CircleTestSpec& spec, const MachineLimits& limits,
                          SpecWords words) {
  const MotionOutputs& m = *limits.motion_outputs;
  if (spec.marker_output >= m.num_dio) {
    throw LimitError(
        fmt::format("{}: {} {}: the motion module loaded at {} has num_dio={} (M62/M63 P0..P{}); "
                    "raise num_dio there or use another output",
                    limits.source, words(SpecSetting::marker), spec.marker_output, m.where,
                    m.num_dio, m.num_dio - 1));
  }
  if (spec.segment_output >= m.num_aio) {
    throw LimitError(
        fmt::format("{}: {} {}: the motion module loaded at {} has num_aio={} (M67 E0..E{}); "
                    "raise num_aio there or use another output",
                    limits.source, words(SpecSetting::segment_out), spec.segment_output, m.where,
                    m.num_aio, m.num_aio - 1));
  }
}

}  // namespace

std::vector<std::string> check_against_machine(const CircleTestSpec& spec,
                                               const MachineLimits& limits,
                                               const std::array<double, 3>& work_offset_mm,
                                               SpecWords words) {
  validate(spec, words);
  check_axes_present(spec, limits);
  check_soft_limits(spec, limits, work_offset_mm);
  check_velocity(spec, limits);
  std::vector<std::string> checks{"soft limits", "velocity"};
  if (check_acceleration(spec, limits, words)) {
    checks.push_back("acceleration");
    checks.push_back("lead run-up");
  }
  if (limits.motion_outputs) {
    check_motion_outputs(spec, limits, words);
    checks.push_back("motion outputs");
  }
  return checks;
}

}  // namespace circtest
