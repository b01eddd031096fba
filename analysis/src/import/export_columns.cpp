// The columns of an instrument file: the --columns names with their units, and a title
// row's fields read as those names (British and American spellings, unit signs spelled out).
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <string>
#include <utility>
#include <vector>

#include "circtest/analysis/instrument_export.hpp"
#include "circtest/core/cli.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/strings.hpp"
#include "export_columns.hpp"

namespace circtest {

namespace {

using import_detail::kDegPerRad;

struct Unit {
  std::string_view name;
  double scale;
};
struct RoleName {
  std::string_view name;  // before the unit: "angle", "dev", "t"; an axis letter for positions
  ExportRole role;
  std::array<Unit, 3> units;  // empty names: no more units; all empty: the name takes none
};

// The names of --columns, per role with its units (converted to deg, mm, s).
constexpr std::array kRoleNames{
    RoleName{"angle", ExportRole::angle, {Unit{"deg", 1.0}, Unit{"rad", kDegPerRad}, Unit{}}},
    RoleName{"dev", ExportRole::deviation, {Unit{"um", 1e-3}, Unit{"mm", 1.0}, Unit{"nm", 1e-6}}},
    RoleName{
        "ccw", ExportRole::deviation_ccw, {Unit{"um", 1e-3}, Unit{"mm", 1.0}, Unit{"nm", 1e-6}}},
    RoleName{"cw", ExportRole::deviation_cw, {Unit{"um", 1e-3}, Unit{"mm", 1.0}, Unit{"nm", 1e-6}}},
    RoleName{"t", ExportRole::time, {Unit{"s", 1.0}, Unit{"ms", 1e-3}, Unit{}}},
    RoleName{"run", ExportRole::run, {}},
    RoleName{"skip", ExportRole::skip, {}},
};
constexpr std::array<Unit, 2> kPositionUnits{Unit{"mm", 1.0}, Unit{"um", 1e-3}};

// The words of a title field, lower case, with the unit signs spelled out (µm, μm -> um,
// ° -> deg).
std::vector<std::string> title_words(std::string_view field) {
  // The micro sign, the Greek mu, the degree sign.
  static constexpr std::array<std::pair<std::string_view, std::string_view>, 3> kSigns{
      {{"\xC2\xB5", "u"}, {"\xCE\xBC", "u"}, {"\xC2\xB0", " deg "}}};
  std::string text;
  text.reserve(field.size() + 8);
  for (std::size_t i = 0; i < field.size();) {
    const auto sign = std::find_if(kSigns.begin(), kSigns.end(), [&](const auto& s) {
      return field.substr(i).starts_with(s.first);
    });
    if (sign == kSigns.end()) {
      text += field[i++];
    } else {
      text += sign->second;
      i += sign->first.size();
    }
  }
  std::vector<std::string> words;
  std::string word;
  for (const char c : text) {
    const auto u = static_cast<unsigned char>(c);
    if (std::isalnum(u)) {
      word += static_cast<char>(std::tolower(u));
    } else if (!word.empty()) {
      words.push_back(std::move(word));
      word.clear();
    }
  }
  if (!word.empty()) words.push_back(std::move(word));
  return words;
}

}  // namespace

std::string import_detail::title_column_name(std::string_view field) {
  const std::vector<std::string> words = title_words(field);
  const auto has = [&words](std::initializer_list<std::string_view> any) {
    return std::any_of(words.begin(), words.end(), [&any](const std::string& w) {
      return std::find(any.begin(), any.end(), w) != any.end();
    });
  };
  std::string role;
  if (has({"angle", "theta"})) {
    role = "angle";
  } else if (has({"ccw", "counterclockwise", "anticlockwise", "acw"}) ||
             (has({"counter", "anti"}) && has({"clockwise"}))) {
    role = "ccw";
  } else if (has({"cw", "clockwise"})) {
    role = "cw";
  } else if (has({"deviation", "dev", "error", "radial", "dr"})) {
    role = "dev";
  } else if (has({"time", "t", "timestamp"})) {
    role = "t";
  } else if (has({"run", "segment"})) {
    return "run";
  } else if (has({"centre", "center", "nominal", "target"})) {
    // "Centre X", "Center X": a coordinate of the centre, not the axis's position.
    return {};
  } else if (const auto axes = std::count_if(
                 words.begin(), words.end(),
                 [](const std::string& w) { return w == "x" || w == "y" || w == "z"; });
             axes == 1) {
    // "X (mm)", "X position [um]": one axis letter names a position column.
    role = *std::find_if(words.begin(), words.end(),
                         [](const std::string& w) { return w == "x" || w == "y" || w == "z"; });
  } else {
    return {};
  }
  std::string unit;
  for (const std::string& w : words) {
    std::string u = w;
    // British and American spellings alike (metre, meter), singular and plural.
    if (u.size() > 3 && u.back() == 's' && u != "ms") u.pop_back();
    if (u == "degree") u = "deg";
    if (u == "radian") u = "rad";
    if (u == "micron" || u == "micrometre" || u == "micrometer") u = "um";
    if (u == "millimetre" || u == "millimeter") u = "mm";
    if (u == "nanometre" || u == "nanometer") u = "nm";
    if (u == "millisecond" || u == "msec") u = "ms";
    if (u == "sec" || u == "second") u = "s";
    if (u == "deg" || u == "rad" || u == "um" || u == "mm" || u == "nm" || u == "ms" ||
        (u == "s" && role == "t")) {
      if (!unit.empty() && unit != u) return {};  // two units: not for us to pick one
      unit = u;
    }
  }
  return unit.empty() ? std::string() : fmt::format("{}_{}", role, unit);
}

std::vector<std::string> export_column_names(Plane plane) {
  std::vector<std::string> names;
  for (const RoleName& r : kRoleNames) {
    if (r.units[0].name.empty()) names.emplace_back(r.name);
    for (const Unit& u : r.units) {
      if (!u.name.empty()) names.push_back(fmt::format("{}_{}", r.name, u.name));
    }
  }
  const PlaneAxes axes = plane_axes(plane);
  for (const char axis : {axes.first, axes.second}) {
    for (const Unit& u : kPositionUnits) names.push_back(fmt::format("{}_{}", axis, u.name));
  }
  return names;
}

std::optional<ExportColumn> parse_export_column(std::string_view name, Plane plane) {
  for (const RoleName& r : kRoleNames) {
    if (r.units[0].name.empty() && name == r.name)
      return ExportColumn{r.role, 1.0, std::string(name)};
    for (const Unit& u : r.units) {
      if (!u.name.empty() && name == fmt::format("{}_{}", r.name, u.name)) {
        return ExportColumn{r.role, u.scale, std::string(name)};
      }
    }
  }
  const PlaneAxes axes = plane_axes(plane);
  for (const char axis : {axes.first, axes.second}) {
    for (const Unit& u : kPositionUnits) {
      if (name == fmt::format("{}_{}", axis, u.name)) {
        return ExportColumn{axis == axes.first ? ExportRole::position_a : ExportRole::position_b,
                            u.scale, std::string(name)};
      }
    }
  }
  return std::nullopt;
}

std::vector<ExportColumn> parse_export_columns(std::string_view list, Plane plane) {
  std::vector<ExportColumn> columns;
  const std::vector<std::string> known = export_column_names(plane);
  std::size_t begin = 0;
  while (begin <= list.size()) {
    std::size_t end = list.find(',', begin);
    if (end == std::string_view::npos) end = list.size();
    const std::string item(trim(list.substr(begin, end - begin)));
    begin = end + 1;
    const auto column = parse_export_column(item, plane);
    if (!column) {
      std::string message =
          fmt::format("--columns: unknown column '{}' for the plane {}: expected one of {}", item,
                      plane_name(plane), join(known, ", "));
      if (const std::string guess = closest_name(item, known); !guess.empty()) {
        message += "; did you mean " + guess + "?";
      }
      throw UsageError(message);
    }
    columns.push_back(*column);
  }
  return columns;
}

}  // namespace circtest
