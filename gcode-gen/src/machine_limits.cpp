#include "circtest/gcode/machine_limits.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <limits>
#include <numbers>

#include "circtest/core/atomic_file.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"

namespace circtest {

namespace {

std::string trim(std::string_view text) {
  const auto first = text.find_first_not_of(" \t\r");
  if (first == std::string_view::npos) return {};
  const auto last = text.find_last_not_of(" \t\r");
  return std::string(text.substr(first, last - first + 1));
}

std::string upper(std::string text) {
  for (char& c : text) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return text;
}

double parse_ini_number(const std::string& source, std::size_t line, const std::string& section,
                        const std::string& key, const std::string& value) {
  const auto number = parse_finite(value);
  if (!number) {
    throw ParseError(source, line,
                     fmt::format("[{}] {}: '{}' is not a number", section, key, value));
  }
  return *number;
}

// LinuxCNC 2.9 (emcIniLoad) accepts these spellings for [TRAJ] LINEAR_UNITS.
std::optional<double> mm_per_unit(const std::string& value) {
  const std::string v = upper(value);
  if (v == "MM" || v == "METRIC") return 1.0;
  if (v == "INCH" || v == "IMPERIAL" || v == "IN") return kMmPerInch;
  return std::nullopt;
}

double deg_to_rad(double deg) {
  return deg * std::numbers::pi / 180.0;
}

}  // namespace

MachineLimits parse_machine_limits(const std::string& text, const std::string& source) {
  MachineLimits limits;
  limits.source = source;
  for (int i = 0; i < 3; ++i) limits.axes[i].axis = static_cast<char>('x' + i);

  // Raw values in machine units; converted once LINEAR_UNITS is known (it may come last).
  struct Pending {
    std::optional<double>* target;
    double value;
    bool is_length;
  };
  std::vector<Pending> pending;
  std::vector<std::string> seen;  // LinuxCNC's INI reader returns a key's first occurrence
  std::string section;
  std::size_t line_no = 0;
  std::size_t begin = 0;
  while (begin < text.size()) {
    std::size_t end = text.find('\n', begin);
    if (end == std::string::npos) end = text.size();
    const std::string line = trim(std::string_view(text).substr(begin, end - begin));
    begin = end + 1;
    ++line_no;
    if (line.empty() || line[0] == '#' || line[0] == ';') continue;
    if (line[0] == '[') {
      const auto close = line.find(']');
      if (close == std::string::npos) {
        throw ParseError(source, line_no, fmt::format("section header without ']': {}", line));
      }
      section = upper(trim(std::string_view(line).substr(1, close - 1)));
      continue;
    }
    const auto eq = line.find('=');
    if (eq == std::string::npos) {
      throw ParseError(source, line_no, fmt::format("expected KEY = VALUE, got '{}'", line));
    }
    const std::string key = upper(trim(std::string_view(line).substr(0, eq)));
    const std::string value = trim(std::string_view(line).substr(eq + 1));
    const std::string full = section + "/" + key;
    if (section == "HAL" && key == "HALFILE") limits.hal_files.push_back(value);
    if (std::find(seen.begin(), seen.end(), full) != seen.end()) continue;
    seen.push_back(full);
    limits.values.emplace(full, value);

    if (section == "TRAJ") {
      if (key == "LINEAR_UNITS") {
        const auto unit = mm_per_unit(value);
        if (!unit) {
          throw ParseError(source, line_no,
                           fmt::format("[TRAJ] LINEAR_UNITS: unknown unit '{}'", value));
        }
        limits.mm_per_machine_unit = *unit;
      } else if (key == "MAX_LINEAR_VELOCITY") {
        pending.push_back({&limits.max_linear_velocity_mm_per_s,
                           parse_ini_number(source, line_no, section, key, value), true});
      } else if (key == "MAX_LINEAR_ACCELERATION") {
        pending.push_back({&limits.max_linear_acceleration_mm_per_s2,
                           parse_ini_number(source, line_no, section, key, value), true});
      }
      continue;
    }
    if (section.size() == 6 && section.starts_with("AXIS_")) {
      const char letter = static_cast<char>(std::tolower(static_cast<unsigned char>(section[5])));
      if (letter < 'x' || letter > 'z') continue;
      AxisLimits& axis = limits.axes[letter - 'x'];
      axis.present = true;
      std::optional<double>* target = nullptr;
      if (key == "MIN_LIMIT") target = &axis.min_limit_mm;
      if (key == "MAX_LIMIT") target = &axis.max_limit_mm;
      if (key == "MAX_VELOCITY") target = &axis.max_velocity_mm_per_s;
      if (key == "MAX_ACCELERATION") target = &axis.max_acceleration_mm_per_s2;
      if (target) {
        pending.push_back({target, parse_ini_number(source, line_no, section, key, value), true});
      }
    }
  }
  // A section with no keys still counts as present.
  std::size_t pos = 0;
  while ((pos = text.find('[', pos)) != std::string::npos) {
    const auto close = text.find(']', pos);
    if (close == std::string::npos) break;
    const std::string name = upper(trim(std::string_view(text).substr(pos + 1, close - pos - 1)));
    if (name.size() == 6 && name.starts_with("AXIS_") && name[5] >= 'X' && name[5] <= 'Z') {
      limits.axes[name[5] - 'X'].present = true;
    }
    pos = close;
  }
  for (const Pending& p : pending) {
    *p.target = p.is_length ? p.value * limits.mm_per_machine_unit : p.value;
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
        ini.values.find(upper(word.substr(1, close - 1)) + "/" + word.substr(close + 1));
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
    line = trim(line);
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

MachineLimits read_machine_limits(const std::string& path) {
  MachineLimits limits = parse_machine_limits(read_file(path), path);
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
    if (file.extension() != ".hal" || !std::filesystem::is_regular_file(file)) continue;
    if (auto outputs = find_motion_outputs(read_file(file.string()), file.string(), limits)) {
      limits.motion_outputs = std::move(outputs);
      break;
    }
  }
  return limits;
}

std::vector<std::string> check_against_machine(const CircleTestSpec& spec,
                                               const MachineLimits& limits,
                                               const std::array<double, 3>& work_offset_mm) {
  validate(spec);
  const PlaneAxes axes = plane_axes(spec.plane);
  const double unit = limits.mm_per_machine_unit;
  const char* unit_name = unit == 1.0 ? "mm" : "inch";
  auto in_machine_units = [unit](double mm) { return mm / unit; };
  auto section = [](char axis) {
    return fmt::format("[AXIS_{}]", static_cast<char>(std::toupper(axis)));
  };
  for (char axis : {axes.first, axes.second, axes.normal}) {
    if (!limits.axes[axis - 'x'].present) {
      throw ParseError(limits.source, 0,
                       fmt::format("no {} section: cannot check the {} axis of the test",
                                   section(axis), static_cast<char>(std::toupper(axis))));
    }
  }

  // Extent of every position the program visits, per axis, in work coordinates (mm).
  std::array<double, 3> low = spec.centre_mm;
  std::array<double, 3> high = spec.centre_mm;
  {
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
  }
  for (int i = 0; i < 3; ++i) {
    const AxisLimits& axis = limits.axes[i];
    const char letter = static_cast<char>('X' + i);
    const double machine_low = low[i] + work_offset_mm[i];
    const double machine_high = high[i] + work_offset_mm[i];
    // A micrometre of slack so that a circle touching a limit exactly is not refused.
    constexpr double kSlackMm = 1e-6;
    if (axis.min_limit_mm && machine_low < *axis.min_limit_mm - kSlackMm) {
      throw LimitError(fmt::format(
          "{}: the test reaches {} = {} {} in machine coordinates, below {} MIN_LIMIT = {}",
          limits.source, letter, in_machine_units(machine_low), unit_name, section(axis.axis),
          in_machine_units(*axis.min_limit_mm)));
    }
    if (axis.max_limit_mm && machine_high > *axis.max_limit_mm + kSlackMm) {
      throw LimitError(fmt::format(
          "{}: the test reaches {} = {} {} in machine coordinates, above {} MAX_LIMIT = {}",
          limits.source, letter, in_machine_units(machine_high), unit_name, section(axis.axis),
          in_machine_units(*axis.max_limit_mm)));
    }
  }

  const double max_feed =
      *std::max_element(spec.feeds_mm_per_min.begin(), spec.feeds_mm_per_min.end());
  const double v_mm_per_s = max_feed / 60.0;
  // On a circle each axis of the plane reaches the full path speed and the full centripetal
  // acceleration somewhere, so the per-axis limits apply to the path values directly.
  for (char a : {axes.first, axes.second}) {
    const AxisLimits& axis = limits.axes[a - 'x'];
    if (axis.max_velocity_mm_per_s && v_mm_per_s > *axis.max_velocity_mm_per_s) {
      throw LimitError(fmt::format("{}: feed {} mm/min = {:.4g} {}/s exceeds {} MAX_VELOCITY = {}",
                                   limits.source, max_feed, in_machine_units(v_mm_per_s), unit_name,
                                   section(a), in_machine_units(*axis.max_velocity_mm_per_s)));
    }
  }
  if (limits.max_linear_velocity_mm_per_s && v_mm_per_s > *limits.max_linear_velocity_mm_per_s) {
    throw LimitError(
        fmt::format("{}: feed {} mm/min = {:.4g} {}/s exceeds [TRAJ] "
                    "MAX_LINEAR_VELOCITY = {}",
                    limits.source, max_feed, in_machine_units(v_mm_per_s), unit_name,
                    in_machine_units(*limits.max_linear_velocity_mm_per_s)));
  }

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
      a_name = fmt::format("{} MAX_ACCELERATION", section(a));
    }
  }
  if (limits.max_linear_acceleration_mm_per_s2 &&
      *limits.max_linear_acceleration_mm_per_s2 < a_max) {
    a_max = *limits.max_linear_acceleration_mm_per_s2;
    a_name = "[TRAJ] MAX_LINEAR_ACCELERATION";
  }
  if (std::isfinite(a_max)) {
    if (centripetal > a_max) {
      throw LimitError(fmt::format(
          "{}: centripetal acceleration V^2/R = {:.4g} {}/s^2 at F{} on R{} mm exceeds {} = {}",
          limits.source, in_machine_units(centripetal), unit_name, max_feed, spec.radius_mm, a_name,
          in_machine_units(a_max)));
    }
    if (centripetal > normal_share * a_max) {
      throw LimitError(fmt::format(
          "{}: centripetal acceleration V^2/R = {:.4g} {}/s^2 at F{} on R{} mm is above the "
          "{:.4g} {}/s^2 [0.866 * {} = {}] that LinuxCNC's planner allows on an arc; it would "
          "slow the arc below the feed",
          limits.source, in_machine_units(centripetal), unit_name, max_feed, spec.radius_mm,
          in_machine_units(normal_share * a_max), unit_name, a_name, in_machine_units(a_max)));
    }
    // The run-up from rest on the lead-in arc, with the tangential acceleration the planner
    // leaves on an arc of this curvature.
    const double tangential =
        a_max * std::max(tangential_share, std::sqrt(1.0 - std::pow(centripetal / a_max, 2)));
    const double run_up_mm = v_mm_per_s * v_mm_per_s / (2.0 * tangential);
    const double lead_mm = spec.radius_mm * deg_to_rad(spec.lead_deg);
    if (run_up_mm > lead_mm) {
      const double needed_deg = run_up_mm / spec.radius_mm * 180.0 / std::numbers::pi;
      throw LimitError(fmt::format(
          "{}: the {} deg lead-in [{:.3f} mm] is shorter than the {:.3f} mm needed to reach "
          "F{} with {} = {}; use --lead {:.0f} or more",
          limits.source, spec.lead_deg, lead_mm, run_up_mm, max_feed, a_name,
          in_machine_units(a_max), std::ceil(needed_deg)));
    }
  }
  std::vector<std::string> checks{"soft limits", "velocity"};
  if (std::isfinite(a_max)) checks.push_back("acceleration"), checks.push_back("lead run-up");
  if (limits.motion_outputs) {
    const MotionOutputs& m = *limits.motion_outputs;
    if (spec.marker_output >= m.num_dio) {
      throw LimitError(fmt::format(
          "{}: --marker {}: the motion module loaded at {} has num_dio={} (M62/M63 P0..P{}); "
          "raise num_dio there or use another output",
          limits.source, spec.marker_output, m.where, m.num_dio, m.num_dio - 1));
    }
    if (spec.segment_output >= m.num_aio) {
      throw LimitError(fmt::format(
          "{}: --segment-out {}: the motion module loaded at {} has num_aio={} (M67 E0..E{}); "
          "raise num_aio there or use another output",
          limits.source, spec.segment_output, m.where, m.num_aio, m.num_aio - 1));
    }
    checks.push_back("motion outputs");
  }
  return checks;
}

}  // namespace circtest
