#include "machine_sim.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include "circtest/core/trace_keys.hpp"

namespace circtest::sim {

namespace {

struct AxisState {
  double motor = 0.0;
  double table = 0.0;       // screw side, after the backlash play
  double direction = 0.0;   // sign of the motor's last motion
  double spike = 0.0;       // friction error not yet removed by the servo
  double motor_prev = 0.0;  // motor position one period before `before`
  bool initialised = false;
};

int axis_index(char letter) {
  return letter - 'x';
}

}  // namespace

Trace simulate(const MachineModel& machine, const CircleProgram& program) {
  const PlaneAxes axes = plane_axes(program.plane);
  const int ia = axis_index(axes.first);
  const int ib = axis_index(axes.second);
  const AxisModel* models[3] = {&machine.x, &machine.y, &machine.z};
  const double T = program.period_s;
  const double R = program.radius_mm;
  const double deg = std::numbers::pi / 180.0;

  Trace trace;
  trace.source = "<simulated>";
  trace.metadata.set(meta_key::plane, std::string(plane_name(program.plane)));
  trace.metadata.set(meta_key::radius_mm, fmt::format("{}", R));
  trace.metadata.set(meta_key::centre_mm, fmt::format("{},{},{}", program.centre_mm[0],
                                                      program.centre_mm[1], program.centre_mm[2]));
  if (program.run_feeds_mm_per_min.empty()) {
    trace.metadata.set(meta_key::feed_mm_per_min, fmt::format("{}", program.feed_mm_per_min));
  } else {
    trace.metadata.set(meta_key::feeds_mm_per_min,
                       fmt::format("{}", fmt::join(program.run_feeds_mm_per_min, ",")));
  }
  trace.metadata.set(meta_key::sample_period_s, fmt::format("{}", T));
  trace.columns = {column_name::t,
                   column_name::x,
                   column_name::y,
                   column_name::z,
                   column_name::commanded('x'),
                   column_name::commanded('y'),
                   column_name::commanded('z'),
                   column_name::marker,
                   column_name::segment};
  if (program.radial) trace.columns.push_back(column_name::r);
  if (program.radial && program.bar_length_mm) {
    trace.metadata.set(meta_key::bar_length_mm, fmt::format("{}", *program.bar_length_mm));
  }
  trace.values.assign(trace.columns.size(), {});

  std::mt19937_64 rng(machine.seed);
  std::normal_distribution<double> noise(0.0, machine.noise_mm > 0 ? machine.noise_mm : 1.0);
  AxisState state[3];
  std::size_t k = 0;

  auto emit = [&](const double cmd[3], double marker, double segment) {
    double table[3];
    for (int i = 0; i < 3; ++i) {
      const AxisModel& m = *models[i];
      AxisState& s = state[i];
      if (!s.initialised) {
        s.motor = cmd[i];
        s.table = cmd[i];
        s.motor_prev = cmd[i];
        s.initialised = true;
      }
      const double before = s.motor;
      if (m.kv_per_s > 0.0) {
        s.motor += (1.0 - std::exp(-m.kv_per_s * T)) * (cmd[i] - s.motor);
      } else {
        s.motor = cmd[i];
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
      double p = (s.table + s.spike) * (1.0 + m.scale);
      if (m.cyclic_pitch_mm > 0.0) {
        p += m.cyclic_amplitude_mm *
             std::sin(2.0 * std::numbers::pi * s.table / m.cyclic_pitch_mm + m.cyclic_phase_rad);
      }
      table[i] = p;
    }
    table[ia] += machine.squareness_rad * table[ib];
    if (machine.noise_mm > 0.0) {
      for (double& v : table) v += noise(rng);
    }
    const double row[9] = {static_cast<double>(k) * T,
                           table[0],
                           table[1],
                           table[2],
                           cmd[0],
                           cmd[1],
                           cmd[2],
                           marker,
                           segment};
    for (std::size_t c = 0; c < 9; ++c) trace.values[c].push_back(row[c]);
    if (program.radial) {
      const double length =
          std::hypot(table[0] - program.centre_mm[0], table[1] - program.centre_mm[1],
                     table[2] - program.centre_mm[2]);
      trace.values[9].push_back(length - program.bar_length_mm.value_or(0.0));
    }
    trace.line_of_row.push_back(static_cast<std::uint32_t>(k + 2));
    ++k;
  };

  auto point = [&](double angle_rad, double out[3]) {
    out[0] = program.centre_mm[0];
    out[1] = program.centre_mm[1];
    out[2] = program.centre_mm[2];
    out[ia] += R * std::cos(angle_rad);
    out[ib] += R * std::sin(angle_rad);
  };

  auto dwell = [&](double angle_rad) {
    double cmd[3];
    point(angle_rad, cmd);
    const auto n = static_cast<std::size_t>(std::llround(program.dwell_s / T));
    for (std::size_t i = 0; i < n; ++i) emit(cmd, 0.0, 0.0);
  };

  const double start = program.start_deg * deg;
  const double lead = program.lead_deg * deg;
  const double arc = program.arc_deg * deg;
  int segment = 0;
  double angle = start;
  for (std::size_t run = 0; run < program.runs.size(); ++run) {
    const Direction dir = program.runs[run];
    const double feed = run < program.run_feeds_mm_per_min.size()
                            ? program.run_feeds_mm_per_min[run]
                            : program.feed_mm_per_min;
    const double omega = feed / 60.0 / R;  // rad/s
    const double sign = dir == Direction::CCW ? 1.0 : -1.0;
    // Each run starts at the measured arc's start, reached by its lead-in on the circle.
    const double run_start = dir == Direction::CCW ? start : start + arc;
    const double lead_start = run_start - sign * lead;
    angle = lead_start;
    dwell(angle);
    ++segment;
    const double total = 2.0 * lead + arc;
    const double steps = total / (omega * T);
    const auto n = static_cast<std::size_t>(std::ceil(steps));
    for (std::size_t i = 0; i <= n; ++i) {
      const double s = std::min(static_cast<double>(i) * omega * T, total);
      angle = lead_start + sign * s;
      const bool measured = s >= lead && s <= lead + arc;
      double cmd[3];
      point(angle, cmd);
      emit(cmd, measured ? 1.0 : 0.0, segment);
    }
  }
  dwell(angle);
  return trace;
}

}  // namespace circtest::sim
