#pragma once
// The names written into traces and read back (docs/trace-format.md): column names and
// metadata keys, spelled once. circgen's program header, circlog-record, the trace writer,
// circana and the test simulator all use these, so a rename cannot split writer and reader.
#include <string>
#include <string_view>

namespace circtest {

namespace column_name {
inline constexpr const char* t = "t";              // time of the sample, s
inline constexpr const char* period = "period";    // circlog's servo period counter
inline constexpr const char* marker = "marker";    // 1 while a measured arc runs
inline constexpr const char* segment = "segment";  // id of the run (M67), 0 = idle
inline constexpr const char* x = "x";              // actual positions, mm
inline constexpr const char* y = "y";
inline constexpr const char* z = "z";
inline constexpr const char* r = "r";  // radial deviation (ballbar import), mm
inline constexpr const char* commanded_suffix = "_cmd";
// The actual-position column of an axis letter ('x' -> "x").
inline std::string actual(char axis) {
  return std::string(1, axis);
}
// The commanded-position column of an axis letter ('x' -> "x_cmd").
inline std::string commanded(char axis) {
  return actual(axis) + commanded_suffix;
}
// The motor (encoder) feedback column of an axis letter ('x' -> "x_fb"): joint.N.motor-pos-fb.
inline constexpr const char* feedback_suffix = "_fb";
inline std::string feedback(char axis) {
  return actual(axis) + feedback_suffix;
}
// The position column circana computes from a radial trace's `r` ('x' -> "x_r").
inline constexpr const char* from_radial_suffix = "_r";
inline std::string from_radial(char axis) {
  return actual(axis) + from_radial_suffix;
}
// Columns the trace formats store as integers.
inline bool is_integer(std::string_view name) {
  return name == marker || name == segment || name == period;
}
}  // namespace column_name

namespace meta_key {
// The test (circgen's program header, copied into the trace by the recorder).
inline constexpr const char* generator = "generator";
inline constexpr const char* date = "date";
inline constexpr const char* test = "test";
inline constexpr const char* plane = "plane";
inline constexpr const char* axes = "axes";
inline constexpr const char* units = "units";
inline constexpr const char* diameter_mm = "diameter_mm";
inline constexpr const char* radius_mm = "radius_mm";
inline constexpr const char* centre_mm = "centre_mm";
// The centre in machine coordinates (circgen, when it knows the work offset's origin).
inline constexpr const char* centre_machine_mm = "centre_machine_mm";
inline constexpr const char* feed_mm_per_min = "feed_mm_per_min";
inline constexpr const char* feeds_mm_per_min = "feeds_mm_per_min";
// The same in inches, beside the mm keys when the program is in inches (G20).
inline constexpr const char* diameter_in = "diameter_in";
inline constexpr const char* radius_in = "radius_in";
inline constexpr const char* centre_in = "centre_in";
inline constexpr const char* feed_in_per_min = "feed_in_per_min";
inline constexpr const char* feeds_in_per_min = "feeds_in_per_min";
inline constexpr const char* directions = "directions";
inline constexpr const char* direction_labels = "direction_labels";
inline constexpr const char* arc_deg = "arc_deg";
inline constexpr const char* start_deg = "start_deg";
inline constexpr const char* lead_deg = "lead_deg";
inline constexpr const char* dwell_s = "dwell_s";
inline constexpr const char* marker_output = "marker_output";
inline constexpr const char* segment_output = "segment_output";
inline constexpr const char* segments = "segments";
inline constexpr const char* ini = "ini";                  // the machine's INI file
inline constexpr const char* ini_checked = "ini_checked";  // the limits circgen checked
// A ballbar's bar length (radial traces): the radius its deviations are about.
inline constexpr const char* bar_length_mm = "bar_length_mm";
inline constexpr const char* imported_from = "imported_from";  // the polar file of a ballbar
// Conditions of clause 4.4 (given by the operator or the program).
inline constexpr const char* machine = "machine";
inline constexpr const char* machine_serial = "machine_serial";
inline constexpr const char* instrument = "instrument";
inline constexpr const char* operator_name = "operator";
inline constexpr const char* location = "location";
inline constexpr const char* notes = "notes";
inline constexpr const char* temperature_air_C = "temperature_air_C";
inline constexpr const char* temperature_machine_C = "temperature_machine_C";
inline constexpr const char* temperature_instrument_C = "temperature_instrument_C";
inline constexpr const char* expansion_machine_per_K = "expansion_machine_per_K";
inline constexpr const char* expansion_instrument_per_K = "expansion_instrument_per_K";
inline constexpr const char* compensation = "compensation";
inline constexpr const char* other_axes = "other_axes";
// Written by the recorder (circlog-record).
inline constexpr const char* recorder = "recorder";
inline constexpr const char* source = "source";
inline constexpr const char* sample_period_s = "sample_period_s";
inline constexpr const char* start_time = "start_time";
inline constexpr const char* start_period = "start_period";
inline constexpr const char* channels = "channels";
inline constexpr const char* channel_prefix = "channel.";  // "channel.<name>": what it is
inline constexpr const char* module = "module";
inline constexpr const char* module_channels = "module.channels";
inline constexpr const char* module_depth = "module.depth";
inline constexpr const char* program = "program";
inline constexpr const char* ini_sha256 = "ini_sha256";  // of the INI file at the start
// The recorder's trailer, known only at the end of a recording.
inline constexpr const char* rows = "rows";
inline constexpr const char* runs = "runs";
inline constexpr const char* end_period = "end_period";
inline constexpr const char* overruns = "overruns";
inline constexpr const char* gaps = "gaps";
inline constexpr const char* lost_samples = "lost_samples";
inline constexpr const char* ring_high_water = "ring_high_water";
inline constexpr const char* stop_reason = "stop_reason";
}  // namespace meta_key

}  // namespace circtest
