// circgen: writes the ISO 230-4 circular test program for LinuxCNC. Only option parsing
// lives here; the command (circtest/circgen/commands.hpp) writes the program.
#include <fmt/format.h>
#include <boost/program_options.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <iostream>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "circtest/circgen/commands.hpp"
#include "circtest/core/cli.hpp"
#include "circtest/core/cli_options.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/utc_time.hpp"
#include "circtest/gcode/annex_c.hpp"
#include "circtest/gcode/generator.hpp"
#include "circtest/gcode/plausible_ranges.hpp"

namespace po = boost::program_options;
using namespace circtest;

namespace {

// SOURCE_DATE_EPOCH makes the output reproducible (reproducible-builds.org convention).
std::string header_date() {
  if (const char* epoch = std::getenv("SOURCE_DATE_EPOCH")) {
    // Whole seconds up to the end of year 9999, the last date ISO 8601 writes in 4 digits.
    constexpr double kLastSecond = 253402300799.0;
    const double seconds = parse_option_number("SOURCE_DATE_EPOCH", epoch);
    if (!(seconds >= 0.0 && seconds <= kLastSecond) || seconds != std::floor(seconds)) {
      throw UsageError(fmt::format(
          "SOURCE_DATE_EPOCH: expected whole seconds since 1970 in 0..{:.0f} (year 9999), got '{}'",
          kLastSecond, epoch));
    }
    return utc_iso8601({static_cast<std::time_t>(seconds), 0});
  }
  return utc_now_iso8601();
}

std::string opt_text(const po::variables_map& vm, const char* name) {
  return vm[name].as<std::string>();
}

double opt_number(const po::variables_map& vm, const char* name) {
  return parse_option_number(std::string("--") + name, opt_text(vm, name));
}

po::options_description circgen_options() {
  po::options_description options(
      "circgen: ISO 230-4 / JIS B 6194 circular test program for LinuxCNC\n"
      "usage: circgen --d MM --f MM_PER_MIN [options] > test.ngc\n\noptions");
  // clang-format off
  options.add_options()
    ("help,h", "this text")
    ("version", "print the version")
    ("d", po::value<std::string>(), "circle diameter (mm, or inch with --inch)")
    ("r", po::value<std::string>(), "circle radius, instead of --d")
    ("f", po::value<std::string>(), "feed per minute")
    ("feeds", po::value<std::string>(), "feed sweep F1,F2,...: one run pair per feed")
    ("ref-d", po::value<std::string>(), "Annex C reference diameter D2 (with --ref-f)")
    ("ref-f", po::value<std::string>(), "Annex C reference feed V2: feed = V2*sqrt(D/D2)")
    ("plane", po::value<std::string>()->default_value("XY"),
     "XY (G17), YZ (G19) or ZX (G18); several, e.g. XY,YZ,ZX: a test set in one program")
    ("centre", po::value<std::string>(), "circle centre X,Y,Z in the active work offset (0,0,0)")
    ("center", po::value<std::string>(), "same as --centre")
    ("clearance", po::value<std::string>(),
     "clearance position on the plane's normal axis (Z for XY, X for YZ, Y for ZX), one or one "
     "per plane; approach and leave through it (ballbar default: 50 mm beyond the centre)")
    ("safe-z", po::value<std::string>(), "same as --clearance")
    ("floor", po::value<std::string>(),
     "lowest Z the tool may reach in the work offset (e.g. the table top plus a margin)")
    ("dir", po::value<std::string>()->default_value("both"), "both (CCW then CW), ccw or cw")
    ("arc", po::value<std::string>(),
     "total angle travelled, overshoot (--lead) included: data arc + 2 x lead, the data arc "
     "90..360 deg (default a 360 deg data arc; ballbar in YZ/ZX: 220 = 180 + 2 x 20)")
    ("start", po::value<std::string>(),
     "start angle, deg from the plane's first axis toward its second (default 0; a partial "
     "arc in YZ/ZX: centred on top)")
    ("lead", po::value<std::string>(),
     "lead-in and lead-out (ballbar: overshoot) arcs, deg (default 10; ballbar 20)")
    ("instrument", po::value<std::string>()->default_value("encoder"),
     "encoder, grid or ballbar: pauses and moves around the runs")
    ("approach-feed", po::value<std::string>(),
     "feed of the descent to the circle and of ballbar feed-in/out (default min(200 mm/min, "
     "half the lowest feed))")
    ("feed-in", po::value<std::string>(),
     "ballbar radial feed-in/out, outside the circle (default 1.5 mm)")
    ("ballbar-lengths", po::value<std::string>(),
     "the ballbar's lengths, mm (default 50,100,150,300): the radius must be one of them")
    ("dwell", po::value<std::string>()->default_value("0"),
     "pause where the direction reverses, s (at most 2)")
    ("inch", "program in inch (G20); lengths and feeds given in inch")
    ("marker", po::value<std::string>()->default_value("0"), "digital output for M62/M63")
    ("segment-out", po::value<std::string>()->default_value("0"), "analog output for M67 ids")
    ("ini", po::value<std::string>(), "LinuxCNC INI file: refuse a test beyond its limits")
    ("work-offset", po::value<std::string>(),
     "select this work offset (G54..G59.3) in the program (default: the one in use)")
    ("tool", po::value<std::string>(),
     "apply this tool's length offset with G43 H<n> (default: the one in use)")
    ("offset", po::value<std::string>(),
     "work offset origin X,Y,Z in machine coordinates: the --ini check and the header's "
     "centre_machine_mm (0,0,0 with --ini)")
    ("offset-from-linuxcnc",
     "--offset is the origin the running LinuxCNC uses: not refused when the parameter file "
     "(written when LinuxCNC exits) differs")
    ("output,o", po::value<std::string>(), "write the program to FILE (atomically)");
  // clang-format on
  return options;
}

// --d or --r, as the diameter in the program's units (mm, or inch with --inch).
double diameter_of(const po::variables_map& vm, double mm) {
  auto text = [&vm](const char* name) { return opt_text(vm, name); };
  auto number = [&vm](const char* name) { return opt_number(vm, name); };
  if (vm.count("d") && vm.count("r")) throw UsageError("give --d or --r, not both");
  if (!vm.count("d") && !vm.count("r")) throw UsageError("missing --d (diameter) or --r (radius)");
  const double diameter = vm.count("d") ? number("d") : 2.0 * number("r");
  if (!std::isfinite(diameter)) {  // twice a radius near the largest double
    throw UsageError(
        fmt::format("--r: a radius of {} is outside the plausible range {:.4g}..{:.4g} {}",
                    text("r"), plausible::diameter.min / 2.0 / mm,
                    plausible::diameter.max / 2.0 / mm, vm.count("inch") ? "in" : "mm"));
  }
  if (diameter <= 0.0) {
    throw UsageError(fmt::format("--{}: the circle must be larger than 0, got {}",
                                 vm.count("d") ? "d" : "r", text(vm.count("d") ? "d" : "r")));
  }
  return diameter;
}

// --f, --feeds or Annex C's --ref-d/--ref-f, in mm/min.
void set_feeds(CircleTestSpec& spec, const po::variables_map& vm, double diameter, double mm) {
  auto text = [&vm](const char* name) { return opt_text(vm, name); };
  auto number = [&vm](const char* name) { return opt_number(vm, name); };
  const int feed_sources = static_cast<int>(vm.count("f") + vm.count("feeds")) +
                           ((vm.count("ref-d") || vm.count("ref-f")) ? 1 : 0);
  if (feed_sources == 0) throw UsageError("missing --f (feed), --feeds or --ref-d/--ref-f");
  if (feed_sources > 1) throw UsageError("give one of --f, --feeds or --ref-d/--ref-f");
  std::vector<double> feeds;
  if (vm.count("f")) feeds.push_back(number("f"));
  if (vm.count("feeds")) feeds = parse_option_list("--feeds", text("feeds"));
  if (vm.count("ref-d") || vm.count("ref-f")) {
    if (!vm.count("ref-d") || !vm.count("ref-f")) {
      throw UsageError("Annex C needs both --ref-d D2 and --ref-f V2");
    }
    const AnnexCNote note =
        annex_c_note(diameter, number("ref-d"), number("ref-f"), spec.units, circgen_option_words);
    feeds.push_back(note.scaled_feed);
    spec.annex_c = note;
  }
  for (double f : feeds) {
    if (f <= 0.0) {
      throw UsageError(fmt::format("--{}: a feed must be positive, got {}",
                                   vm.count("feeds") ? "feeds" : "f", f));
    }
    spec.feeds_mm_per_min.push_back(f * mm);
  }
}

// --plane: one plane or a set, in program order.
std::vector<Plane> planes_of(const po::variables_map& vm) {
  std::vector<Plane> planes;
  const std::string given = opt_text(vm, "plane");
  std::size_t pos = 0;
  while (pos <= given.size()) {
    const std::size_t comma = std::min(given.find(',', pos), given.size());
    const std::string item = given.substr(pos, comma - pos);
    pos = comma + 1;
    const auto plane = parse_plane(item);
    if (!plane) {
      const bool xz = item == "XZ" || item == "xz" || item == "Xz" || item == "xZ";
      // G18's positive sense runs from +Z toward +X; "XZ" would suggest the opposite.
      throw UsageError(fmt::format("--plane: '{}' is not XY, YZ or ZX{}", item,
                                   xz ? " (for G18 use ZX: CCW runs from +Z toward +X)" : ""));
    }
    if (std::find(planes.begin(), planes.end(), *plane) != planes.end()) {
      throw UsageError(fmt::format("--plane: {} is given twice in '{}'", item, given));
    }
    planes.push_back(*plane);
  }
  return planes;
}

// The centre and the floor, shared by every plane.
void set_centre(CircleTestSpec& spec, const po::variables_map& vm, double mm) {
  auto text = [&vm](const char* name) { return opt_text(vm, name); };
  if (vm.count("centre") && vm.count("center")) throw UsageError("give --centre only once");
  const char* centre_name = vm.count("center") ? "center" : "centre";
  if (vm.count(centre_name)) {
    const auto c = parse_option_list(std::string("--") + centre_name, text(centre_name), 3);
    for (int i = 0; i < 3; ++i) spec.centre_mm[i] = c[i] * mm;
  }
  if (vm.count("floor")) spec.floor_mm = opt_number(vm, "floor") * mm;
}

// --clearance (or --safe-z): one position for every plane, or one per plane.
std::vector<std::optional<double>> clearances_of(const po::variables_map& vm, std::size_t planes,
                                                 double mm) {
  if (vm.count("clearance") && vm.count("safe-z"))
    throw UsageError("give --clearance or its alias --safe-z, not both");
  const char* name = vm.count("safe-z") ? "safe-z" : "clearance";
  std::vector<std::optional<double>> out(planes);
  if (!vm.count(name)) return out;
  const std::string option = std::string("--") + name;
  std::vector<double> values = parse_option_list(option, opt_text(vm, name));
  if (values.size() == 1) values.resize(planes, values.front());
  if (values.size() != planes) {
    throw UsageError(fmt::format("{}: {} positions for {} planes: give one, or one per plane",
                                 option, values.size(), planes));
  }
  for (std::size_t k = 0; k < planes; ++k) out[k] = values[k] * mm;
  return out;
}

// Directions, instrument, the moves around the runs, outputs, offsets, shared by every
// plane; returns the work offset origin in machine coordinates.
std::array<double, 3> set_path(CircleTestSpec& spec, const po::variables_map& vm, double mm) {
  auto text = [&vm](const char* name) { return opt_text(vm, name); };
  auto number = [&vm](const char* name) { return opt_number(vm, name); };
  const std::string dir = text("dir");
  if (dir == "both") {
    spec.directions = {Direction::CCW, Direction::CW};
  } else if (const auto d = parse_direction(dir)) {
    spec.directions = {*d};
  } else {
    throw UsageError(fmt::format("--dir: '{}' is not both, ccw or cw", dir));
  }
  const auto instrument = parse_instrument(text("instrument"));
  if (!instrument) {
    throw UsageError(
        fmt::format("--instrument: '{}' is not encoder, grid or ballbar", text("instrument")));
  }
  spec.instrument = *instrument;
  const bool ballbar = spec.instrument == Instrument::ballbar;
  spec.lead_deg =
      vm.count("lead") ? number("lead") : (ballbar ? kBallbarDefaultOvershootDeg : 10.0);
  if (vm.count("approach-feed")) spec.approach_feed_mm_per_min = number("approach-feed") * mm;
  if (vm.count("feed-in")) {
    if (!ballbar) throw UsageError("--feed-in is only used with --instrument ballbar");
    spec.feed_in_mm = number("feed-in") * mm;
  }
  if (vm.count("ballbar-lengths")) {
    if (!ballbar) throw UsageError("--ballbar-lengths is only used with --instrument ballbar");
    // Bar lengths are in mm whatever the program units: that is how bars are sold.
    spec.ballbar_lengths_mm = parse_option_list("--ballbar-lengths", text("ballbar-lengths"));
  }
  spec.dwell_s = number("dwell");
  spec.marker_output = parse_option_index("--marker", text("marker"));
  spec.segment_output = parse_option_index("--segment-out", text("segment-out"));
  if (vm.count("work-offset")) {
    std::string code = text("work-offset");
    for (char& c : code) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    spec.work_offset_code = code;
  }
  if (vm.count("tool")) spec.tool_length_offset = parse_option_index("--tool", text("tool"));
  spec.date = header_date();
  std::array<double, 3> offset{0.0, 0.0, 0.0};
  if (vm.count("offset")) {
    const auto o = parse_option_list("--offset", text("offset"), 3);
    for (int i = 0; i < 3; ++i) offset[i] = o[i] * mm;
    spec.work_offset_mm = offset;
  }
  return offset;
}

// The data arc from --arc, the total angle travelled: 360 deg of data without --arc, and a
// ballbar's usual 220 deg in all over the top of a vertical plane.
double data_arc_deg(const CircleTestSpec& spec, const po::variables_map& vm) {
  const bool vertical = spec.plane != Plane::XY;
  if (!vm.count("arc")) {
    return spec.instrument == Instrument::ballbar && vertical
               ? kBallbarVerticalTotalArcDeg - 2.0 * spec.lead_deg
               : 360.0;
  }
  // Degrees without float noise: 379.9999 - 2 x 10 is 359.9999, not 359.99989999999997.
  auto deg = [](double v) { return std::abs(v) < 1e9 ? std::round(v * 1e9) / 1e9 : v; };
  const double total = opt_number(vm, "arc");
  const double data = deg(total - 2.0 * spec.lead_deg);
  if (std::isfinite(total) && std::isfinite(spec.lead_deg) && !(data >= 90.0 && data <= 360.0)) {
    throw UsageError(fmt::format(
        "--arc: {} deg is the total angle travelled; less 2 x {} deg overshoot (--lead) it leaves "
        "{} deg of data, and the data arc must be 90..360 deg (ISO 230-4 clause 3.1): give --arc "
        "{}..{}",
        opt_text(vm, "arc"), spec.lead_deg, data, deg(90.0 + 2.0 * spec.lead_deg),
        deg(360.0 + 2.0 * spec.lead_deg)));
  }
  return data;
}

// One spec per plane of --plane: the shared spec with the plane's own arc, start and
// clearance.
std::vector<CircleTestSpec> plane_specs(const CircleTestSpec& shared, const po::variables_map& vm,
                                        double mm) {
  const std::vector<Plane> planes = planes_of(vm);
  const std::vector<std::optional<double>> clearances = clearances_of(vm, planes.size(), mm);
  const bool ballbar = shared.instrument == Instrument::ballbar;
  if (planes.size() > 1 && !ballbar && !clearances.front()) {
    throw UsageError(fmt::format(
        "--plane {}: a test set moves from plane to plane between its pauses; give --clearance "
        "(one position on the normal axes, or one per plane)",
        opt_text(vm, "plane")));
  }
  std::vector<CircleTestSpec> specs;
  for (std::size_t k = 0; k < planes.size(); ++k) {
    CircleTestSpec spec = shared;
    spec.plane = planes[k];
    spec.arc_deg = data_arc_deg(spec, vm);
    spec.start_deg =
        vm.count("start") ? opt_number(vm, "start") : default_start_deg(spec.plane, spec.arc_deg);
    spec.safe_mm = clearances[k];
    if (!spec.safe_mm && ballbar) spec.safe_mm = ballbar_default_clearance_mm(spec);
    specs.push_back(std::move(spec));
  }
  return specs;
}

int run(int argc, char** argv) {
  const po::options_description options = circgen_options();
  po::variables_map vm;
  try {
    const int style =
        po::command_line_style::default_style & ~po::command_line_style::allow_guessing;
    refuse_option_placeholders(argc, argv);
    po::store(po::command_line_parser(argc, argv).options(options).style(style).run(), vm);
    po::notify(vm);
  } catch (const po::error& e) {
    throw option_usage_error(e, options);
  }
  if (vm.count("help")) {
    std::cout << options << '\n';
    return 0;
  }
  if (vm.count("version")) {
    std::cout << generator_version() << '\n';
    return 0;
  }
  CircleTestSpec spec;
  spec.units = vm.count("inch") ? LengthUnit::inch : LengthUnit::mm;
  const double mm = spec.units == LengthUnit::inch ? kMmPerInch : 1.0;
  const double diameter = diameter_of(vm, mm);
  spec.radius_mm = diameter / 2.0 * mm;
  set_feeds(spec, vm, diameter, mm);
  set_centre(spec, vm, mm);
  const std::array<double, 3> offset = set_path(spec, vm, mm);
  GenerateRequest request;
  request.planes = plane_specs(spec, vm, mm);
  if (vm.count("ini")) request.ini_path = opt_text(vm, "ini");
  request.work_offset_origin_mm = offset;
  request.offset_from_linuxcnc = vm.count("offset-from-linuxcnc") > 0;
  if (vm.count("output")) request.output_path = opt_text(vm, "output");
  return run_generate(std::move(request), std::cout, std::cerr);
}

}  // namespace

int main(int argc, char** argv) {
  return run_cli("circgen", [&] { return run(argc, argv); });
}
