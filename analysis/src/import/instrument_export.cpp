#include "circtest/analysis/instrument_export.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <numeric>

#include "circtest/core/cli.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/strings.hpp"
#include "circtest/core/trace_keys.hpp"
#include "circtest/core/utc_time.hpp"
#include "export_columns.hpp"

namespace circtest {

namespace {

using import_detail::kDegPerRad;
using import_detail::title_column_name;

// ------------------------------------------------------------------ the text's lines

// A line split at blanks, tabs, commas and semicolons (a decimal comma is therefore never
// read as a decimal point: "0,5;1,2" is four fields, refused by their count).
std::vector<std::string> split_fields(std::string_view line) {
  std::vector<std::string> fields;
  std::string field;
  for (const char c : line) {
    if (c == ' ' || c == '\t' || c == ',' || c == ';') {
      if (!field.empty()) fields.push_back(std::move(field));
      field.clear();
    } else {
      field += c;
    }
  }
  if (!field.empty()) fields.push_back(std::move(field));
  return fields;
}

// A title row's fields: split at tabs, commas and semicolons when it has any (a title such
// as "CCW deviation (um)" holds blanks), else at blanks.
std::vector<std::string> split_title(std::string_view line) {
  if (line.find_first_of(",;\t") == std::string_view::npos) return split_fields(line);
  std::vector<std::string> fields;
  std::size_t begin = 0;
  while (begin <= line.size()) {
    std::size_t end = line.find_first_of(",;\t", begin);
    if (end == std::string_view::npos) end = line.size();
    const std::string_view field = trim(line.substr(begin, end - begin));
    if (!field.empty()) fields.emplace_back(field);
    begin = end + 1;
  }
  return fields;
}

struct TextLine {
  std::size_t number = 0;
  std::string_view text;  // into the export's text, without its line end
};

// Lines that hold something: blank lines dropped; a BOM and CR line ends removed.
std::vector<TextLine> content_lines(std::string_view text) {
  std::vector<TextLine> out;
  std::size_t number = 0, begin = 0;
  while (begin < text.size()) {
    std::size_t end = text.find('\n', begin);
    if (end == std::string_view::npos) end = text.size();
    std::string_view view = text.substr(begin, end - begin);
    begin = end + 1;
    ++number;
    if (number == 1 && view.starts_with("\xEF\xBB\xBF")) view.remove_prefix(3);
    if (!view.empty() && view.back() == '\r') view.remove_suffix(1);
    if (trim(view).empty()) continue;
    out.push_back({number, view});
  }
  return out;
}

bool is_comment(std::string_view line) {
  const std::string_view t = trim(line);
  return t.starts_with('#') || t.starts_with(';');
}

// ------------------------------------------------------------------ the table

struct Table {
  std::vector<ExportColumn> columns;
  std::vector<std::vector<double>> values;  // per column (skip columns stay empty)
  std::vector<std::size_t> lines;
  std::optional<std::size_t> column(ExportRole role) const {
    for (std::size_t i = 0; i < columns.size(); ++i) {
      if (columns[i].role == role) return i;
    }
    return std::nullopt;
  }
};

// What an export holds before its rows are read: the test's metadata (a circana export's
// own lines), its title row and the lines of rows.
struct ExportText {
  TraceMetadata metadata;
  std::optional<TextLine> title;
  std::vector<TextLine> rows;
};

ExportText split_export(std::string_view text, const std::string& source) {
  ExportText out;
  bool own_export = false;
  for (TextLine& line : content_lines(text)) {
    if (is_comment(line.text)) {
      const std::string_view body = trim(trim(line.text).substr(1));
      const auto colon = body.find(':');
      if (colon == std::string_view::npos) continue;
      const std::string key(trim(body.substr(0, colon)));
      const std::string value(trim(body.substr(colon + 1)));
      if (key == kExportedByKey && value == kExportedByPolar) own_export = true;
      if (!own_export || !out.rows.empty() || key.empty()) continue;  // others' comments are text
      // The test's metadata goes into every output (JSON, plots, the history): UTF-8 only.
      if (invalid_utf8_offset(line.text) != std::string_view::npos) {
        throw ParseError(source, line.number,
                         fmt::format("metadata '{}': not UTF-8 text", utf8_replacing_invalid(key)));
      }
      out.metadata.set(key, value);
      out.metadata.set_line(out.metadata.entries().size() - 1, line.number);
      continue;
    }
    if (out.rows.empty()) {
      // Before the rows: lines whose first field is no number (a title, a preamble of
      // "Machine: ..." lines); the last of them is the title.
      const auto fields = split_fields(line.text);
      if (fields.empty() || !parse_finite(fields.front())) {
        out.title = std::move(line);
        continue;
      }
    }
    out.rows.push_back(std::move(line));
  }
  return out;
}

// The columns: the option's, else the title row's, else for two columns angle_deg,dev_um
// (the plain export), else refused.
std::vector<ExportColumn> export_columns(const ExportText& text, const std::string& source,
                                         const ExportImportOptions& options, Plane plane) {
  if (options.columns) return parse_export_columns(*options.columns, plane);
  const std::string example = "--columns angle_deg,dev_um or t_s,x_mm,y_mm";
  if (text.title) {
    std::vector<ExportColumn> columns;
    for (const std::string& field : split_title(text.title->text)) {
      std::string name = title_column_name(field);
      const auto column = name.empty() ? std::nullopt : parse_export_column(name, plane);
      if (!column) {
        throw ParseError(source, text.title->number,
                         fmt::format("title '{}': cannot tell what '{}' holds and in which unit; "
                                     "name the columns with {}",
                                     text.title->text, field, example));
      }
      columns.push_back(*column);
    }
    return columns;
  }
  if (text.rows.empty()) {
    throw ParseError(source, text.title ? text.title->number : 0,
                     "no rows of numbers: an export needs at least 3");
  }
  const std::size_t fields = split_fields(text.rows.front().text).size();
  if (fields == 2) return parse_export_columns("angle_deg,dev_um", plane);
  throw ParseError(source, text.rows.front().number,
                   fmt::format("{} columns and no title row: name them with {}", fields, example));
}

void check_value(const ExportColumn& column, double v, const TextLine& line,
                 const std::string& source, const std::string& field) {
  const auto refuse = [&](const std::string& expected) {
    throw ParseError(source, line.number,
                     fmt::format("column '{}': expected {}, got '{}' in '{}'", column.name,
                                 expected, field, line.text));
  };
  switch (column.role) {
    case ExportRole::angle:
    case ExportRole::deviation:
    case ExportRole::deviation_ccw:
    case ExportRole::deviation_cw:
      // One message for both: either number would size the trace rather than describe a test.
      if (std::abs(column.role == ExportRole::angle ? v : v * 1e3) >
          (column.role == ExportRole::angle ? kMaxPolarAngleDeg : kMaxPolarDeviationUm)) {
        refuse(fmt::format("an angle within +-{:g} deg and radial deviations within +-{:g} um",
                           kMaxPolarAngleDeg, kMaxPolarDeviationUm));
      }
      break;
    case ExportRole::run:
      if (!(v >= 1.0 && v <= 2147483647.0 && v == std::floor(v))) {
        refuse("a run id, a whole number from 1 to 2147483647");
      }
      break;
    case ExportRole::time:
      if (std::abs(v) > kMaxExportTimeS)
        refuse(fmt::format("a time within +-{:g} s", kMaxExportTimeS));
      break;
    case ExportRole::position_a:
    case ExportRole::position_b:
      if (std::abs(v) > kMaxExportPositionMm) {
        refuse(fmt::format("a position within +-{:g} mm", kMaxExportPositionMm));
      }
      break;
    case ExportRole::skip:
      break;
  }
}

Table read_rows(const ExportText& text, std::vector<ExportColumn> columns,
                const std::string& source) {
  Table table;
  table.columns = std::move(columns);
  table.values.assign(table.columns.size(), {});
  std::vector<std::string> names;
  for (const auto& c : table.columns) names.push_back(c.name);
  const std::optional<std::size_t> time = table.column(ExportRole::time);
  for (const TextLine& line : text.rows) {
    const std::vector<std::string> fields = split_fields(line.text);
    if (fields.size() != table.columns.size()) {
      throw ParseError(source, line.number,
                       fmt::format("expected {} fields ({}), got {}: '{}'", table.columns.size(),
                                   join(names, ","), fields.size(), line.text));
    }
    for (std::size_t i = 0; i < fields.size(); ++i) {
      const ExportColumn& column = table.columns[i];
      if (column.role == ExportRole::skip) continue;
      const auto v = parse_finite(fields[i]);
      if (!v) {
        throw ParseError(source, line.number,
                         fmt::format("column '{}': expected a number, got '{}' in '{}'",
                                     column.name, fields[i], line.text));
      }
      const double value = *v * column.scale;
      check_value(column, value, line, source, fields[i]);
      if (time && i == *time && !table.values[i].empty() && value < table.values[i].back()) {
        throw DataError(
            source, line.number,
            fmt::format("time goes back: {} s after {} s", value, table.values[i].back()));
      }
      table.values[i].push_back(value);
    }
    table.lines.push_back(line.number);
  }
  if (table.lines.size() < 3) {
    throw ParseError(source, text.rows.empty() ? 0 : text.rows.back().number,
                     fmt::format("{} rows: an export needs at least 3", table.lines.size()));
  }
  return table;
}

// ------------------------------------------------------------------ the test's metadata

// Keys of a circana export that describe the trace written, not the test: set here.
bool written_here(std::string_view key) {
  return key == meta_key::centre_mm || key == meta_key::bar_length_mm ||
         key == meta_key::imported_from || key == kExportedByKey || key == meta_key::diameter_mm ||
         key == meta_key::radius_in || key == meta_key::diameter_in || key == meta_key::centre_in;
}

// Settles an item the option and the file may both state: they must agree.
void agree(TraceMetadata& out, const TraceMetadata& file, const char* key,
           const std::optional<std::string>& option, std::string_view option_name,
           const std::string& source, bool (*same)(const std::string&, const std::string&)) {
  const std::string* in_file = file.find(key);
  if (option && in_file && !same(*option, *in_file)) {
    throw DataError(source, file.line_of(key),
                    fmt::format("{} {} disagrees with the export's {}: {}; leave the option out "
                                "or correct it",
                                option_name, *option, key, *in_file));
  }
  if (option && !in_file) out.set(key, *option);
}

bool same_text(const std::string& a, const std::string& b) {
  return a == b;
}
bool same_number(const std::string& a, const std::string& b) {
  const auto x = parse_finite(a), y = parse_finite(b);
  return x && y && std::abs(*x - *y) <= 1e-9 * std::max(1.0, std::abs(*x));
}
bool same_time(const std::string& a, const std::string& b) {
  return canonical_utc_iso8601(a) == canonical_utc_iso8601(b);
}

std::optional<std::string> number_text(const std::optional<double>& v) {
  return v ? std::optional<std::string>(fmt::format("{}", *v)) : std::nullopt;
}

// The trace's metadata: the file's test keys with their lines, then what the options add.
TraceMetadata import_metadata(const ExportText& text, const std::string& source,
                              const ExportImportOptions& options, Plane plane, bool polar) {
  const TraceMetadata& file = text.metadata;
  TraceMetadata out;
  for (std::size_t i = 0; i < file.entries().size(); ++i) {
    const auto& [key, value] = file.entries()[i];
    if (written_here(key) || key == meta_key::plane) continue;
    out.set(key, value);
    out.set_line(out.entries().size() - 1, file.line_at(i));
  }
  out.set(meta_key::plane, std::string(plane_name(plane)));
  agree(out, file, meta_key::radius_mm, number_text(options.radius_mm), "--radius", source,
        same_number);
  agree(out, file, meta_key::feed_mm_per_min, number_text(options.feed_mm_per_min), "--feed",
        source, same_number);
  const char* date_key = file.find(meta_key::start_time) || !file.find(meta_key::date)
                             ? meta_key::start_time
                             : meta_key::date;
  agree(out, file, date_key,
        options.date.empty() ? std::nullopt : std::optional<std::string>(options.date), "--date",
        source, same_time);
  if (const auto& ini = options.ini_provenance) {
    const std::string* path = ini->find(meta_key::ini);
    const std::string* sha = ini->find(meta_key::ini_sha256);
    agree(out, file, meta_key::ini_sha256, *sha, "--ini " + *path + ": SHA-256", source, same_text);
    if (!file.find(meta_key::ini)) out.set(meta_key::ini, *path);
  }
  const std::optional<std::string> instrument =
      options.instrument.empty() ? std::nullopt : std::optional<std::string>(options.instrument);
  agree(out, file, meta_key::instrument, instrument, "--instrument", source, same_text);
  if (!out.find(meta_key::instrument)) {
    out.set(meta_key::instrument, polar ? kUnnamedRadialInstrument : kUnnamedXyInstrument);
  }
  out.set(meta_key::imported_from, source);
  check_metadata(out, source);
  return out;
}

// ------------------------------------------------------------------ polar exports

struct PolarPoint {
  double angle_deg = 0.0;
  double deviation_mm = 0.0;
  double run = 1.0;
  std::size_t line = 0;
};

// Each deviation column of the table as the points of its run, in the run's order.
std::vector<PolarPoint> polar_points(const Table& table, const ExportImportOptions& options,
                                     const std::string& source) {
  const auto angle = table.column(ExportRole::angle);
  const auto dev = table.column(ExportRole::deviation);
  const auto ccw = table.column(ExportRole::deviation_ccw);
  const auto cw = table.column(ExportRole::deviation_cw);
  const auto run = table.column(ExportRole::run);
  const auto& a = table.values[*angle];
  std::vector<PolarPoint> points;
  if (ccw || cw) {
    // One angle, a deviation per direction: the CCW run sweeps up, the CW run down.
    std::vector<std::size_t> order(a.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::stable_sort(order.begin(), order.end(),
                     [&a](std::size_t i, std::size_t j) { return a[i] < a[j]; });
    double id = 1.0;
    for (const auto& column : {ccw, cw}) {
      if (!column) continue;
      if (column == cw) std::reverse(order.begin(), order.end());
      for (const std::size_t i : order) {
        points.push_back({a[i], table.values[*column][i], id, table.lines[i]});
      }
      id += 1.0;
    }
    return points;
  }
  for (std::size_t i = 0; i < a.size(); ++i) {
    points.push_back(
        {a[i], table.values[*dev][i], run ? table.values[*run][i] : 0.0, table.lines[i]});
  }
  if (run) return points;
  if (options.direction) {
    // One run: its angles must run one way; they are put in the direction's order.
    int sense = 0;
    for (std::size_t i = 1; i < points.size(); ++i) {
      const double step = points[i].angle_deg - points[i - 1].angle_deg;
      const int s = step > 0 ? 1 : (step < 0 ? -1 : 0);
      if (s != 0 && sense != 0 && s != sense) {
        throw DataError(source, points[i].line,
                        fmt::format("the angle turns back here, but --direction {} says the "
                                    "export holds one run; leave --direction out to split it",
                                    direction_name(*options.direction)));
      }
      if (s != 0) sense = s;
    }
    const int wanted = *options.direction == Direction::CCW ? 1 : -1;
    if (sense != 0 && sense != wanted) std::reverse(points.begin(), points.end());
    for (auto& p : points) p.run = 1.0;
    return points;
  }
  // Runs split where the angle turns back (a CCW and a CW run in one file); a point repeated
  // at the turn belongs to the new run, like its first sample.
  double segment = 1.0;
  int sense = 0;
  std::size_t last_moved = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (i > 0) {
      const double step = points[i].angle_deg - points[i - 1].angle_deg;
      const int s = step > 0 ? 1 : (step < 0 ? -1 : 0);
      if (s != 0 && sense != 0 && s != sense) {
        segment += 1.0;
        sense = 0;
        for (std::size_t j = last_moved + 1; j < i; ++j) points[j].run = segment;
      }
      if (s != 0 && sense == 0) sense = s;
      if (s != 0) last_moved = i;
    }
    points[i].run = segment;
  }
  return points;
}

Trace polar_trace(const std::vector<PolarPoint>& points, Plane plane, double radius_mm) {
  const PlaneAxes axes = plane_axes(plane);
  Trace trace;
  trace.columns = {column_name::commanded(axes.first), column_name::commanded(axes.second),
                   column_name::r, column_name::marker, column_name::segment};
  trace.values.assign(trace.columns.size(), {});
  for (const PolarPoint& p : points) {
    const double t = p.angle_deg / kDegPerRad;
    trace.values[0].push_back(radius_mm * std::cos(t));
    trace.values[1].push_back(radius_mm * std::sin(t));
    trace.values[2].push_back(p.deviation_mm);
    trace.values[3].push_back(1.0);
    trace.values[4].push_back(p.run);
    trace.line_of_row.push_back(static_cast<std::uint32_t>(p.line));
  }
  return trace;
}

Trace xy_trace(const Table& table, Plane plane) {
  const PlaneAxes axes = plane_axes(plane);
  Trace trace;
  const auto add = [&](std::string name, std::vector<double> values) {
    trace.columns.push_back(std::move(name));
    trace.values.push_back(std::move(values));
  };
  if (const auto t = table.column(ExportRole::time)) add(column_name::t, table.values[*t]);
  add(column_name::actual(axes.first), table.values[*table.column(ExportRole::position_a)]);
  add(column_name::actual(axes.second), table.values[*table.column(ExportRole::position_b)]);
  if (const auto run = table.column(ExportRole::run)) {
    add(column_name::marker, std::vector<double>(table.lines.size(), 1.0));
    add(column_name::segment, table.values[*run]);
  }
  for (const std::size_t line : table.lines) {
    trace.line_of_row.push_back(static_cast<std::uint32_t>(line));
  }
  return trace;
}

// The columns as a polar export (true) or a position export (false); UsageError (from the
// option) or ParseError (from the title) when they are neither.
bool check_column_set(const std::vector<ExportColumn>& columns, bool from_option,
                      const ExportText& text, const std::string& source,
                      const ExportImportOptions& options) {
  std::array<int, 9> count{};
  for (const auto& c : columns) ++count[static_cast<std::size_t>(c.role)];
  const auto n = [&count](ExportRole r) { return count[static_cast<std::size_t>(r)]; };
  std::vector<std::string> names;
  for (const auto& c : columns) names.push_back(c.name);
  const auto refuse = [&](const std::string& why) {
    const std::string message = fmt::format("columns {}: {}", join(names, ","), why);
    if (from_option) throw UsageError("--columns: " + message);
    throw ParseError(source, text.title ? text.title->number : 0, message);
  };
  for (std::size_t r = 1; r < count.size(); ++r) {
    if (count[r] > 1) refuse("a column other than skip named twice");
  }
  const bool polar = n(ExportRole::angle) > 0;
  const int devs =
      n(ExportRole::deviation) + n(ExportRole::deviation_ccw) + n(ExportRole::deviation_cw);
  if (polar) {
    if (n(ExportRole::position_a) || n(ExportRole::position_b) || n(ExportRole::time)) {
      refuse(
          "an angle and positions or time: expected either angle_* with dev_* (or ccw_*, "
          "cw_*), or t_* with the plane's positions");
    }
    if (devs == 0) refuse("an angle without a deviation column (dev_um, ccw_um or cw_um)");
    if (n(ExportRole::deviation) && devs > 1) refuse("dev_* together with ccw_* or cw_*");
    if (n(ExportRole::run) && n(ExportRole::deviation) == 0) {
      refuse("a run column with ccw_*/cw_* columns, which name the runs themselves");
    }
  } else {
    if (!n(ExportRole::position_a) || !n(ExportRole::position_b)) {
      refuse("expected an angle with its deviations, or both positions of the plane");
    }
    if (devs) refuse("deviations without an angle column");
  }
  if (options.direction && (!polar || n(ExportRole::run) || !n(ExportRole::deviation))) {
    throw UsageError(
        "--direction: only for a polar export of one run with one deviation column (dev_*)");
  }
  if (polar && !options.radius_mm && !text.metadata.find(meta_key::radius_mm)) {
    throw UsageError(
        "--radius: a polar export needs the nominal radius its deviations are taken from");
  }
  return polar;
}

}  // namespace

Trace import_export_text(std::string_view text, const std::string& source,
                         const ExportImportOptions& options) {
  const ExportText parts = split_export(text, source);
  Plane plane = options.plane.value_or(Plane::XY);
  if (const std::string* p = parts.metadata.find(meta_key::plane)) {
    const auto in_file = parse_plane(*p);
    if (!in_file || (options.plane && *options.plane != *in_file)) {
      throw DataError(source, parts.metadata.line_of(meta_key::plane),
                      in_file ? fmt::format("--plane {} disagrees with the export's plane: {}",
                                            plane_name(*options.plane), *p)
                              : fmt::format("plane: expected XY, YZ or ZX, got '{}'", *p));
    }
    plane = *in_file;
  }
  std::vector<ExportColumn> columns = export_columns(parts, source, options, plane);
  const bool polar = check_column_set(columns, options.columns.has_value(), parts, source, options);
  const Table table = read_rows(parts, std::move(columns), source);
  TraceMetadata metadata = import_metadata(parts, source, options, plane, polar);
  Trace trace;
  if (polar) {
    const double radius_mm = *metadata.number(meta_key::radius_mm, source);
    trace = polar_trace(polar_points(table, options, source), plane, radius_mm);
    // The directions the file states, so that the analysis checks the runs it finds.
    std::string directions;
    if (table.column(ExportRole::deviation_ccw)) directions = "CCW";
    if (table.column(ExportRole::deviation_cw)) directions += directions.empty() ? "CW" : ",CW";
    if (options.direction) directions = direction_name(*options.direction);
    if (!directions.empty() && !metadata.find(meta_key::segments) &&
        !metadata.find(meta_key::directions)) {
      metadata.set(meta_key::directions, directions);
    }
    metadata.set(meta_key::centre_mm, "0,0,0");
    metadata.set(meta_key::bar_length_mm, fmt::format("{}", radius_mm));
  } else {
    trace = xy_trace(table, plane);
  }
  trace.source = source;
  trace.metadata = std::move(metadata);
  return trace;
}

}  // namespace circtest
