#include "circtest/compensation/plan_json.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string_view>

#include "circtest/compensation/comp_table.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/ini.hpp"
#include "circtest/core/numbers.hpp"
#include "plan/context.hpp"

namespace circtest::compensation {

namespace {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;
using Values = std::vector<std::string>;

// What the words need of the configuration after the plan: which axis each joint moves and
// the machine units per mm. A configuration the plan itself could read always gives both; the
// words fall back to section names when it cannot be read.
struct Machine {
  std::map<int, char> joint_axis;
  double units_per_mm = 1.0;
  std::optional<IniDocument> ini;
};

Machine machine_of(const Plan& plan) {
  Machine m;
  try {
    const auto main = std::find_if(plan.files.begin(), plan.files.end(),
                                   [&](const FileChange& f) { return f.path == plan.ini_path; });
    m.ini = main != plan.files.end() ? IniDocument::parse(main->after, plan.ini_path)
                                     : IniDocument::load(plan.ini_path);
    m.units_per_mm = detail::units_per_mm(*m.ini);
  } catch (const Error&) {
    return m;
  }
  for (const char letter : std::string_view("XYZABCUVW")) {
    try {
      for (const int j : detail::joints_of(*m.ini, letter)) m.joint_axis[j] = letter;
    } catch (const Error&) {
      // No joint for this letter, or a kinematics circcomp does not map.
    }
  }
  return m;
}

// The axis letter of [JOINT_n] or [AXIS_L], 0 for another section.
char axis_of(const Machine& m, const std::string& section) {
  if (section.rfind("AXIS_", 0) == 0 && section.size() == 6) return section[5];
  if (section.rfind("JOINT_", 0) == 0) {
    const auto n = parse_finite(std::string_view(section).substr(6));
    if (n && *n >= 0 && *n < 64 && *n == static_cast<int>(*n)) {
      const auto it = m.joint_axis.find(static_cast<int>(*n));
      if (it != m.joint_axis.end()) return it->second;
    }
  }
  return 0;
}

// "10.2" (one decimal), "0" for nothing.
std::string amount(double v) {
  if (std::abs(v) < 0.05) return "0";
  return fmt::format("{:.1f}", v);
}

// VALUE scaled for the words (BACKLASH in µm, a squareness in µrad), or the INI's text.
std::string scaled(const std::optional<std::string>& text, double factor) {
  if (!text) return "0";
  const auto v = parse_finite(*text);
  return v ? amount(*v * factor) : *text;
}

std::string shown(const std::optional<std::string>& text) {
  return text ? *text : "(none)";
}

// The gains of a joint's servo loop: "FF1 X 0 → 1.0".
bool is_loop_gain(const std::string& key) {
  static const char* const kGains[] = {"P",   "I",    "D",        "FF0",       "FF1",
                                       "FF2", "BIAS", "DEADBAND", "MAX_OUTPUT"};
  return std::any_of(std::begin(kGains), std::end(kGains), [&](const char* g) { return key == g; });
}

std::string key_words(const Machine& m, const std::string& section, const std::string& key,
                      const std::optional<std::string>& before,
                      const std::optional<std::string>& after) {
  const char axis = axis_of(m, section);
  const std::string who = axis ? std::string(1, axis) : "[" + section + "]";
  if (key == "BACKLASH") {
    const double um = 1000.0 / m.units_per_mm;
    return fmt::format("{} backlash {} → {} µm", who, scaled(before, um), scaled(after, um));
  }
  if (key.rfind("SQUARENESS_", 0) == 0) {
    return fmt::format("squareness {} correction {} → {} µrad", key.substr(11), scaled(before, 1e6),
                       scaled(after, 1e6));
  }
  if (key == "COMP_FILE") {
    return fmt::format("{} compensation table {} → {}", who, shown(before), shown(after));
  }
  if (key == "COMP_FILE_TYPE") {
    return fmt::format("{} compensation table type {} → {}", who, shown(before), shown(after));
  }
  if (key == "KINEMATICS") return fmt::format("kinematics {} → {}", shown(before), shown(after));
  if (key == "HALFILE" && !before) return fmt::format("HAL file {} added", shown(after));
  if (key == "HALFILE" && !after) return fmt::format("HAL file {} removed", shown(before));
  if (axis && is_loop_gain(key)) {
    return fmt::format("{} {} {} → {}", key, axis, shown(before), shown(after));
  }
  return fmt::format("[{}] {} {} → {}", section, key, shown(before), shown(after));
}

// False for a key written without effect: a BACKLASH or squareness set from nothing to 0.
bool effective(const Machine& m, const std::string& key, const std::optional<std::string>& before,
               const std::optional<std::string>& after) {
  if (key == "BACKLASH") {
    const double um = 1000.0 / m.units_per_mm;
    return scaled(before, um) != scaled(after, um);
  }
  if (key.rfind("SQUARENESS_", 0) == 0) return scaled(before, 1e6) != scaled(after, 1e6);
  return true;
}

// "setting": a value that corrects the machine (a backlash, a squareness, a gain, any key
// circtest does not know); "wiring": what makes LinuxCNC use it (a HAL file, the kinematics,
// a compensation table's name and type).
const char* kind_of(const std::string& key) {
  static const char* const kWiring[] = {"HALFILE", "KINEMATICS", "COMP_FILE", "COMP_FILE_TYPE"};
  return std::any_of(std::begin(kWiring), std::end(kWiring),
                     [&](const char* w) { return key == w; })
             ? "wiring"
             : "setting";
}

ojson change(const FileChange& f, const std::string& section, const std::string& key,
             const std::optional<std::string>& before, const std::optional<std::string>& after,
             const Machine& m) {
  ojson c;
  c["file"] = f.path;
  c["section"] = section;
  c["key"] = key;
  c["before"] = before ? ojson(*before) : ojson(nullptr);
  c["after"] = after ? ojson(*after) : ojson(nullptr);
  c["words"] = key_words(m, section, key, before, after);
  c["kind"] = kind_of(key);
  c["effective"] = effective(m, key, before, after);
  return c;
}

Values values(const IniDocument& ini, const std::string& section, const std::string& key) {
  Values v;
  for (const auto& e : ini.get_all(section, key)) v.push_back(e.value);
  return v;
}

// Every key whose value(s) differ between the file's text before and after. A key given once
// is one change; a key given several times ([HAL] HALFILE) a change per value added or removed.
void ini_changes(const FileChange& f, const IniDocument& before, const IniDocument& after,
                 const Machine& m, ojson& out) {
  std::vector<std::string> sections = after.sections();
  for (const auto& s : before.sections()) {
    if (std::find(sections.begin(), sections.end(), s) == sections.end()) sections.push_back(s);
  }
  for (const auto& section : sections) {
    std::vector<std::string> keys;
    for (const IniDocument* doc : {&after, &before}) {
      for (const auto& e : doc->entries(section)) {
        if (std::find(keys.begin(), keys.end(), e.key) == keys.end()) keys.push_back(e.key);
      }
    }
    for (const auto& key : keys) {
      Values vb = values(before, section, key), va = values(after, section, key);
      if (vb == va) continue;
      if (vb.size() <= 1 && va.size() <= 1) {
        auto first = [](const Values& v) {
          return v.empty() ? std::nullopt : std::optional<std::string>(v.front());
        };
        out.push_back(change(f, section, key, first(vb), first(va), m));
        continue;
      }
      for (const auto& v : vb) {
        if (std::find(va.begin(), va.end(), v) == va.end())
          out.push_back(change(f, section, key, v, std::nullopt, m));
      }
      for (const auto& v : va) {
        if (std::find(vb.begin(), vb.end(), v) == vb.end())
          out.push_back(change(f, section, key, std::nullopt, v, m));
      }
    }
  }
}

// Backlash (type 1: forward less reverse trim) and the linear part of the trims (scale, ppm)
// of a compensation table; zero for no table.
struct TableTerms {
  double backlash_units = 0.0;
  double scale_ppm = 0.0;
};
TableTerms table_terms(const CompTable& t) {
  TableTerms terms;
  const double n = static_cast<double>(t.entries.size());
  if (n == 0) return terms;
  double sx = 0, sy = 0, sxx = 0, sxy = 0, backlash = 0;
  for (const auto& e : t.entries) {
    const double trim = (e.forward_trim + e.reverse_trim) / 2.0;
    sx += e.nominal;
    sy += trim;
    sxx += e.nominal * e.nominal;
    sxy += e.nominal * trim;
    backlash += e.forward_trim - e.reverse_trim;
  }
  terms.backlash_units = t.type == 1 ? backlash / n : 0.0;
  const double den = n * sxx - sx * sx;
  if (n >= 2 && den > 0) terms.scale_ppm = (n * sxy - sx * sy) / den * 1e6;
  return terms;
}

// The words of a file that is not an INI file: a compensation table named by a [JOINT_n]
// COMP_FILE as the backlash and scale it holds before and after, any other file by its size.
std::string file_words(const FileChange& f, const std::string& ini_path, const Machine& m,
                       bool& table) {
  table = false;
  const std::string what =
      fmt::format("{} {}", fs::path(f.path).filename().string(), f.existed ? "changed" : "created");
  if (!m.ini) return what;
  const fs::path here = fs::path(f.path).lexically_normal();
  for (const auto& section : m.ini->sections()) {
    const auto file = m.ini->get(section, "COMP_FILE");
    if (!file || (fs::path(ini_path).parent_path() / *file).lexically_normal() != here) continue;
    const auto type_text = m.ini->get(section, "COMP_FILE_TYPE");
    const int type = type_text && parse_finite(*type_text) == 1.0 ? 1 : 0;
    try {
      const TableTerms before =
          f.existed ? table_terms(parse_comp_table(f.before, type, f.path)) : TableTerms{};
      const TableTerms after = table_terms(parse_comp_table(f.after, type, f.path));
      const char axis = axis_of(m, section);
      const std::string who = axis ? std::string(1, axis) : "[" + section + "]";
      std::string words = fmt::format("{} compensation table {}: ", who, what);
      table = true;
      if (type == 1) {
        const double um = 1000.0 / m.units_per_mm;
        words += fmt::format("backlash {} → {} µm, ", amount(before.backlash_units * um),
                             amount(after.backlash_units * um));
      }
      return words + fmt::format("scale correction {} → {} ppm", amount(before.scale_ppm),
                                 amount(after.scale_ppm));
    } catch (const Error&) {
      return what;
    }
  }
  return what;
}

// The lines of TEXT (without their line breaks).
std::vector<std::string_view> text_lines(std::string_view text) {
  std::vector<std::string_view> out;
  while (!text.empty()) {
    const std::size_t e = text.find('\n');
    out.push_back(text.substr(0, e));
    text = e == std::string_view::npos ? std::string_view() : text.substr(e + 1);
  }
  return out;
}

// The gains written into the HAL lines of F, one change each (a setting); true when they are
// all that changes in F (each changed line one of theirs).
bool hal_value_changes(const Plan& plan, const FileChange& f, ojson& out) {
  std::set<std::size_t> lines;
  for (const HalValueChange& v : plan.hal_values) {
    if (v.file != f.path) continue;
    lines.insert(v.line);
    ojson c;
    c["file"] = f.path;
    c["section"] = nullptr;
    c["key"] = v.key;
    c["before"] = v.before;
    c["after"] = v.after;
    c["words"] =
        fmt::format("{} {} {} → {} ({}:{}, {})", v.key, v.axis ? std::string(1, v.axis) : "?",
                    v.before, v.after, fs::path(f.path).filename().string(), v.line, v.command);
    c["kind"] = "setting";
    c["effective"] = true;
    c["hal_line"] = v.line;
    c["hal_command"] = v.command;
    out.push_back(std::move(c));
  }
  if (lines.empty() || !f.existed) return false;
  const auto a = text_lines(f.before), b = text_lines(f.after);
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i] != b[i] && lines.count(i + 1) == 0) return false;
  }
  return true;
}

bool has_sections(const std::string& text, const std::string& path) {
  try {
    return !IniDocument::parse(text, path).sections().empty();
  } catch (const Error&) {
    return false;
  }
}

}  // namespace

nlohmann::ordered_json plan_json(const Plan& plan) {
  const Machine m = machine_of(plan);
  ojson j;
  j["schema"] = kPlanSchema;
  j["ini"] = plan.ini_path;
  ojson changes = ojson::array();
  ojson files = ojson::array();
  for (const FileChange& f : plan.files) {
    ojson file;
    file["file"] = f.path;
    file["created"] = !f.existed;
    if (has_sections(f.after, f.path) || (f.existed && has_sections(f.before, f.path))) {
      file["kind"] = "ini";
      ini_changes(f, IniDocument::parse(f.before, f.path), IniDocument::parse(f.after, f.path), m,
                  changes);
    } else {
      file["kind"] = "other";
      // A compensation table holds settings (backlash, scale); any other file is wiring.
      bool table = false;
      file["words"] = file_words(f, plan.ini_path, m, table);
      if (hal_value_changes(plan, f, changes)) {
        files.push_back(std::move(file));
        continue;
      }
      changes.push_back({{"file", f.path},
                         {"section", nullptr},
                         {"key", nullptr},
                         {"before", nullptr},
                         {"after", nullptr},
                         {"words", file["words"]},
                         {"kind", table ? "setting" : "wiring"},
                         {"effective", true}});
    }
    files.push_back(std::move(file));
  }
  j["changes"] = std::move(changes);
  j["files"] = std::move(files);
  j["summary"] = plan.changes;
  j["advice"] = plan.advice;
  j["notes"] = plan.notes;
  j["provenance_checked"] = plan.provenance_checked;
  return j;
}

}  // namespace circtest::compensation
