#pragma once
// Data in from other instruments and out to them (docs/circana.md "Import"): the text or CSV
// exports of ballbar software (an angle and the radial deviation, per direction) and of grid
// encoder software (time-stamped X/Y), read into a trace that circana analyze, diagnose and
// report and circcomp take like a logged one; and the polar export of an evaluated trace.
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "circtest/analysis/evaluation.hpp"
#include "circtest/core/plane.hpp"
#include "circtest/core/trace.hpp"

namespace circtest {

// What one column of an export holds. Values are converted to deg (angle), mm (deviations,
// positions) or s (time).
enum class ExportRole {
  skip,           // any text, not read
  angle,          // deg from the plane's first axis toward its second
  deviation,      // radial deviation from the nominal radius
  deviation_ccw,  // the same, of the CCW run, on the row's angle
  deviation_cw,   // the same, of the CW run
  run,            // the run's id, a whole number from 1
  time,           // time stamp
  position_a,     // the plane's first axis (x for XY)
  position_b,     // its second axis
};

struct ExportColumn {
  ExportRole role = ExportRole::skip;
  double scale = 1.0;  // to deg, mm or s
  std::string name;    // as --columns spells it: "angle_deg", "dev_um", "x_mm", "skip"
};

// The names --columns takes (and a title row is read as): angle_deg, angle_rad, dev_um,
// dev_mm, dev_nm, ccw_um, cw_um (and _mm, _nm), run, t_s, t_ms, the plane's axis letters
// with _mm or _um (x_mm, y_um), skip.
std::vector<std::string> export_column_names(Plane plane);
// One name; nullopt when it is none of export_column_names(plane).
std::optional<ExportColumn> parse_export_column(std::string_view name, Plane plane);
// "angle_deg,dev_um": throws UsageError naming the bad item, with the closest known name.
std::vector<ExportColumn> parse_export_columns(std::string_view list, Plane plane);

// What the command line says about an import. Each item, when set, must agree with what a
// circana export-polar file states about itself (else DataError naming its line).
struct ExportImportOptions {
  std::optional<Plane> plane;  // default: the file's, else XY
  // --columns as given ("angle_deg,dev_um"), read for the plane once it is settled;
  // default: the title row's.
  std::optional<std::string> columns;
  std::optional<double> radius_mm;  // polar: required unless the file has it
  std::optional<double> feed_mm_per_min;
  std::optional<Direction> direction;  // a polar export of one run with one deviation column
  std::string date;                    // canonical_utc_iso8601
  // --ini: the keys record_ini_provenance (core/sha256.hpp) wrote for the machine's INI.
  std::optional<TraceMetadata> ini_provenance;
  std::string instrument;  // what measured it; a default says it is not named
};

// The instrument named when --instrument is not given.
inline constexpr const char* kUnnamedRadialInstrument =
    "radial instrument (polar export; not named: give --instrument)";
inline constexpr const char* kUnnamedXyInstrument =
    "X/Y instrument (position export; not named: give --instrument)";
// The first metadata line of circana export-polar: its `# key: value` lines are the test's.
inline constexpr const char* kExportedByKey = "exported_by";
inline constexpr const char* kExportedByPolar = "circana export-polar";

// Bounds of the values of an export: beyond them a number sizes the trace, not a test.
inline constexpr double kMaxPolarAngleDeg = 3600.0;       // as a trace's start_deg
inline constexpr double kMaxPolarDeviationUm = 10'000.0;  // a ballbar's range is a few mm
inline constexpr double kMaxExportPositionMm = 100'000.0;
inline constexpr double kMaxExportTimeS = 1e10;

// Reads an export (its whole text) into a trace ready to write: a polar export as a radial
// trace (commanded columns on the nominal circle about 0,0, `r` the deviation,
// bar_length_mm the radius, marker 1, one segment per run), a position export with `t` and
// the plane's actual columns. Throws ParseError "source:line: ..." for a bad row or title,
// UsageError for --columns that do not fit the file, DataError when an option and the file
// disagree, IoError for the INI.
Trace import_export_text(std::string_view text, const std::string& source,
                         const ExportImportOptions& options);

// The polar export of an evaluated trace: per measured run the angle about the centre
// (nominal, else the first run's least-squares centre) and the deviation from the radius
// (nominal, else that run's), in time order, with the run's id; the test's metadata (plane,
// radius, feeds, runs announced, date, INI fingerprint, conditions) as `# key: value` lines
// that import_export_text reads back.
std::string polar_export_text(const Trace& trace, const Evaluation& evaluation);

}  // namespace circtest
