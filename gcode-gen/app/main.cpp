// circgen: writes the ISO 230-4 circular test program for LinuxCNC. Only option parsing
// lives here; the command (circtest/gcode/commands.hpp) writes the program.
#include <fmt/format.h>
#include <boost/program_options.hpp>

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <iostream>
#include <string>
#include <utility>

#include "circtest/core/cli.hpp"
#include "circtest/core/cli_options.hpp"
#include "circtest/core/error.hpp"
#include "circtest/core/numbers.hpp"
#include "circtest/core/utc_time.hpp"
#include "circtest/gcode/annex_c.hpp"
#include "circtest/gcode/commands.hpp"
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
    ("plane", po::value<std::string>()->default_value("XY"), "XY (G17), YZ (G19) or ZX (G18)")
    ("centre", po::value<std::string>(), "circle centre X,Y,Z in the active work offset (0,0,0)")
    ("center", po::value<std::string>(), "same as --centre")
    ("safe-z", po::value<std::string>(),
     "clearance position on the plane's normal axis (Z for XY); approach and leave through it")
    ("dir", po::value<std::string>()->default_value("both"), "both (CCW then CW), ccw or cw")
    ("arc", po::value<std::string>(),
     "measured arc, 90..360 deg (default 360; ballbar in YZ/ZX: 180)")
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

// Plane and centre.
void set_plane(CircleTestSpec& spec, const po::variables_map& vm, double mm) {
  auto text = [&vm](const char* name) { return opt_text(vm, name); };
  auto number = [&vm](const char* name) { return opt_number(vm, name); };
  const auto plane = parse_plane(text("plane"));
  if (!plane) {
    const std::string given = text("plane");
    const bool xz = given == "XZ" || given == "xz" || given == "Xz" || given == "xZ";
    // G18's positive sense runs from +Z toward +X; "XZ" would suggest the opposite.
    throw UsageError(fmt::format("--plane: '{}' is not XY, YZ or ZX{}", given,
                                 xz ? " (for G18 use ZX: CCW runs from +Z toward +X)" : ""));
  }
  spec.plane = *plane;

  if (vm.count("centre") && vm.count("center")) throw UsageError("give --centre only once");
  const char* centre_name = vm.count("center") ? "center" : "centre";
  if (vm.count(centre_name)) {
    const auto c = parse_option_list(std::string("--") + centre_name, text(centre_name), 3);
    for (int i = 0; i < 3; ++i) spec.centre_mm[i] = c[i] * mm;
  }
  if (vm.count("safe-z")) spec.safe_mm = number("safe-z") * mm;
}

// Directions, instrument, arcs, feeds of the moves around the runs, outputs, offsets; returns
// the work offset origin in machine coordinates.
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
  const bool vertical = spec.plane != Plane::XY;
  // A ballbar's centre pivot sits on the table: in a vertical plane it runs the usual 220 deg
  // (180 deg of data and 20 deg overshoot each end) over the top instead of a full circle.
  spec.arc_deg = vm.count("arc") ? number("arc") : (ballbar && vertical ? 180.0 : 360.0);
  spec.start_deg =
      vm.count("start") ? number("start") : default_start_deg(spec.plane, spec.arc_deg);
  spec.lead_deg =
      vm.count("lead") ? number("lead") : (ballbar ? kBallbarDefaultOvershootDeg : 10.0);
  if (vm.count("approach-feed")) spec.approach_feed_mm_per_min = number("approach-feed") * mm;
  if (vm.count("feed-in")) {
    if (!ballbar) throw UsageError("--feed-in is only used with --instrument ballbar");
    spec.feed_in_mm = number("feed-in") * mm;
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
    for (double v : offset) check_plausible(plausible::offset, v, circgen_option_words);
    spec.work_offset_mm = offset;
  }
  return offset;
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
  set_plane(spec, vm, mm);
  const std::array<double, 3> offset = set_path(spec, vm, mm);
  GenerateRequest request;
  request.spec = std::move(spec);
  if (vm.count("ini")) request.ini_path = opt_text(vm, "ini");
  request.work_offset_origin_mm = offset;
  if (vm.count("output")) request.output_path = opt_text(vm, "output");
  return run_generate(std::move(request), std::cout, std::cerr);
}

}  // namespace

int main(int argc, char** argv) {
  return run_cli("circgen", [&] { return run(argc, argv); });
}
