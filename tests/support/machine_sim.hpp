#pragma once
// A machine simulator for tests: the commanded circle of an ISO 230-4 program through a
// per-axis model (first-order position loop, backlash play, reversal spike, scale, cyclic
// error) and the
// squareness of the first plane axis to the second, sampled every period like circlog.
// Its injected errors are the independent truth the analysis is checked against.
#include <cstdint>
#include <optional>
#include <vector>

#include "circtest/core/plane.hpp"
#include "circtest/core/trace.hpp"

namespace circtest::sim {

struct AxisModel {
  double kv_per_s = 0.0;  // position-loop gain; 0 = ideal (no lag)
  // A velocity-mode drive under the position loop (sim-servo's pid and circdrive without
  // friction): the velocity command kv e + ff1 v_cmd, followed by the motor with the time
  // constant drive_tau_s. 0: the first-order loop above (the motor follows kv e at once).
  double drive_tau_s = 0.0;
  double ff1 = 0.0;          // velocity feed-forward (1 cancels the lag), with drive_tau_s only
  double backlash_mm = 0.0;  // play between motor and table
  double scale = 0.0;        // relative scale error: table = motor * (1 + scale)
  double cyclic_amplitude_mm = 0.0;  // waviness tied to axis position
  double cyclic_pitch_mm = 0.0;
  double cyclic_phase_rad = 0.0;
  // Reversal spike: Coulomb friction reverses with the motor's direction; a stiff servo first
  // takes the new friction force as a position error (the table stays behind by spike_mm in
  // the old direction), then its integral action removes it with the time constant spike_ms.
  // table += -spike_mm * sign(v_new) * exp(-(t - t_reversal) / spike_ms), superposed.
  double spike_mm = 0.0;
  double spike_ms = 0.0;
};

struct MachineModel {
  AxisModel x, y, z;
  // Squareness of the plane's first axis to its second: a_actual = a + squareness * b.
  double squareness_rad = 0.0;
  // The three squarenesses of a test set, as circtest_kins and configs/sim-mill have them
  // (each from the slide positions): x += xy * y, y += yz * z, z += zx * x. Added to the
  // plane's squareness_rad above.
  double squareness_xy_rad = 0.0;
  double squareness_yz_rad = 0.0;
  double squareness_zx_rad = 0.0;
  double noise_mm = 0.0;  // Gaussian noise on the measured positions (standard deviation)
  std::uint64_t seed = 1;
};

struct CircleProgram {
  Plane plane = Plane::XY;
  double radius_mm = 75.0;
  double centre_mm[3] = {0.0, 0.0, 0.0};  // x, y, z
  double feed_mm_per_min = 1000.0;
  // Feed of each run (same length as `runs`), for feed sweeps; empty: feed_mm_per_min.
  std::vector<double> run_feeds_mm_per_min;
  std::vector<Direction> runs = {Direction::CCW, Direction::CW};
  double arc_deg = 360.0;
  double start_deg = 0.0;
  double lead_deg = 30.0;  // lead-in and lead-out arcs on the same circle, marker off
  double dwell_s = 0.2;    // at rest before the first run and between runs
  double period_s = 0.001;
  // A ball bar between the nominal centre (its pivot) and the tool: adds a column `r`, the
  // 3-D distance from the centre to the measured position; with bar_length_mm set, its
  // change from that length instead (and a bar_length_mm metadata line).
  bool radial = false;
  std::optional<double> bar_length_mm;
  // Adds the motor feedback columns x_fb, y_fb, z_fb (the motor and the friction spike, which
  // the encoder sees; no play, scale, squareness or cyclic error).
  bool feedback_columns = false;
};

// A test set: the planes' circles one after another in one trace, as circgen's set program
// runs them (all on one circle centre and radius, one period).
struct TestSetProgram {
  std::vector<CircleProgram> planes;
  double pause_s = 0.5;  // at rest at each plane's first point: the operator's pause
  double approach_feed_mm_per_min = 3000.0;  // the straight move to each plane's first point
};

// Columns: t, x, y, z (measured), x_cmd, y_cmd, z_cmd, marker, segment (1, 2, ... per run),
// r with `radial`, x_fb, y_fb, z_fb with `feedback_columns`.
// Metadata: plane, radius, centre, feed.
Trace simulate(const MachineModel& machine, const CircleProgram& program);

// The set's trace: the same columns, segments numbered 1..N over all planes. Metadata: plane
// (the planes in order, "XY,YZ,ZX"), radius, centre, feeds_mm_per_min and segments
// ("id:DIR:Ffeed:PLANE"), as circgen's set program and circlog-record write them. Throws
// std::invalid_argument for planes with different circles or periods.
Trace simulate_set(const MachineModel& machine, const TestSetProgram& set);

}  // namespace circtest::sim
