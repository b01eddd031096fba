#include "machine_sim.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>

#include "circtest/core/trace_keys.hpp"

namespace circtest::sim {

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

struct AxisState {
  double motor = 0.0;
  double table = 0.0;       // screw side, after the backlash play
  double direction = 0.0;   // sign of the motor's last motion
  double spike = 0.0;       // friction error not yet removed by the servo
  double motor_prev = 0.0;  // motor position one period before `before`
  double velocity = 0.0;    // the motor's, with a drive (AxisModel::drive_tau_s)
  double cmd_prev = 0.0;    // the last period's command, with a drive
  double feedback = 0.0;    // what the motor encoder reads after the last step
  bool initialised = false;
};

int axis_index(char letter) {
  return letter - 'x';
}

// One axis's measured position after a servo period toward CMD: the position loop, the
// reversal spike, the backlash play, the scale and the cyclic error.
double step_axis(const AxisModel& m, AxisState& s, double cmd, double T) {
  if (!s.initialised) {
    s.motor = cmd;
    s.table = cmd;
    s.motor_prev = cmd;
    s.cmd_prev = cmd;
    s.initialised = true;
  }
  const double before = s.motor;
  if (m.kv_per_s > 0.0 && m.drive_tau_s > 0.0) {
    // pid with error-previous-target: last period's command against the motor, plus the
    // command's velocity times FF1; the motor's velocity follows it with the drive's time
    // constant (semi-implicit Euler, as circdrive steps).
    const double u = m.kv_per_s * (s.cmd_prev - s.motor) + m.ff1 * (cmd - s.cmd_prev) / T;
    s.velocity += (u - s.velocity) * std::min(1.0, T / m.drive_tau_s);
    s.motor += s.velocity * T;
  } else if (m.kv_per_s > 0.0) {
    s.motor += (1.0 - std::exp(-m.kv_per_s * T)) * (cmd - s.motor);
  } else {
    s.motor = cmd;
  }
  if (m.spike_mm != 0.0 && m.spike_ms > 0.0) {
    s.spike *= std::exp(-T / (m.spike_ms * 1e-3));
    const double v = s.motor - before;
    if (std::abs(v) > 1e-12) {
      const double dir = v > 0 ? 1.0 : -1.0;
      if (s.direction != 0.0 && dir != s.direction) {
        // The reversal instant within the last two periods: the vertex of the parabola
        // through the last three motor positions (s = 0 at `before`).
        const double b1 = 0.5 * (s.motor - s.motor_prev);
        const double a2 = 0.5 * (s.motor_prev - 2.0 * before + s.motor);
        const double vertex = a2 != 0.0 ? std::clamp(-b1 / (2.0 * a2), -1.0, 1.0) : 0.0;
        const double elapsed = (1.0 - vertex) * T;
        s.spike += -m.spike_mm * dir * std::exp(-elapsed / (m.spike_ms * 1e-3));
      }
      s.direction = dir;
    }
  }
  const double half = 0.5 * m.backlash_mm;
  if (s.motor - s.table > half) s.table = s.motor - half;
  if (s.motor - s.table < -half) s.table = s.motor + half;
  s.motor_prev = before;
  s.cmd_prev = cmd;
  s.feedback = s.motor + s.spike;
  double p = (s.table + s.spike) * (1.0 + m.scale);
  if (m.cyclic_pitch_mm > 0.0) {
    p += m.cyclic_amplitude_mm *
         std::sin(2.0 * std::numbers::pi * s.table / m.cyclic_pitch_mm + m.cyclic_phase_rad);
  }
  return p;
}

// The machine sampled every period: each emitted command becomes one trace row.
class Simulator {
 public:
  Simulator(const MachineModel& machine, Plane plane, double period_s, const CircleProgram& radial)
      : machine_(machine),
        plane_(plane_axes(plane)),
        T_(period_s),
        radial_(radial),
        rng_(machine.seed),
        noise_(0.0, machine.noise_mm > 0 ? machine.noise_mm : 1.0) {}

  Trace& trace() { return trace_; }
  double period() const { return T_; }

  void columns() {
    trace_.columns = {column_name::t,
                      column_name::x,
                      column_name::y,
                      column_name::z,
                      column_name::commanded('x'),
                      column_name::commanded('y'),
                      column_name::commanded('z'),
                      column_name::marker,
                      column_name::segment};
    if (radial_.radial) trace_.columns.push_back(column_name::r);
    if (radial_.feedback_columns) {
      fb_column_ = trace_.columns.size();
      for (char a : {'x', 'y', 'z'}) trace_.columns.push_back(column_name::feedback(a));
    }
    if (radial_.radial && radial_.bar_length_mm) {
      trace_.metadata.set(meta_key::bar_length_mm, fmt::format("{}", *radial_.bar_length_mm));
    }
    trace_.values.assign(trace_.columns.size(), {});
  }

  void emit(const double cmd[3], double marker, double segment) {
    const AxisModel* models[3] = {&machine_.x, &machine_.y, &machine_.z};
    double table[3];
    for (int i = 0; i < 3; ++i) table[i] = step_axis(*models[i], state_[i], cmd[i], T_);
    table[axis_index(plane_.first)] += machine_.squareness_rad * table[axis_index(plane_.second)];
    skew(table);
    if (machine_.noise_mm > 0.0) {
      for (double& v : table) v += noise_(rng_);
    }
    const double row[9] = {static_cast<double>(k_) * T_,
                           table[0],
                           table[1],
                           table[2],
                           cmd[0],
                           cmd[1],
                           cmd[2],
                           marker,
                           segment};
    for (std::size_t c = 0; c < 9; ++c) trace_.values[c].push_back(row[c]);
    if (radial_.radial) {
      const double length =
          std::hypot(table[0] - radial_.centre_mm[0], table[1] - radial_.centre_mm[1],
                     table[2] - radial_.centre_mm[2]);
      trace_.values[9].push_back(length - radial_.bar_length_mm.value_or(0.0));
    }
    if (fb_column_ > 0) {
      for (std::size_t i = 0; i < 3; ++i)
        trace_.values[fb_column_ + i].push_back(state_[i].feedback);
    }
    trace_.line_of_row.push_back(static_cast<std::uint32_t>(k_ + 2));
    ++k_;
  }

  // At rest at CMD for DURATION_S.
  void dwell(const double cmd[3], double duration_s) {
    const auto n = static_cast<std::size_t>(std::llround(duration_s / T_));
    for (std::size_t i = 0; i < n; ++i) emit(cmd, 0.0, 0.0);
  }

  // A straight move from FROM to TO at FEED (marker and segment 0).
  void move(const double from[3], const double to[3], double feed_mm_per_min) {
    const double length = std::hypot(to[0] - from[0], to[1] - from[1], to[2] - from[2]);
    const auto n = static_cast<std::size_t>(std::ceil(length / (feed_mm_per_min / 60.0 * T_)));
    for (std::size_t i = 1; i <= n; ++i) {
      const double f = static_cast<double>(i) / static_cast<double>(n);
      const double cmd[3] = {from[0] + f * (to[0] - from[0]), from[1] + f * (to[1] - from[1]),
                             from[2] + f * (to[2] - from[2])};
      emit(cmd, 0.0, 0.0);
    }
  }

 private:
  // The three squarenesses of the set, each from the slide positions before any of them, as
  // circtest_kins' forward kinematics has them.
  void skew(double table[3]) const {
    if (machine_.squareness_xy_rad == 0.0 && machine_.squareness_yz_rad == 0.0 &&
        machine_.squareness_zx_rad == 0.0) {
      return;
    }
    const double x = table[0], y = table[1], z = table[2];
    table[0] = x + machine_.squareness_xy_rad * y;
    table[1] = y + machine_.squareness_yz_rad * z;
    table[2] = z + machine_.squareness_zx_rad * x;
  }

  const MachineModel& machine_;
  PlaneAxes plane_;
  double T_;
  const CircleProgram& radial_;
  Trace trace_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> noise_;
  AxisState state_[3];
  std::size_t k_ = 0;
  std::size_t fb_column_ = 0;
};

// The commanded point at ANGLE_RAD on the program's circle.
void circle_point(const CircleProgram& program, double angle_rad, double out[3]) {
  const PlaneAxes axes = plane_axes(program.plane);
  out[0] = program.centre_mm[0];
  out[1] = program.centre_mm[1];
  out[2] = program.centre_mm[2];
  out[axis_index(axes.first)] += program.radius_mm * std::cos(angle_rad);
  out[axis_index(axes.second)] += program.radius_mm * std::sin(angle_rad);
}

double run_feed(const CircleProgram& program, std::size_t run) {
  return run < program.run_feeds_mm_per_min.size() ? program.run_feeds_mm_per_min[run]
                                                   : program.feed_mm_per_min;
}

// The angle where run RUN's lead-in starts.
double lead_start_rad(const CircleProgram& program, std::size_t run) {
  const double sign = program.runs[run] == Direction::CCW ? 1.0 : -1.0;
  const double start = program.start_deg * kDeg;
  const double run_start =
      program.runs[run] == Direction::CCW ? start : start + program.arc_deg * kDeg;
  return run_start - sign * program.lead_deg * kDeg;
}

// The program's runs, each after a dwell at its lead-in's start, numbered from SEGMENT + 1;
// returns the last commanded angle.
double run_circle(Simulator& sim, const CircleProgram& program, int& segment) {
  const double R = program.radius_mm, T = sim.period();
  const double lead = program.lead_deg * kDeg, arc = program.arc_deg * kDeg;
  double angle = program.start_deg * kDeg;
  for (std::size_t run = 0; run < program.runs.size(); ++run) {
    const double omega = run_feed(program, run) / 60.0 / R;  // rad/s
    const double sign = program.runs[run] == Direction::CCW ? 1.0 : -1.0;
    const double lead_start = lead_start_rad(program, run);
    angle = lead_start;
    double cmd[3];
    circle_point(program, angle, cmd);
    sim.dwell(cmd, program.dwell_s);
    ++segment;
    const double total = 2.0 * lead + arc;
    const auto n = static_cast<std::size_t>(std::ceil(total / (omega * T)));
    for (std::size_t i = 0; i <= n; ++i) {
      const double s = std::min(static_cast<double>(i) * omega * T, total);
      angle = lead_start + sign * s;
      const bool measured = s >= lead && s <= lead + arc;
      circle_point(program, angle, cmd);
      sim.emit(cmd, measured ? 1.0 : 0.0, segment);
    }
  }
  return angle;
}

void circle_metadata(TraceMetadata& meta, const CircleProgram& program) {
  meta.set(meta_key::radius_mm, fmt::format("{}", program.radius_mm));
  meta.set(meta_key::centre_mm, fmt::format("{},{},{}", program.centre_mm[0], program.centre_mm[1],
                                            program.centre_mm[2]));
  meta.set(meta_key::sample_period_s, fmt::format("{}", program.period_s));
}

}  // namespace

Trace simulate(const MachineModel& machine, const CircleProgram& program) {
  Simulator sim(machine, program.plane, program.period_s, program);
  Trace& trace = sim.trace();
  trace.source = "<simulated>";
  trace.metadata.set(meta_key::plane, std::string(plane_name(program.plane)));
  trace.metadata.set(meta_key::radius_mm, fmt::format("{}", program.radius_mm));
  trace.metadata.set(meta_key::centre_mm, fmt::format("{},{},{}", program.centre_mm[0],
                                                      program.centre_mm[1], program.centre_mm[2]));
  if (program.run_feeds_mm_per_min.empty()) {
    trace.metadata.set(meta_key::feed_mm_per_min, fmt::format("{}", program.feed_mm_per_min));
  } else {
    trace.metadata.set(meta_key::feeds_mm_per_min,
                       fmt::format("{}", fmt::join(program.run_feeds_mm_per_min, ",")));
  }
  trace.metadata.set(meta_key::sample_period_s, fmt::format("{}", program.period_s));
  sim.columns();
  int segment = 0;
  const double angle = run_circle(sim, program, segment);
  double cmd[3];
  circle_point(program, angle, cmd);
  sim.dwell(cmd, program.dwell_s);
  return std::move(trace);
}

Trace simulate_set(const MachineModel& machine, const TestSetProgram& set) {
  if (set.planes.empty()) throw std::invalid_argument("simulate_set: no plane");
  const CircleProgram& first = set.planes.front();
  for (const CircleProgram& p : set.planes) {
    if (p.radius_mm != first.radius_mm || p.period_s != first.period_s ||
        !std::equal(p.centre_mm, p.centre_mm + 3, first.centre_mm)) {
      throw std::invalid_argument("simulate_set: the planes share one circle and period");
    }
  }
  Simulator sim(machine, first.plane, first.period_s, first);
  Trace& trace = sim.trace();
  trace.source = "<simulated set>";
  std::vector<std::string> planes, segments, feeds;
  for (const CircleProgram& p : set.planes) {
    planes.emplace_back(plane_name(p.plane));
    for (std::size_t run = 0; run < p.runs.size(); ++run) {
      const std::string f = fmt::format("{}", run_feed(p, run));
      segments.push_back(fmt::format("{}:{}:F{}:{}", segments.size() + 1,
                                     direction_name(p.runs[run]), f, plane_name(p.plane)));
      if (std::find(feeds.begin(), feeds.end(), f) == feeds.end()) feeds.push_back(f);
    }
  }
  trace.metadata.set(meta_key::plane, fmt::format("{}", fmt::join(planes, ",")));
  circle_metadata(trace.metadata, first);
  trace.metadata.set(meta_key::feeds_mm_per_min, fmt::format("{}", fmt::join(feeds, ",")));
  trace.metadata.set(meta_key::segments, fmt::format("{}", fmt::join(segments, ",")));
  sim.columns();
  int segment = 0;
  double here[3];
  circle_point(first, lead_start_rad(first, 0), here);
  for (const CircleProgram& p : set.planes) {
    // To the plane's first lead-in, then the operator's pause to re-orient the instrument.
    double next[3];
    circle_point(p, lead_start_rad(p, 0), next);
    sim.move(here, next, set.approach_feed_mm_per_min);
    sim.dwell(next, set.pause_s);
    circle_point(p, run_circle(sim, p, segment), here);
  }
  sim.dwell(here, first.dwell_s);
  return std::move(trace);
}

}  // namespace circtest::sim
