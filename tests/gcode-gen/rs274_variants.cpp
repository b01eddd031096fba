// The circgen variants the rs274 tests run, and their shared helpers (rs274_variants.hpp).
#include "rs274_variants.hpp"

#include <algorithm>
#include <cmath>

namespace circtest::testing {
namespace {

const Direction CCW = Direction::CCW;
const Direction CW = Direction::CW;

// The encoder programs: planes, directions, partial arcs, sweeps, inch, Annex C.
std::vector<Variant> encoder_variants() {
  return {
      {"default_xy", {"--d", "150", "--f", "300"}, Plane::XY, 75, {0, 0, 0}, {300}, {CCW, CW}},
      {"xy_ccw_centre_start_safe",
       {"--d", "80", "--f", "1000", "--dir", "ccw", "--centre", "10,-20,5", "--start", "30",
        "--safe-z", "50"},
       Plane::XY,
       40,
       {10, -20, 5},
       {1000},
       {CCW},
       360,
       30},
      {"xy_cw", {"--f", "600", "--dir", "cw", "--r", "50"}, Plane::XY, 50, {0, 0, 0}, {600}, {CW}},
      {"yz_both",
       {"--plane", "YZ", "--d", "100", "--f", "500", "--centre", "0,50,-30"},
       Plane::YZ,
       50,
       {0, 50, -30},
       {500},
       {CCW, CW}},
      {"zx_both_safe",
       {"--plane", "ZX", "--d", "100", "--f", "500", "--centre", "5,0,-40", "--safe-z", "20"},
       Plane::ZX,
       50,
       {5, 0, -40},
       {500},
       {CCW, CW}},
      {"zx_partial_180",
       {"--plane", "zx", "--d", "120", "--f", "400", "--arc", "220", "--lead", "20"},
       Plane::ZX,
       60,
       {0, 0, 0},
       {400},
       {CCW, CW},
       180,
       270,  // a partial arc in ZX is centred on top (+Z) by default
       20},
      {"yz_partial_90_cw_sweep",
       {"--plane", "YZ", "--d", "100", "--arc", "110", "--start", "45", "--dir", "cw", "--feeds",
        "100,200"},
       Plane::YZ,
       50,
       {0, 0, 0},
       {100, 200},
       {CW},
       90,
       45},
      {"xy_sweep_dwell",
       {"--d", "50", "--feeds", "200,500,1000", "--lead", "30", "--dwell", "0.2"},
       Plane::XY,
       25,
       {0, 0, 0},
       {200, 500, 1000},
       {CCW, CW},
       360,
       0,
       30},
      {"xy_partial_270_ccw_sweep_outputs",
       {"--d", "60", "--arc", "290", "--start", "90", "--dir", "ccw", "--feeds", "300,600",
        "--marker", "2", "--segment-out", "3"},
       Plane::XY,
       30,
       {0, 0, 0},
       {300, 600},
       {CCW},
       270,
       90,
       10,
       "mm",
       2,
       3},
      {"inch",
       {"--inch", "--d", "4", "--f", "20", "--centre", "1,2,0.5", "--safe-z", "1.5"},
       Plane::XY,
       2,
       {1, 2, 0.5},
       {20},
       {CCW, CW},
       360,
       0,
       10,
       "inch"},
      {"inch_zx_partial",
       {"--inch", "--plane", "ZX", "--d", "3", "--f", "15", "--arc", "140", "--start", "-30"},
       Plane::ZX,
       1.5,
       {0, 0, 0},
       {15},
       {CCW, CW},
       120,
       330,
       10,
       "inch"},
      {"annex_c",
       {"--d", "125", "--ref-d", "100", "--ref-f", "500"},
       Plane::XY,
       62.5,
       {0, 0, 0},
       {559},
       {CCW, CW}},
  };
}

// The ballbar's and the grid's programs, and the offsets a program may set.
std::vector<Variant> instrument_variants() {
  return {
      {"ballbar_xy_safe",
       {"--instrument", "ballbar", "--d", "200", "--f", "1000", "--centre", "10,20,-50", "--safe-z",
        "30"},
       Plane::XY,
       100,
       {10, 20, -50},
       {1000},
       {CCW, CW},
       360,
       0,
       20},
      {"ballbar_xy_ccw_sweep_feed_in_approach",
       {"--instrument", "ballbar", "--d", "150", "--feeds", "500,1000", "--dir", "ccw", "--feed-in",
        "2", "--approach-feed", "120", "--start", "45", "--ballbar-lengths", "75,150"},
       Plane::XY,
       75,
       {0, 0, 0},
       {500, 1000},
       {CCW},
       360,
       45,
       20},
      {"ballbar_yz_default_top",
       {"--instrument", "ballbar", "--plane", "YZ", "--d", "300", "--f", "800", "--centre",
        "0,0,100", "--safe-z", "50"},
       Plane::YZ,
       150,
       {0, 0, 100},
       {800},
       {CCW, CW},
       180,
       0,
       20},
      {"ballbar_zx_partial_cw_sweep",
       {"--instrument", "ballbar", "--plane", "ZX", "--d", "200", "--feeds", "300,600", "--dir",
        "cw"},
       Plane::ZX,
       100,
       {0, 0, 0},
       {300, 600},
       {CW},
       180,
       270,
       20},
      {"ballbar_inch_xy",
       {"--instrument", "ballbar", "--inch", "--d", "7.874", "--f", "40", "--safe-z", "2"},
       Plane::XY,
       3.937,
       {0, 0, 0},
       {40},
       {CCW, CW},
       360,
       0,
       20,
       "inch"},
      {"grid_xy_safe",
       {"--instrument", "grid", "--d", "140", "--f", "2000", "--safe-z", "5", "--approach-feed",
        "300"},
       Plane::XY,
       70,
       {0, 0, 0},
       {2000},
       {CCW, CW}},
      {"grid_yz_partial",
       {"--instrument", "grid", "--plane", "YZ", "--d", "100", "--f", "1000", "--arc", "220"},
       Plane::YZ,
       50,
       {0, 0, 0},
       {1000},
       {CCW, CW},
       200,
       350},
      {"xy_work_offset_and_tool",
       {"--d", "100", "--f", "600", "--work-offset", "G55", "--tool", "3"},
       Plane::XY,
       50,
       {0, 0, 0},
       {600},
       {CCW, CW}},
      {"ballbar_zx_safe_tool",
       {"--instrument", "ballbar", "--plane", "ZX", "--d", "200", "--f", "800", "--safe-z", "40",
        "--tool", "3", "--work-offset", "G59.1"},
       Plane::ZX,
       100,
       {0, 0, 0},
       {800},
       {CCW, CW},
       180,
       270,
       20},
      {"encoder_zx_partial_safe",
       {"--plane", "ZX", "--d", "100", "--f", "500", "--arc", "140", "--clearance", "-10"},
       Plane::ZX,
       50,
       {0, 0, 0},
       {500},
       {CCW, CW},
       120,
       300},
  };
}

}  // namespace

std::vector<Variant> variants() {
  std::vector<Variant> all = encoder_variants();
  for (Variant& v : instrument_variants()) all.push_back(std::move(v));
  return all;
}

// The value of an option in the variant's arguments, if given.
std::optional<std::string> arg(const Variant& v, const std::string& name) {
  for (std::size_t i = 0; i + 1 < v.args.size(); ++i)
    if (v.args[i] == name) return v.args[i + 1];
  return std::nullopt;
}

bool is_ballbar(const Variant& v) {
  return arg(v, "--instrument") == "ballbar";
}

// The ballbar's feed-in in program units: 1.5 mm unless --feed-in says otherwise.
double feed_in(const Variant& v) {
  if (!is_ballbar(v)) return 0.0;
  if (const auto f = arg(v, "--feed-in")) return std::stod(*f);
  return v.units == "mm" ? 1.5 : 1.5 / 25.4;
}

// --approach-feed, or min(200 mm/min, half the lowest feed), in program units.
double approach_feed(const Variant& v) {
  if (const auto f = arg(v, "--approach-feed")) return std::stod(*f);
  const double per_mm = v.units == "mm" ? 1.0 : 1.0 / 25.4;
  return std::min(200.0 * per_mm, *std::min_element(v.feeds.begin(), v.feeds.end()) / 2.0);
}

// --clearance (or --safe-z) in program units; a ballbar's default 50 mm beyond the centre.
std::optional<double> clearance(const Variant& v) {
  for (const char* name : {"--clearance", "--safe-z"})
    if (const auto c = arg(v, name)) return std::stod(*c);
  if (!is_ballbar(v)) return std::nullopt;
  const int n = plane_axes(v.plane).normal - 'x';
  return v.centre[n] + (v.units == "mm" ? 50.0 : 50.0 / 25.4);
}

double wrap360(double deg) {
  double r = std::fmod(deg, 360.0);
  if (r < 0) r += 360.0;
  return r;
}

double angle_diff(double a, double b) {
  const double d = wrap360(a - b);
  return std::min(d, 360.0 - d);
}

bool moved(double from, double to) {
  return std::abs(to - from) > 1e-9;
}

}  // namespace circtest::testing
